// The scans' history: scan.list newest first, filtered by sample, state, submission days and
// text in the label, a page at a time. The filters live in the route ("#/scans?state=failed"),
// so a filtered list is a link too. Rows open the scan view; ticked rows are compared.
import { useEffect, useState } from 'preact/hooks';
import { html } from './ui.js';
import { MAX_COMPARE, toggleCompare } from './logic/compare.js';
import { describeError, shortTime } from './logic/format.js';
import { HISTORY_PAGE, SCAN_STATES, historyField, historyQuery } from './logic/scans.js';

const FILTERS = ['sample', 'state', 'from', 'to', 'text'];

export function ScansPanel({ params, samples, call, navigate, reloads }) {
  const [rows, setRows] = useState(null);
  const [more, setMore] = useState(false);
  const [error, setError] = useState(null);
  const [draft, setDraft] = useState(() => Object.fromEntries(FILTERS.map((k) => [k, params[k] || ''])));
  const [picked, setPicked] = useState([]);
  const page = Math.max(1, Number(params.page) || 1);
  const key = JSON.stringify(params);

  useEffect(() => { setDraft(Object.fromEntries(FILTERS.map((k) => [k, params[k] || '']))); }, [key]);
  useEffect(() => {
    let gone = false;
    setError(null);
    call('scan.list', historyQuery(params)).then((list) => {
      if (gone) return;
      setMore(list.length > HISTORY_PAGE);
      setRows(list.slice(0, HISTORY_PAGE));
    }, (e) => {
      if (gone) return;
      const d = describeError(e);
      setError({ field: historyField(d.path), message: d.message });
      setRows([]);
      setMore(false);
    });
    return () => { gone = true; };
  }, [key, reloads]);

  const sampleName = new Map(samples.map((s) => [s.id, s.name]));
  const apply = (e) => {
    e.preventDefault();
    navigate({ view: 'scans', params: { ...draft, page: '' } });
  };
  const go = (p) => navigate({ view: 'scans', params: { ...params, page: p > 1 ? String(p) : '' } });
  const set = (k) => (e) => setDraft({ ...draft, [k]: e.currentTarget.value });
  const err = (k) => error && error.field === k;
  const fieldAttrs = (k) => ({ 'aria-invalid': err(k) ? 'true' : 'false', 'aria-describedby': err(k) ? 'scans-error' : undefined });

  return html`<section class="panel" aria-labelledby="h-scans">
    <h2 id="h-scans">Scans</h2>
    <form class="filters row" data-testid="scans-filter" onSubmit=${apply} aria-label="Filter the scans">
      <label>Sample <select name="sample" value=${draft.sample} onChange=${set('sample')} ...${fieldAttrs('sample')}>
        <option value="">any</option>
        ${samples.map((s) => html`<option value=${String(s.id)}>${s.name}</option>`)}
      </select></label>
      <label>State <select name="state" value=${draft.state} onChange=${set('state')} ...${fieldAttrs('state')}>
        <option value="">any</option>
        ${SCAN_STATES.map((s) => html`<option value=${s}>${s}</option>`)}
      </select></label>
      <label>From <input type="date" name="from" value=${draft.from} onInput=${set('from')} ...${fieldAttrs('from')} /></label>
      <label>To <input type="date" name="to" value=${draft.to} onInput=${set('to')} ...${fieldAttrs('to')} /></label>
      <label>Label <input type="search" name="text" value=${draft.text} onInput=${set('text')} placeholder="text in the label" ...${fieldAttrs('text')} /></label>
      <button type="submit" data-testid="scans-apply">Filter</button>
    </form>
    ${error && html`<div class="form-error" role="alert" id="scans-error" data-testid="scans-error" data-field=${error.field || ''}>${error.field ? `${error.field}: ` : ''}${error.message}</div>`}
    <div class="scans-wrap"><table class="scans" data-testid="scans" data-page=${page} data-loaded=${rows ? 'true' : 'false'}>
      <thead><tr><th><span class="sr-only">compare</span></th><th>scan</th><th>label</th><th>sample</th><th>state</th><th>points</th><th>submitted</th><th>finished</th></tr></thead>
      <tbody>
        ${(rows || []).map((s) => html`<tr key=${s.id} data-testid="scan-row" data-scan=${s.id} data-state=${s.state}>
          <td><input type="checkbox" aria-label=${`compare scan ${s.id}`} data-testid="compare-pick" checked=${picked.includes(s.id)}
            onChange=${() => setPicked((l) => toggleCompare(l, s.id))} /></td>
          <td><a href=${`#/scan/${s.id}`} data-testid="scan-open">#${s.id}</a></td>
          <td>${s.plan && s.plan.name ? s.plan.name : html`<span class="muted">–</span>`}</td>
          <td><a href=${`#/sample/${s.plan.sample}`}>${sampleName.get(s.plan.sample) || `sample ${s.plan.sample}`}</a></td>
          <td><span class=${`badge state-${s.state}`}>${s.state}</span>${s.reason ? html` <span class="muted reason">${s.reason}</span>` : ''}</td>
          <td>${s.points_done}/${s.points_total}${s.points_diverged ? html` <span class="muted">· ${s.points_diverged} diverged</span>` : ''}</td>
          <td>${shortTime(s.submitted_at)}</td>
          <td>${shortTime(s.finished_at)}</td>
        </tr>`)}
        ${rows && rows.length === 0 && html`<tr><td colspan="8" class="muted">no scans${FILTERS.some((k) => params[k]) ? ' match these filters' : ''}</td></tr>`}
      </tbody>
    </table></div>
    <div class="row pager">
      <button data-testid="scans-prev" disabled=${page <= 1} onClick=${() => go(page - 1)}>Newer</button>
      <span class="muted" data-testid="scans-page">page ${page}</span>
      <button data-testid="scans-next" disabled=${!more} onClick=${() => go(page + 1)}>Older</button>
      <button data-testid="compare-open" disabled=${picked.length < 2}
        onClick=${() => navigate({ view: 'compare', ids: picked, params: {} })}>Compare ${picked.length || ''} (at most ${MAX_COMPARE})</button>
    </div>
  </section>`;
}
