// uPlot wrappers: β against θr with error bars (drawn in a hook: uPlot has none), the
// divergence lane with its thresholds, and spectra against λ.
import uPlot from 'uplot';
import { logRange, spacedLabels } from './logic/axes.js';

const css = (name, fallback) => getComputedStyle(document.documentElement).getPropertyValue(name).trim() || fallback;

// Vertical bars ± err[i] around y[i] for series `si`, in the series' colour.
function errorBars(si, errCol) {
  return (u) => {
    const xs = u.data[0], ys = u.data[si], es = errCol();
    if (!es || !u.series[si].show) return;
    const ctx = u.ctx;
    ctx.save();
    ctx.strokeStyle = u.series[si].stroke();
    ctx.lineWidth = 1;
    ctx.beginPath();
    const [i0, i1] = [u.series[0].idxs ? u.series[0].idxs[0] : 0, u.series[0].idxs ? u.series[0].idxs[1] : xs.length - 1];
    for (let i = i0; i <= i1; i++) {
      const y = ys[i], e = es[i];
      if (y == null || e == null || !(e > 0)) continue;
      const x = Math.round(u.valToPos(xs[i], 'x', true));
      let lo = y - e;
      if (u.scales.y.distr === 3 && lo <= 0) lo = y / 10;
      ctx.moveTo(x, u.valToPos(y + e, 'y', true));
      ctx.lineTo(x, u.valToPos(lo, 'y', true));
    }
    ctx.stroke();
    ctx.restore();
  };
}

function hline(value, scale, color) {
  return (u) => {
    if (value == null) return;
    const y = Math.round(u.valToPos(value, scale, true));
    const ctx = u.ctx;
    ctx.save();
    ctx.strokeStyle = color;
    ctx.setLineDash([6, 4]);
    ctx.beginPath();
    ctx.moveTo(u.bbox.left, y);
    ctx.lineTo(u.bbox.left + u.bbox.width, y);
    ctx.stroke();
    ctx.restore();
  };
}

// An adaptive scan's candidates and choices along the foot of the β plot: a faint tick per
// candidate θr, a dot per reading of each measured candidate (a candidate read again stacks
// dots), the order it was first chosen in above them where there is room, and the latest
// point ringed. marks() → logic.js candidateMarks, read at every draw (points keep coming).
function candidateTicks(marks) {
  return (u) => {
    const m = marks();
    if (!m) return;
    const ctx = u.ctx, dpr = devicePixelRatio || 1;
    const bottom = u.bbox.top + u.bbox.height;
    const px = (v) => u.valToPos(v, 'x', true);
    const inside = (x) => x >= u.bbox.left - 1 && x <= u.bbox.left + u.bbox.width + 1;
    ctx.save();
    ctx.strokeStyle = css('--candidate', 'rgba(95, 107, 122, .45)');
    ctx.lineWidth = dpr;
    ctx.beginPath();
    for (const t of m.ticks) {
      const x = Math.round(px(t));
      if (!inside(x)) continue;
      ctx.moveTo(x, bottom);
      ctx.lineTo(x, bottom - 8 * dpr);
    }
    ctx.stroke();
    const chosen = css('--chosen', '#00838f'), latest = css('--latest', '#d81b60');
    const r = 2.5 * dpr, step = 6 * dpr;
    const labels = [];
    for (const c of m.chosen) {
      const x = px(c.thetaR);
      if (!inside(x)) continue;
      ctx.fillStyle = c.latest ? latest : chosen;
      for (let k = 0; k < c.readings; k++) {
        ctx.beginPath();
        ctx.arc(x, bottom - 12 * dpr - k * step, r, 0, 2 * Math.PI);
        ctx.fill();
      }
      if (c.latest) {
        ctx.strokeStyle = latest;
        ctx.lineWidth = 1.5 * dpr;
        ctx.beginPath();
        ctx.arc(x, bottom - 12 * dpr - (c.readings - 1) * step, r + 2.5 * dpr, 0, 2 * Math.PI);
        ctx.stroke();
      }
      labels.push({ x, order: c.order, latest: c.latest, top: bottom - 12 * dpr - (c.readings - 1) * step - r - 4 * dpr });
    }
    ctx.font = `${10 * dpr}px system-ui, sans-serif`;
    ctx.textAlign = 'center';
    ctx.textBaseline = 'bottom';
    const ordered = [...labels.filter((l) => l.latest), ...labels.filter((l) => !l.latest).sort((a, b) => a.order - b.order)];
    for (const l of spacedLabels(ordered, 16 * dpr)) {
      ctx.fillStyle = l.latest ? latest : chosen;
      ctx.fillText(String(l.order), l.x, l.top);
    }
    ctx.restore();
  };
}

// curve: logic.js Curve (its cols are the plot's columns, kept sorted by θr).
// Point markers follow uPlot's density rule (shown while the points are a few pixels apart):
// a marker per point would cost an arc each per frame on a 1,000-point scan.
// fitted: an optional lookup (θi, θr) → β of a fitted model at the curve's wavelength, drawn
// as a third series.
// marks: an optional () → candidateMarks for an adaptive scan; the x axis then spans every
// candidate from the first point on.
export function betaPlot(el, curve, { log, width, height, onPick, fitted = null, marks = null }) {
  const measured = css('--measured', '#1565c0'), twin = css('--twin', '#e65100');
  const span = (u, lo, hi) => {
    const t = (marks && marks()?.ticks) || [];
    const a = Math.min(lo ?? Infinity, t.length ? t[0] : Infinity), b = Math.max(hi ?? -Infinity, t.length ? t[t.length - 1] : -Infinity);
    if (!Number.isFinite(a) || !Number.isFinite(b)) return [0, 90];
    return a === b ? [a - 1, b + 1] : [a - 0.02 * (b - a), b + 0.02 * (b - a)];
  };
  const opts = {
    width, height,
    scales: { x: marks ? { time: false, range: span } : { time: false }, y: log ? { distr: 3 } : { auto: true } },
    axes: [{ label: 'θr (°)' }, { label: `β at ${curve.nm} nm`, size: 60 }],
    series: [
      { label: 'θr' },
      { label: 'measured β ± u', stroke: measured, width: 1.5, points: { size: 5 } },
      { label: 'twin β ± s.e.', stroke: twin, width: 1.5, dash: [5, 3], points: { show: false } },
      ...(fitted ? [{ label: 'fitted model', stroke: css('--fitted', '#2e7d32'), width: 2, points: { show: false } }] : []),
    ],
    legend: { live: true },
    hooks: {
      draw: [errorBars(1, () => curve.cols[2]), errorBars(2, () => curve.cols[4]), ...(marks ? [candidateTicks(marks)] : [])],
      ready: [(u) => {
        u.over.addEventListener('click', () => {
          const i = u.cursor.idx;
          if (i != null && onPick) onPick(curve.cols[7][i]);
        });
      }],
    },
  };
  return new uPlot(opts, betaData(curve, log, fitted), el);
}

export function betaData(curve, log, fitted = null) {
  const c = curve.cols;
  const cols = [c[0], c[1], c[3]];
  if (fitted) cols.push(c[0].map((tr) => fitted(curve.thetaI, tr, curve.nm)));
  if (!log) return cols;
  const pos = (v) => (v != null && v > 0 ? v : null);
  return [cols[0], ...cols.slice(1).map((col) => col.map(pos))];
}

// Several curves against one θr axis (compare): ys one column per scan, nulls where a scan has
// no point; colours in order.
export const SERIES_COLORS = ['#1565c0', '#e65100', '#2e7d32', '#6a1b9a', '#00838f', '#ad1457'];
export function overlayPlot(el, x, ys, labels, { width, height, ylabel, zeroLine = false }) {
  return new uPlot({
    width, height,
    scales: { x: { time: false } },
    axes: [{ label: 'θr (°)' }, { label: ylabel, size: 70 }],
    series: [{ label: 'θr' }, ...ys.map((_, i) => ({ label: labels[i], stroke: SERIES_COLORS[i % SERIES_COLORS.length], width: 1.5, spanGaps: true, points: { size: 4 } }))],
    hooks: zeroLine ? { draw: [hline(0, 'y', '#888')] } : {},
  }, [x, ...ys], el);
}

export function lanePlot(el, curve, { zThreshold, dEThreshold, width, height }) {
  const z = css('--z', '#6a1b9a'), de = css('--de', '#2e7d32');
  return new uPlot({
    width, height,
    scales: { x: { time: false }, y: { auto: true, range: (u, lo, hi) => [0, Math.max(hi, (zThreshold || 0) * 1.2, (dEThreshold || 0) * 1.2, 1)] } },
    axes: [{ label: 'θr (°)' }, { label: 'max |z|, ΔE00', size: 60 }],
    series: [
      { label: 'θr' },
      { label: 'max |z|', stroke: z, width: 1.5, points: { size: 4 } },
      { label: 'ΔE00', stroke: de, width: 1.5, points: { size: 4 } },
    ],
    hooks: { draw: [hline(zThreshold, 'y', z), hline(dEThreshold, 'y', de)] },
  }, laneData(curve), el);
}

export function laneData(curve) {
  return [curve.cols[0], curve.cols[5], curve.cols[6]];
}

// Measured and predicted spectra of one point.
export function spectrumPlot(el, point, { width, height }) {
  const m = point.measured, p = point.predicted;
  const cols = { m: m.values, mu: m.std_uncertainty, p: p ? p.values : m.values.map(() => null), ps: p ? p.std_uncertainty : null };
  return new uPlot({
    width, height,
    scales: { x: { time: false } },
    axes: [{ label: 'λ (nm)' }, { label: 'β', size: 60 }],
    series: [
      { label: 'λ' },
      { label: 'measured', stroke: css('--measured', '#1565c0'), width: 1.5 },
      { label: 'twin', stroke: css('--twin', '#e65100'), width: 1.5, dash: [5, 3] },
    ],
    hooks: { draw: [errorBars(1, () => cols.mu), errorBars(2, () => cols.ps)] },
  }, [m.wavelengths_nm, cols.m, cols.p], el);
}

// A twin prediction (twin.predict) as columns against θr at the channel nearest nm.
export function predictionColumns(predictions, nm) {
  const rows = predictions.map((q) => {
    let c = 0;
    q.wavelengths_nm.forEach((w, i) => { if (Math.abs(w - nm) < Math.abs(q.wavelengths_nm[c] - nm)) c = i; });
    return [q.geometry.theta_r, q.radiance_factor[c], q.std_error[c]];
  }).sort((a, b) => a[0] - b[0]);
  return [rows.map((r) => r[0]), rows.map((r) => r[1]), rows.map((r) => r[2])];
}

export function predictionPlot(el, cols, { nm, width, height }) {
  return new uPlot({
    width, height,
    scales: { x: { time: false } },
    axes: [{ label: 'θr (°)' }, { label: `β at ${nm} nm`, size: 60 }],
    series: [{ label: 'θr' }, { label: 'twin β ± s.e.', stroke: css('--twin', '#e65100'), width: 1.5 }],
    hooks: { draw: [errorBars(1, () => cols[2])] },
  }, [cols[0], cols[1]], el);
}

// An adaptive scan's uncertainty against the points used, on a log axis: each parameter's
// u/|value| (parameters mode) or the estimated interpolation error (curve mode), with the
// target (target_rel_u, tolerance) as a dashed line. cols: logic.js AdaptiveTrack.columns().
export function adaptivePlot(el, cols, { target, width, height, ylabel }) {
  const color = css('--target', '#c62828');
  return new uPlot({
    width, height,
    scales: {
      x: { time: false, range: (u, lo, hi) => [Math.min(lo ?? 0, 0), Math.max(hi ?? 1, (lo ?? 0) + 1)] },
      y: { distr: 3, range: (u) => logRange(u.data.slice(1).flat(), target) },
    },
    axes: [
      { label: 'points used', incrs: [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000] },
      { label: ylabel, size: 70, values: (u, splits) => splits.map(decade) },
    ],
    series: [{ label: 'points' }, ...cols.labels.map((l, i) => ({ label: l, stroke: SERIES_COLORS[i % SERIES_COLORS.length], width: 1.5, spanGaps: true, points: { show: true, size: 5 } }))],
    hooks: { draw: [hline(target, 'y', color)] },
  }, adaptiveData(cols), el);
}

// A log axis's tick label: the powers of ten only (1e-4, 0.001, 0.01 …).
function decade(v) {
  if (!(v > 0)) return '';
  const e = Math.log10(v);
  return Math.abs(e - Math.round(e)) < 1e-9 ? (e <= -4 ? `1e${Math.round(e)}` : String(Number(v.toPrecision(1)))) : '';
}

export function adaptiveData(cols) {
  return [cols.x, ...cols.ys];
}
