// The dashboard's pure logic: no DOM, no sockets, so `node --test` covers it (test/unit/).

// Reconnect delay for the attempt-th retry (0-based): doubling from `base` to `max`, with
// jitter in [½, 1] of that so that many tabs do not come back in step after a restart.
export function backoffDelay(attempt, { base = 250, max = 8000, random = Math.random } = {}) {
  const d = Math.min(max, base * 2 ** Math.min(attempt, 30));
  return Math.round(d * (0.5 + 0.5 * random()));
}

// goniod names the offending value in error.data.field as a path into the request's params
// ("grids[0].grid.out", "geometries[12]", "wavelengths"): the form field is its first segment.
export function formFieldOf(path) {
  if (typeof path !== 'string' || path === '') return null;
  const m = /^[A-Za-z_][A-Za-z0-9_]*/.exec(path);
  return m ? m[0] : null;
}

// A JSON-RPC error object → {message, code, errc, field (the form's field name or null), path}.
export function describeError(err) {
  const data = (err && err.data) || {};
  return {
    code: err && err.code,
    message: (err && err.message) || 'unknown error',
    errc: data.errc || '',
    path: data.field || '',
    field: formFieldOf(data.field),
  };
}

// The scan.submit params from the form's text values; empty fields are left to goniod's
// defaults, and the values are passed as typed so that goniod's validation names them.
export function submitParams(form) {
  const p = { sample: /^\d+$/.test(form.sample) ? Number(form.sample) : form.sample };
  if (form.name) p.name = form.name;
  if (form.grids) {
    const grids = form.grids.split('\n').map((s) => s.trim()).filter(Boolean);
    p.grids = grids.length === 1 ? grids[0] : grids;
  }
  if (form.wavelengths) p.wavelengths = form.wavelengths.trim();
  if (form.repeats !== '' && form.repeats != null) p.repeats = Number(form.repeats);
  if (form.priority !== '' && form.priority != null) p.priority = Number(form.priority);
  if (form.reference) {
    p.reference = form.reference === 'interval'
      ? { mode: 'interval', interval: Number(form.interval || 10) }
      : form.reference;
  }
  return p;
}

// Index of the channel nearest to `nm` (wavelength grids are increasing).
export function channelOf(wavelengths, nm) {
  if (!wavelengths || wavelengths.length === 0) return -1;
  let best = 0;
  for (let i = 1; i < wavelengths.length; i++)
    if (Math.abs(wavelengths[i] - nm) < Math.abs(wavelengths[best] - nm)) best = i;
  return best;
}

// Where `x` goes in the ascending array `xs` (after equal values: arrival order is kept).
export function insertionIndex(xs, x) {
  let lo = 0, hi = xs.length;
  while (lo < hi) {
    const mid = (lo + hi) >> 1;
    if (xs[mid] <= x) lo = mid + 1; else hi = mid;
  }
  return lo;
}

// A scan's points as plot columns against θr at one incidence and one wavelength, kept sorted
// by θr as points arrive (uPlot needs ascending x). Columns: θr, measured β, its u, twin β,
// its s.e., max |z|, ΔE00 and the point index (for clicks).
export class Curve {
  constructor(nm, thetaI = null) {
    this.nm = nm;
    this.thetaI = thetaI;
    this.cols = [[], [], [], [], [], [], [], []];
  }
  get length() { return this.cols[0].length; }
  accepts(p) {
    const g = p.actual || p.planned;
    return this.thetaI === null || Math.abs(g.theta_i - this.thetaI) < 1e-6;
  }
  add(p) {
    if (!this.accepts(p)) return false;
    const g = p.planned || p.actual;
    const m = p.measured || {};
    const c = channelOf(m.wavelengths_nm, this.nm);
    if (c < 0) return false;
    const pr = p.predicted;
    const row = [
      g.theta_r,
      m.values[c],
      m.std_uncertainty[c],
      pr ? pr.values[c] : null,
      pr ? pr.std_uncertainty[c] : null,
      p.z_max ?? null,
      p.delta_e00 ?? null,
      p.index,
    ];
    const at = insertionIndex(this.cols[0], row[0]);
    for (let k = 0; k < row.length; k++) this.cols[k].splice(at, 0, row[k]);
    return true;
  }
}

// Incidences present in a list of points (for the plot's θi selector).
export function incidences(points) {
  const s = new Set();
  for (const p of points) s.add((p.planned || p.actual).theta_i);
  return [...s].sort((a, b) => a - b);
}

// Upsert by id, newest (highest id) first: the alert list.
export function mergeAlerts(list, incoming) {
  const byId = new Map(list.map((a) => [a.id, a]));
  for (const a of incoming) byId.set(a.id, a);
  return [...byId.values()].sort((a, b) => b.id - a.id);
}

export function unacknowledged(alerts) {
  return alerts.reduce((n, a) => n + (a.acknowledged ? 0 : 1), 0);
}

// What a role may do; the server enforces the same (the method table), the UI only hides.
const rank = { none: 0, viewer: 1, technician: 2, admin: 3 };
export function can(role, action) {
  const need = { control: 'technician', submit: 'technician', ack: 'technician', predict: 'technician', create: 'technician' }[action] || 'viewer';
  return (rank[role] || 0) >= rank[need];
}

// Which actions a scan in a state offers (scan.pause/resume/cancel and queue.reorder).
export function scanActions(state) {
  switch (state) {
    case 'queued': return ['cancel', 'reorder'];
    case 'running': return ['pause', 'cancel'];
    case 'paused':
    case 'interrupted': return ['resume', 'cancel'];
    default: return [];
  }
}

// Arm end points for the goniometer diagram, in SVG coordinates (y down) around (cx, cy):
// the sample normal points up; the source arm lies along ωi = (−sin θi, cos θi) and the
// receiver along ωr = (sin θr, cos θr) (docs/architecture.md §2).
export function armEnd(thetaDeg, length, cx, cy, side) {
  const t = (thetaDeg * Math.PI) / 180;
  return { x: cx + side * length * Math.sin(t), y: cy - length * Math.cos(t) };
}

// The collision zone: receiver angles within `sep` of the source arm (θr = −θi ± sep), as an
// SVG wedge path of radius r.
export function collisionWedge(thetaI, sep, r, cx, cy) {
  const a = armEnd(-thetaI - sep, r, cx, cy, 1);
  const b = armEnd(-thetaI + sep, r, cx, cy, 1);
  const large = 2 * sep > 180 ? 1 : 0;
  const f = (v) => v.toFixed(2);
  return `M${f(cx)},${f(cy)} L${f(a.x)},${f(a.y)} A${f(r)},${f(r)} 0 ${large} 1 ${f(b.x)},${f(b.y)} Z`;
}

// Chunks of scan.export (csv, json) concatenate to the file; bsdf and ssdd come whole.
export async function exportFile(call, scan, format) {
  let r = await call('scan.export', { scan, format });
  const parts = [r.content];
  while (r.next_offset !== null && r.next_offset !== undefined) {
    r = await call('scan.export', { scan, format, offset: r.next_offset });
    parts.push(r.content);
  }
  return { filename: r.filename, mediaType: r.media_type, content: parts.join('') };
}

// fn(latest value) at most once per `ms`: notifications that arrive with every point
// (progress, instrument state) re-render the page at a readable rate, not at the point rate.
export function coalesce(fn, ms, timers = globalThis) {
  let latest, timer = null;
  return (v) => {
    latest = v;
    if (timer !== null) return;
    timer = timers.setTimeout(() => { timer = null; fn(latest); }, ms);
  };
}

export function fmt(v, digits = 4) {
  if (v === null || v === undefined || Number.isNaN(v)) return '–';
  if (typeof v !== 'number') return String(v);
  const a = Math.abs(v);
  if (a !== 0 && (a < 1e-3 || a >= 1e5)) return v.toExponential(digits - 1);
  let s = v.toPrecision(digits);
  if (s.includes('.') && !s.includes('e')) s = s.replace(/0+$/, '').replace(/\.$/, '');
  return s;
}
