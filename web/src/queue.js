// The queue: the running scan and the waiting ones (queued, paused, interrupted) with their actions,
// and the submit form, whose API errors are shown at the field they name.
import { useState } from 'preact/hooks';
import { html, Field, setter } from './ui.js';
import { describeError } from './logic/format.js';
import { can, scanActions } from './logic/roles.js';
import { submitFieldOf, submitParams } from './logic/submit.js';

const FIELDS = ['sample', 'name', 'grids', 'geometries', 'wavelengths', 'repeats', 'reference', 'priority',
  'adaptive', 'model', 'target_rel_u', 'tolerance', 'max_points'];

// Errors of a failed scan.submit split into the one of a form field (an adaptive plan's keys
// have fields of their own: "adaptive.model" → model) and the rest.
function submitErrors(err) {
  const d = describeError(err);
  const f = submitFieldOf(d.path);
  return f && FIELDS.includes(f) ? { [f]: d.message } : { _form: d.message };
}

export function SubmitForm({ samples, call, onSubmitted }) {
  const [form, setForm] = useState({ sample: '', name: '', grids: 'in=45;out=-30:80:2', wavelengths: '400:700:10', repeats: '1', reference: 'every_point', interval: '10', priority: '0',
    adaptive: 'off', model: '', target_rel_u: '0.02', tolerance: '0.01', max_points: '40' });
  const [errors, setErrors] = useState({});
  const [busy, setBusy] = useState(false);
  const set = setter(setForm);
  const sample = form.sample || (samples[0] ? String(samples[0].id) : '');
  const submit = async (e) => {
    e.preventDefault();
    setBusy(true);
    setErrors({}); // the last attempt's errors go: this one's answer brings its own
    try {
      const scan = await call('scan.submit', submitParams({ ...form, sample }));
      onSubmitted(scan);
    } catch (err) {
      const fe = submitErrors(err);
      if (fe.geometries) fe.grids = fe.geometries; // the form has one field for both
      setErrors(fe);
    }
    setBusy(false);
  };
  const input = (k, type = 'text', extra = {}) => (id, describedby) =>
    html`<input id=${id} name=${k} type=${type} value=${form[k]} onInput=${set(k)} aria-invalid=${errors[k] ? 'true' : 'false'} aria-describedby=${describedby} ...${extra} />`;
  return html`<form class="submit" data-testid="scan-submit" onSubmit=${submit} aria-label="Submit a scan" novalidate>
    <${Field} name="sample" label="Sample" error=${errors.sample}>${(id) => html`
      <select id=${id} name="sample" value=${sample} onChange=${set('sample')}>
        ${samples.map((s) => html`<option value=${String(s.id)}>${s.name}${s.bsdf ? '' : ' (no twin)'}</option>`)}
      </select>`}<//>
    <${Field} name="name" label="Label" error=${errors.name}>${input('name')}<//>
    <${Field} name="grids" label="Geometry grid" error=${errors.grids} hint="in=45;out=-30:80:2 (one per line)">${(id, d) => html`
      <textarea id=${id} name="grids" rows="2" value=${form.grids} onInput=${set('grids')} aria-invalid=${errors.grids ? 'true' : 'false'} aria-describedby=${d}></textarea>`}<//>
    <${Field} name="wavelengths" label="Wavelengths (nm)" error=${errors.wavelengths}>${input('wavelengths')}<//>
    <div class="row">
      <${Field} name="repeats" label="Repeats" error=${errors.repeats}>${input('repeats', 'number', { min: 1, max: 100 })}<//>
      <${Field} name="priority" label="Priority" error=${errors.priority}>${input('priority', 'number', { min: -100, max: 100 })}<//>
    </div>
    <div class="row">
      <${Field} name="reference" label="Reference white" error=${errors.reference}>${(id) => html`
        <select id=${id} name="reference" value=${form.reference} onChange=${set('reference')}>
          <option value="every_point">every point</option>
          <option value="interval">every n points</option>
          <option value="start">once at the start</option>
        </select>`}<//>
      ${form.reference === 'interval' && html`<${Field} name="interval" label="n" error=${errors.interval}>${input('interval', 'number', { min: 1 })}<//>`}
    </div>
    <${Field} name="adaptive" label="Adaptive" error=${errors.adaptive} hint="the grid's geometries are candidates: the twin chooses which to measure">${(id, d) => html`
      <select id=${id} name="adaptive" value=${form.adaptive} onChange=${set('adaptive')} aria-describedby=${d}>
        <option value="off">no: measure every geometry</option>
        <option value="parameters">parameters: fit a model to a target uncertainty</option>
        <option value="curve">curve: interpolate within a tolerance</option>
      </select>`}<//>
    ${form.adaptive === 'parameters' && html`<${Field} name="model" label="Model (free parameters marked ?)" error=${errors.model} hint="e.g. conductor:alpha=?,eta=0.2,k=3.9">${input('model')}<//>`}
    ${form.adaptive !== 'off' && html`<div class="row">
      ${form.adaptive === 'parameters'
        ? html`<${Field} name="target_rel_u" label="Target u/|value|" error=${errors.target_rel_u}>${input('target_rel_u', 'text', { inputmode: 'decimal' })}<//>`
        : html`<${Field} name="tolerance" label="Tolerance (relative)" error=${errors.tolerance}>${input('tolerance', 'text', { inputmode: 'decimal' })}<//>`}
      <${Field} name="max_points" label="Points at most" error=${errors.max_points}>${input('max_points', 'number', { min: 1 })}<//>
    </div>`}
    ${errors._form && html`<div class="form-error" role="alert" data-testid="submit-error">${errors._form}</div>`}
    <button type="submit" data-testid="scan-submit-button" disabled=${busy || !sample}>Submit scan</button>
  </form>`;
}

function ScanRow({ scan, index, last, role, call, notify, onSelect, selected }) {
  const act = async (method, params) => {
    try { await call(method, params); } catch (e) { notify(`${method}: ${e.message}`); }
  };
  const actions = can(role, 'control') ? scanActions(scan.state) : [];
  const pct = scan.points_total ? Math.round((100 * scan.points_done) / scan.points_total) : 0;
  // The row's children are the same, and keyed, in every state: a reason that comes and goes
  // would otherwise shift the unkeyed spans, and Preact could take the actions' span for the
  // reason's and rebuild the buttons under the pointer (a lost click) or the focus.
  const reason = html`<span key="reason" class="muted reason" hidden=${!scan.reason}>${scan.reason || ''}</span>`;
  // Pause and Resume take turns in one slot: the button, and the keyboard focus on it, stays
  // when the scan's state flips.
  const toggle = actions.includes('pause')
    ? html`<button data-testid="scan-pause" onClick=${() => act('scan.pause', { scan: scan.id, reason: 'paused from the dashboard' })}>Pause</button>`
    : actions.includes('resume') && html`<button data-testid="scan-resume" onClick=${() => act('scan.resume', { scan: scan.id })}>Resume</button>`;
  return html`<li class=${`scan state-${scan.state}${selected ? ' selected' : ''}`} data-testid=${`queue-item-${scan.id}`} data-state=${scan.state}>
    <button class="link" onClick=${() => onSelect(scan.id)} aria-label=${`show scan ${scan.id}`}>#${scan.id} ${scan.plan && scan.plan.name ? scan.plan.name : ''}</button>
    <span class="badge">${scan.state}</span>
    <progress max="100" value=${pct} aria-label="progress"></progress>
    <span class="muted">${scan.points_done}/${scan.points_total}${scan.points_diverged ? ` · ${scan.points_diverged} diverged` : ''}</span>
    ${reason}
    <span key="actions" class="actions">
      ${toggle}
      ${actions.includes('reorder') && html`<button aria-label="earlier" data-testid="queue-up" disabled=${index === 0} onClick=${() => act('queue.reorder', { scan: scan.id, position: index - 1 })}>↑</button>
        <button aria-label="later" data-testid="queue-down" disabled=${last} onClick=${() => act('queue.reorder', { scan: scan.id, position: index + 1 })}>↓</button>`}
      ${actions.includes('cancel') && html`<button class="danger" data-testid="scan-cancel" onClick=${() => act('scan.cancel', { scan: scan.id, reason: 'cancelled from the dashboard' })}>Cancel</button>`}
    </span>
  </li>`;
}

export function QueuePanel({ queue, role, call, notify, selected, onSelect }) {
  const waiting = (queue && queue.waiting) || [];
  const running = queue && queue.running ? [queue.running] : [];
  // One keyed list: a scan that stops running and starts waiting keeps its row (and the focus).
  const rows = [...running, ...waiting], r = running.length;
  return html`<section class="panel queue-panel" aria-labelledby="h-queue">
    <h2 id="h-queue">Queue</h2>
    <ul class="queue" data-testid="queue">
      ${rows.map((s, i) => html`<${ScanRow} key=${s.id} scan=${s} index=${i < r ? 0 : i - r} last=${i < r || i === rows.length - 1} role=${role} call=${call} notify=${notify} onSelect=${onSelect} selected=${selected === s.id} />`)}
      ${rows.length === 0 && html`<li class="muted">nothing running or waiting</li>`}
    </ul>
  </section>`;
}
