// A scan: measured β ± u and twin β ± s.e. against θr at a chosen wavelength, points drawn as
// they are committed (at most one redraw per animation frame), the divergence lane, a
// clicked point's spectra and colours, and the exports.
import { useEffect, useMemo, useRef, useState } from 'preact/hooks';
import { html, download } from './ui.js';
import { Curve, channelOf, coalesce, exportFile, fmt, incidences } from './logic.js';
import { betaPlot, betaData, lanePlot, laneData, spectrumPlot } from './plot.js';
import { colourOf } from './colour.js';
import tables from 'virtual:colour-tables';

// Draws into the two plots, coalescing the points that arrive between frames.
class LivePlots {
  constructor() { this.beta = null; this.lane = null; this.pending = false; this.frames = 0; }
  schedule(curve, log, countEl) {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      if (this.beta) this.beta.setData(betaData(curve, log));
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

function PointDetails({ point }) {
  const ref = useRef(null);
  useEffect(() => {
    const u = spectrumPlot(ref.current, point, { width: Math.max(280, ref.current.clientWidth || 420), height: 200 });
    return () => u.destroy();
  }, [point]);
  const m = colourOf(point.measured.wavelengths_nm, point.measured.values, tables);
  const p = point.predicted ? colourOf(point.predicted.wavelengths_nm, point.predicted.values, tables) : null;
  const g = point.planned;
  return html`<div class="point-details" data-testid="point-details">
    <h3>Point ${point.index}: θi ${fmt(g.theta_i, 3)}°, θr ${fmt(g.theta_r, 3)}° · max |z| ${fmt(point.z_max, 3)} · ΔE00 ${fmt(point.delta_e00, 3)}${point.diverged ? ' · diverged' : ''}</h3>
    <div class="plot" ref=${ref}></div>
    <div class="swatches"><${Swatch} label="measured" c=${m} />${p && html`<${Swatch} label="twin" c=${p} />`}</div>
    <p class="muted">CIELAB: D65, 10° observer (as the ΔE00 figures)</p>
  </div>`;
}

export function ScanPanel({ scanId, call, bus, thresholds, notify }) {
  const [scan, setScan] = useState(null);
  const [nm, setNm] = useState(550);
  const [thetaI, setThetaI] = useState(null);
  const [log, setLog] = useState(false);
  const [picked, setPicked] = useState(null);
  const [version, setVersion] = useState(0); // bumps when the point set is reloaded
  const store = useRef({ points: new Map() });
  const live = useRef(new LivePlots());
  const betaEl = useRef(null), laneEl = useRef(null), hostEl = useRef(null);

  // Load the scan and its stored points; then take points from the bus.
  useEffect(() => {
    if (!scanId) return undefined;
    let gone = false;
    const points = new Map();
    store.current = { points };
    setPicked(null);
    const take = (p) => {
      if (p.scan_id !== scanId || points.has(p.index)) return;
      points.set(p.index, p);
      if (store.current.curve && store.current.curve.add(p)) live.current.schedule(store.current.curve, store.current.log, hostEl.current);
    };
    const off = bus.on('scan.point', take);
    (async () => {
      try {
        const s = await call('scan.get', { scan: scanId });
        if (gone) return;
        setScan(s);
        const wl = s.plan.wavelengths;
        setNm((cur) => wl[channelOf(wl, cur)]);
        let offset = 0;
        for (;;) {
          const page = await call('scan.points', { scan: scanId, offset, limit: 1000 });
          if (gone) return;
          for (const p of page.points) if (!points.has(p.index)) points.set(p.index, p);
          if (page.next_offset == null || page.points.length === 0) break;
          offset = page.next_offset;
        }
        setThetaI(incidences([...points.values()])[0] ?? null);
        setVersion((v) => v + 1);
      } catch (e) { if (!gone) notify(`scan ${scanId}: ${e.message}`); }
    })();
    const progress = coalesce((p) => setScan((s) => (s ? { ...s, state: p.state, points_done: p.points_done, points_total: p.points_total, points_diverged: p.points_diverged } : s)), 250);
    const offState = bus.on('scan.progress', (p) => { if (p.scan === scanId) progress(p); });
    return () => { gone = true; off(); offState(); };
  }, [scanId]);

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
    const width = Math.max(320, hostEl.current.clientWidth || 640);
    const beta = betaPlot(betaEl.current, curve, { log, width, height: 300, onPick: (i) => setPicked(store.current.points.get(i) || null) });
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
  }, [scan && scan.id, version, nm, thetaI, log, thresholds]);

  const incs = useMemo(() => incidences([...store.current.points.values()]), [version, scan && scan.points_done]);
  const exp = async (format) => {
    try {
      const f = await exportFile(call, scanId, format);
      download(f.filename, f.mediaType, f.content);
    } catch (e) { notify(`export ${format}: ${e.message}`); }
  };

  if (!scanId) return html`<section class="panel scan-panel"><h2>Scan</h2><p class="muted">Submit a scan or pick one in the queue.</p><div data-testid="scan-plot" data-points="0"></div></section>`;
  const wl = scan ? scan.plan.wavelengths : [];
  return html`<section class="panel scan-panel" aria-labelledby="h-scan">
    <h2 id="h-scan">Scan ${scanId}${scan ? ` · ${scan.state} · ${scan.points_done}/${scan.points_total} points` : ''}</h2>
    <div class="row controls">
      <label>λ <select value=${nm} onChange=${(e) => setNm(Number(e.currentTarget.value))} data-testid="plot-wavelength">
        ${wl.map((w) => html`<option value=${w}>${w} nm</option>`)}</select></label>
      ${incs.length > 1 && html`<label>θi <select value=${thetaI} onChange=${(e) => setThetaI(Number(e.currentTarget.value))}>
        ${incs.map((t) => html`<option value=${t}>${t}°</option>`)}</select></label>`}
      <label><input type="checkbox" checked=${log} onChange=${(e) => setLog(e.currentTarget.checked)} data-testid="plot-log" /> log β</label>
      <label>point <input class="point-index" type="number" min="0" value=${picked ? picked.index : ''} data-testid="point-index"
        aria-label="show the point with this index" onChange=${(e) => setPicked(store.current.points.get(Number(e.currentTarget.value)) || null)} /></label>
      <span class="exports">Export:
        ${['csv', 'json', 'bsdf', 'ssdd'].map((f) => html` <button data-testid=${`export-${f}`} onClick=${() => exp(f)}>${f}</button>`)}</span>
    </div>
    <div ref=${hostEl} data-testid="scan-plot" data-points="0" class="plots">
      <div ref=${betaEl} class="plot"></div>
      <div ref=${laneEl} class="plot lane" data-testid="divergence-lane"></div>
    </div>
    <p class="muted">Click a point (or give its index) for its spectra and colours. Thresholds: max |z| ${fmt(thresholds && thresholds.z_threshold, 3)}, ΔE00 ${fmt(thresholds && thresholds.delta_e_threshold, 3)}.</p>
    ${picked && html`<${PointDetails} point=${picked} />`}
  </section>`;
}

export { LivePlots };
