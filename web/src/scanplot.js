// A scan: measured β ± u and twin β ± s.e. against θr at a chosen wavelength, points drawn as
// they are committed (at most one redraw per animation frame), the divergence lane, a
// clicked point's spectra and colours, and the exports.
import { useEffect, useMemo, useRef, useState } from 'preact/hooks';
import { html, download } from './ui.js';
import { AdaptiveTrack, candidateMarks } from './logic/adaptive.js';
import { fmt } from './logic/format.js';
import { POINTS_PAGE, Curve, channelOf, exportFile, incidences } from './logic/points.js';
import { coalesce } from './logic/timing.js';
import { budgetRows, verdictBadge } from './logic/verdict.js';
import { betaPlot, betaData, lanePlot, laneData, spectrumPlot } from './plot.js';
import { colorOf } from './color.js';
import { AdaptivePanel } from './adaptive.js';
import tables from 'virtual:color-tables';

// Draws into the two plots, coalescing the points that arrive between frames.
class LivePlots {
  constructor() { this.beta = null; this.lane = null; this.pending = false; this.frames = 0; }
  schedule(curve, log, countEl, fitted = null) {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      if (this.beta) this.beta.setData(betaData(curve, log, fitted));
      if (this.lane) this.lane.setData(laneData(curve));
      if (countEl) countEl.dataset.points = String(curve.length);
      this.frames++;
    });
  }
}

const lab1 = (v) => (Math.abs(v) < 0.05 ? 0 : v).toFixed(1);

function Swatch({ label, c }) {
  return html`<figure class="swatch">
    <div class="chip" style=${{ background: c.hex }} title=${c.hex}></div>
    <figcaption>${label} ${c.hex}<br />L* ${lab1(c.lab[0])} a* ${lab1(c.lab[1])} b* ${lab1(c.lab[2])}${c.clipped ? html`<br /><small>outside sRGB</small>` : ''}</figcaption>
  </figure>`;
}

// A point's uncertainty budget at one channel: what each of the instrument's stated
// tolerances does to the twin's β there (GUM: u of the input, sensitivity, contribution).
function Budget({ point, nm }) {
  const wl = point.measured.wavelengths_nm;
  const c = channelOf(wl, nm);
  if (!point.budget || point.budget.length === 0 || c < 0) return html`<p class="muted" data-testid="point-budget-none">No uncertainty budget with this point (no prediction).</p>`;
  const { rows, combined } = budgetRows(point.budget, c);
  const um = point.u_model ? point.u_model[c] : null;
  return html`<table class="budget" data-testid="point-budget">
    <caption>Uncertainty budget of the twin's β at ${wl[c]} nm (k = 1)</caption>
    <thead><tr><th>input</th><th>distribution</th><th>u</th><th>sensitivity</th><th>contribution to u(β)</th></tr></thead>
    <tbody>${rows.map((r) => html`<tr data-testid="budget-row"><td>${r.component}${r.random ? html` <small class="muted">random</small>` : ''}</td><td>${r.distribution}</td>
      <td>${fmt(r.u, 3)} ${r.unit}</td><td>${fmt(r.sensitivity, 3)}</td><td>${fmt(r.contribution, 3)}</td></tr>`)}</tbody>
    <tfoot><tr><th colspan="4">combined √Σ contribution²${um != null ? ` (u_model ${fmt(um, 3)})` : ''}</th><td data-testid="budget-combined">${fmt(combined, 3)}</td></tr></tfoot>
  </table>`;
}

function PointDetails({ point, nm }) {
  const ref = useRef(null);
  useEffect(() => {
    const u = spectrumPlot(ref.current, point, { width: Math.max(280, ref.current.clientWidth || 420), height: 200 });
    return () => u.destroy();
  }, [point]);
  const m = colorOf(point.measured.wavelengths_nm, point.measured.values, tables);
  const p = point.predicted ? colorOf(point.predicted.wavelengths_nm, point.predicted.values, tables) : null;
  const g = point.planned;
  return html`<div class="point-details" data-testid="point-details">
    <h3>Point ${point.index}: θi ${fmt(g.theta_i, 3)}°, θr ${fmt(g.theta_r, 3)}° · max |z| ${fmt(point.z_max, 3)} · ΔE00 ${fmt(point.delta_e00, 3)}${point.diverged ? ' · diverged' : ''}${point.decision ? html` · <span class=${`verdict tone-${verdictBadge({ decision: point.decision }).tone}`} data-testid="point-decision">${verdictBadge({ decision: point.decision }).text}</span>` : ''}</h3>
    <div class="plot" ref=${ref}></div>
    <div class="swatches"><${Swatch} label="measured" c=${m} />${p && html`<${Swatch} label="twin" c=${p} />`}</div>
    <p class="muted">CIELAB: D65, 10° observer (as the ΔE00 figures)</p>
    <${Budget} point=${point} nm=${nm} />
  </div>`;
}

// The scan's verdict from all its points (scan.get `verdict`) as a badge.
function VerdictBadge({ verdict }) {
  const b = verdictBadge(verdict);
  const cause = verdict && verdict.cause ? ` · cause: ${verdict.cause.parameter} ${fmt(verdict.cause.value, 4)} ± ${fmt(verdict.cause.u, 2)}` : '';
  return html`<div class="verdict-row"><span class=${`verdict tone-${b.tone}`} data-testid="verdict" data-decision=${b.decision}
    title=${verdict && verdict.summary ? verdict.summary : ''}>verdict: ${b.text}</span>
    ${verdict && verdict.summary && html`<span class="muted verdict-summary">${verdict.summary}${cause}</span>`}</div>`;
}

// fitted: null, or (θi, θr, nm) → β of a fitted model, drawn over the points. onScan(scan):
// each scan.get result (its verdict and fits), for the view around the panel. An adaptive
// scan also shows its loop (adaptive.js): the status from scan.get, then from every
// scan.progress (each one kept for the uncertainty plot, none coalesced away), and its
// candidates along the β plot's θr axis.
export function ScanPanel({ scanId, call, bus, thresholds, notify, fitted = null, onScan = null, reloads = 0, empty = 'Submit a scan or pick one in the queue.' }) {
  const [scan, setScan] = useState(null);
  const [nm, setNm] = useState(550);
  const [thetaI, setThetaI] = useState(null);
  const [log, setLog] = useState(false);
  const [picked, setPicked] = useState(null);
  // What is typed in the point box until it is committed: points arriving re-render the
  // view, and a box bound to the picked point alone would lose the typing.
  const [draft, setDraft] = useState(null);
  const [version, setVersion] = useState(0); // bumps when the point set is reloaded
  const store = useRef({ points: new Map(), candidates: null, track: new AdaptiveTrack() });
  const live = useRef(new LivePlots());
  const betaEl = useRef(null), laneEl = useRef(null), hostEl = useRef(null);

  // Load the scan and its stored points; then take points from the bus.
  useEffect(() => {
    if (!scanId) return undefined;
    let gone = false;
    const points = new Map();
    const track = new AdaptiveTrack();
    store.current = { points, candidates: null, track };
    setPicked(null);
    setDraft(null);
    const take = (p) => {
      if (p.scan_id !== scanId || points.has(p.index)) return;
      points.set(p.index, p);
      if (store.current.curve && store.current.curve.add(p)) live.current.schedule(store.current.curve, store.current.log, hostEl.current, store.current.fitted);
    };
    const off = bus.on('scan.point', take);
    (async () => {
      try {
        let s = await call('scan.get', { scan: scanId });
        if (gone) return;
        if (s.plan.adaptive) {
          // The candidates: the plan's geometries, which scan.get leaves out unless asked.
          s = await call('scan.get', { scan: scanId, geometries: true });
          if (gone) return;
          store.current.candidates = s.plan.geometries || [];
          track.add(s.adaptive);
        }
        setScan(s);
        if (onScan) onScan(s);
        const wl = s.plan.wavelengths;
        setNm((cur) => wl[channelOf(wl, cur)]);
        let offset = 0;
        for (;;) {
          const page = await call('scan.points', { scan: scanId, offset, limit: POINTS_PAGE });
          if (gone) return;
          for (const p of page.points) if (!points.has(p.index)) points.set(p.index, p);
          if (page.next_offset == null || page.points.length === 0) break;
          offset = page.next_offset;
        }
        setThetaI(incidences([...points.values()])[0] ?? null);
        setVersion((v) => v + 1);
      } catch (e) { if (!gone) notify(`scan ${scanId}: ${e.message}`); }
    })();
    const progress = coalesce((p) => setScan((s) => (s ? { ...s, state: p.state, points_done: p.points_done, points_total: p.points_total, points_diverged: p.points_diverged, adaptive: track.latest ?? s.adaptive } : s)), 250);
    // The verdict firms up with every point: read again at most every 2 s while points come.
    const verdict = coalesce(() => call('scan.get', { scan: scanId }).then((s) => {
      if (gone) return;
      if (s.plan.adaptive) track.add(s.adaptive);
      setScan((cur) => (cur ? { ...cur, verdict: s.verdict, fits: s.fits, state: s.state, finished_at: s.finished_at, reason: s.reason, adaptive: track.latest ?? s.adaptive } : s));
      if (onScan) onScan(s);
    }, () => {}), 2000);
    const offState = bus.on('scan.progress', (p) => {
      if (p.scan !== scanId) return;
      if (p.adaptive) track.add(p.adaptive);
      progress(p);
      verdict();
    });
    return () => { gone = true; off(); offState(); };
  }, [scanId, reloads]);

  // (Re)build the curve and the plots for the chosen wavelength, incidence and scale.
  useEffect(() => {
    if (!scan) return undefined;
    const curve = new Curve(nm, thetaI);
    for (const p of [...store.current.points.values()].sort((a, b) => a.index - b.index)) {
      if (thetaI === null) curve.thetaI = (p.planned || p.actual).theta_i;
      curve.add(p);
    }
    if (curve.thetaI !== thetaI && thetaI === null) setThetaI(curve.thetaI);
    store.current.curve = curve;
    store.current.log = log;
    store.current.fitted = fitted;
    const width = Math.max(320, hostEl.current.clientWidth || 640);
    const marks = scan.plan.adaptive ? () => candidateMarks(store.current.candidates, [...store.current.points.values()], curve.thetaI) : null;
    const beta = betaPlot(betaEl.current, curve, { log, width, height: 300, fitted, marks, onPick: (i) => { setPicked(store.current.points.get(i) || null); setDraft(null); } });
    const lane = lanePlot(laneEl.current, curve, { zThreshold: thresholds && thresholds.z_threshold, dEThreshold: thresholds && thresholds.delta_e_threshold, width, height: 170 });
    live.current.beta = beta;
    live.current.lane = lane;
    hostEl.current.dataset.points = String(curve.length);
    const ro = typeof ResizeObserver !== 'undefined' ? new ResizeObserver(() => {
      const w = Math.max(320, hostEl.current.clientWidth);
      beta.setSize({ width: w, height: 300 });
      lane.setSize({ width: w, height: 170 });
    }) : null;
    if (ro) ro.observe(hostEl.current);
    return () => { if (ro) ro.disconnect(); beta.destroy(); lane.destroy(); live.current.beta = live.current.lane = null; };
  }, [scan && scan.id, version, nm, thetaI, log, thresholds, fitted]);

  const incs = useMemo(() => incidences([...store.current.points.values()]), [version, scan && scan.points_done]);
  const exp = async (format) => {
    try {
      const f = await exportFile(call, scanId, format);
      download(f.filename, f.mediaType, f.content);
    } catch (e) { notify(`export ${format}: ${e.message}`); }
  };

  if (!scanId) return html`<section class="panel scan-panel"><h2>Scan</h2><p class="muted">${empty}</p><div data-testid="scan-plot" data-points="0"></div></section>`;
  const wl = scan ? scan.plan.wavelengths : [];
  return html`<section class="panel scan-panel" aria-labelledby="h-scan">
    <h2 id="h-scan">Scan ${scanId}${scan ? ` · ${scan.state} · ${scan.points_done}/${scan.points_total} points` : ''}</h2>
    <div class="row controls">
      <label>λ <select value=${nm} onChange=${(e) => setNm(Number(e.currentTarget.value))} data-testid="plot-wavelength">
        ${wl.map((w) => html`<option value=${w}>${w} nm</option>`)}</select></label>
      ${incs.length > 1 && html`<label>θi <select value=${thetaI} onChange=${(e) => setThetaI(Number(e.currentTarget.value))}>
        ${incs.map((t) => html`<option value=${t}>${t}°</option>`)}</select></label>`}
      <label><input type="checkbox" checked=${log} onChange=${(e) => setLog(e.currentTarget.checked)} data-testid="plot-log" /> log β</label>
      <label>point <input class="point-index" type="number" min="0" value=${draft ?? (picked ? picked.index : '')} data-testid="point-index"
        aria-label="show the point with this index" onInput=${(e) => setDraft(e.currentTarget.value)}
        onChange=${(e) => { setPicked(store.current.points.get(Number(e.currentTarget.value)) || null); setDraft(null); }} /></label>
      <span class="exports">Export:
        ${['csv', 'json', 'bsdf', 'ssdd'].map((f) => html` <button data-testid=${`export-${f}`} onClick=${() => exp(f)}>${f}</button>`)}</span>
    </div>
    <div ref=${hostEl} data-testid="scan-plot" data-points="0" class="plots">
      <div ref=${betaEl} class="plot"></div>
      ${scan && html`<${VerdictBadge} verdict=${scan.verdict} />`}
      <div ref=${laneEl} class="plot lane" data-testid="divergence-lane"></div>
    </div>
    <p class="muted">Click a point (or give its index) for its spectra and colours. Thresholds: max |z| ${fmt(thresholds && thresholds.z_threshold, 3)}, ΔE00 ${fmt(thresholds && thresholds.delta_e_threshold, 3)}.</p>
    ${picked && html`<${PointDetails} point=${picked} nm=${nm} />`}
    ${scan && scan.plan.adaptive && html`<${AdaptivePanel} scan=${scan} status=${store.current.track.latest ?? scan.adaptive} track=${store.current.track}
      points=${[...store.current.points.values()]} candidates=${store.current.candidates} />`}
  </section>`;
}

export { LivePlots };
