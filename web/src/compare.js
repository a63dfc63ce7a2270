// Up to six scans on one plot (#/compare/4,7,9): their measured β against θr at a chosen
// wavelength and incidence — the same sample over weeks (repeatability, drift) or two samples
// against each other — and each one's difference to the first.
import { useEffect, useState } from 'preact/hooks';
import { html, PlotHost } from './ui.js';
import { MAX_COMPARE, compareColumns, diffStats } from './logic/compare.js';
import { fmt, shortTime } from './logic/format.js';
import { POINTS_PAGE, channelOf, incidences } from './logic/points.js';
import { overlayPlot, SERIES_COLORS } from './plot.js';

async function allPoints(call, scan) {
  const out = [];
  for (let offset = 0; ;) {
    const page = await call('scan.points', { scan, offset, limit: POINTS_PAGE });
    out.push(...page.points);
    if (page.next_offset == null || page.points.length === 0) return out;
    offset = page.next_offset;
  }
}

export function ComparePanel({ ids, params, samples, call, navigate, notify }) {
  const [data, setData] = useState(null); // [{scan, points}]
  const [error, setError] = useState(null);
  const key = ids.join(',');
  useEffect(() => {
    let gone = false;
    setData(null);
    setError(null);
    Promise.all(ids.map(async (id) => ({ scan: await call('scan.get', { scan: id }), points: await allPoints(call, id) })))
      .then((d) => { if (!gone) setData(d); }, (e) => { if (!gone) { setError(e.message); notify(`compare: ${e.message}`); } });
    return () => { gone = true; };
  }, [key]);

  const set = (k) => (e) => navigate({ view: 'compare', ids, params: { ...params, [k]: e.currentTarget.value } });
  if (ids.length < 2) {
    return html`<section class="panel"><h2>Compare</h2><p class="muted" data-testid="compare-empty">Tick two to ${MAX_COMPARE} scans in the <a href="#/scans">history</a> to compare them.</p></section>`;
  }
  if (error) return html`<section class="panel"><h2>Compare</h2><div class="form-error" role="alert">${error}</div></section>`;
  if (!data) return html`<section class="panel"><h2>Compare</h2><p class="muted">loading ${ids.length} scans…</p></section>`;

  const wl = data[0].scan.plan.wavelengths;
  const nm = params.nm ? wl[channelOf(wl, Number(params.nm))] : wl[channelOf(wl, 550)];
  const incs = [...new Set(data.flatMap((d) => incidences(d.points)))].sort((a, b) => a - b);
  const thetaI = params.ti !== undefined && incs.includes(Number(params.ti)) ? Number(params.ti) : incs[0] ?? null;
  const cols = compareColumns(data.map((d) => d.points), nm, thetaI);
  const name = new Map(samples.map((s) => [s.id, s.name]));
  const labels = data.map((d) => `#${d.scan.id} ${d.scan.plan.name || name.get(d.scan.plan.sample) || ''}`.trim());
  const stats = cols.diffs.map(diffStats);
  return html`<section class="panel" aria-labelledby="h-compare" data-testid="compare" data-scans=${key} data-x=${cols.x.length}>
    <h2 id="h-compare">Compare ${ids.length} scans</h2>
    <div class="row controls">
      <label>λ <select value=${nm} onChange=${set('nm')} data-testid="compare-wavelength">${wl.map((w) => html`<option value=${w}>${w} nm</option>`)}</select></label>
      ${incs.length > 1 && html`<label>θi <select value=${thetaI} onChange=${set('ti')}>${incs.map((t) => html`<option value=${t}>${t}°</option>`)}</select></label>`}
    </div>
    <div class="compare-wrap"><table class="compare-table">
      <thead><tr><th>scan</th><th>sample</th><th>submitted</th><th>state</th><th>θr in common with the first</th><th>max |Δβ|</th><th>rms Δβ</th></tr></thead>
      <tbody>${data.map((d, i) => html`<tr data-testid="compare-row" data-scan=${d.scan.id}>
        <td><span class="swatch-line" style=${{ background: SERIES_COLORS[i % SERIES_COLORS.length] }}></span> <a href=${`#/scan/${d.scan.id}`}>${labels[i]}</a></td>
        <td>${name.get(d.scan.plan.sample) || d.scan.plan.sample}</td><td>${shortTime(d.scan.submitted_at)}</td><td>${d.scan.state}</td>
        ${i === 0 ? html`<td colspan="3" class="muted">the reference</td>`
          : html`<td>${stats[i - 1].n}</td><td data-testid="compare-maxdiff">${fmt(stats[i - 1].maxAbs, 3)}</td><td>${fmt(stats[i - 1].rms, 3)}</td>`}
      </tr>`)}</tbody>
    </table></div>
    <${PlotHost} testid="compare-plot" deps=${[key, nm, thetaI]} height=${300}
      make=${(el, w, h) => overlayPlot(el, cols.x, cols.ys, labels, { width: w, height: h, ylabel: `β at ${nm} nm` })} />
    <${PlotHost} testid="compare-diff-plot" deps=${[key, nm, thetaI]} height=${200}
      make=${(el, w, h) => overlayPlot(el, cols.x, [cols.x.map(() => null), ...cols.diffs], labels, { width: w, height: h, ylabel: `β − β(#${ids[0]})`, zeroLine: true })} />
  </section>`;
}
