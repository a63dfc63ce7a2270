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
  const adaptive = adaptiveParams(form);
  if (adaptive) p.adaptive = adaptive;
  return p;
}

// Points per scan.points call: a point with its budget and sensitivities is ~9 kB of JSON
// at 31 channels, so 1,000 of them would pass goniod's 8 MiB response limit.
export const POINTS_PAGE = 250;

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

// The alerts that still ask for someone: unacknowledged and standing (a resolved alert's
// scan ended with a verdict that no longer supports it).
export function unacknowledged(alerts) {
  return alerts.reduce((n, a) => n + (a.acknowledged || a.resolved_at ? 0 : 1), 0);
}

// Standing alerts and the ones goniod resolved, apart, each newest first.
export function splitAlerts(alerts) {
  const standing = [], resolved = [];
  for (const a of alerts) (a.resolved_at ? resolved : standing).push(a);
  return { standing, resolved };
}

// What a role may do; the server enforces the same (the method table), the UI only hides.
const rank = { none: 0, viewer: 1, technician: 2, admin: 3 };
export function can(role, action) {
  const need = { control: 'technician', submit: 'technician', ack: 'technician', predict: 'technician', create: 'technician', fit: 'technician', calibrate: 'admin' }[action] || 'viewer';
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

// ---- routes: the view in the URL's hash, so a link opens the same view after a reload or a
// login ("#/scan/12", "#/sample/3", "#/scans?state=completed&text=gloss", "#/compare/4,7").
export const VIEW_NAMES = ['run', 'scans', 'scan', 'compare', 'alerts', 'samples', 'sample', 'twin'];

export function parseRoute(hash) {
  const h = String(hash || '').replace(/^#\/?/, '');
  const [path, query = ''] = h.split('?');
  const [view, arg] = path.split('/');
  const params = Object.fromEntries(new URLSearchParams(query));
  const id = (s) => (/^[1-9]\d{0,15}$/.test(s || '') ? Number(s) : null);
  switch (view) {
    case 'scan': case 'sample': {
      const n = id(arg);
      return n ? { view, id: n, params } : { view: view === 'scan' ? 'scans' : 'samples', params: {} };
    }
    case 'compare': {
      const ids = [...new Set(String(arg || '').split(',').map(id).filter(Boolean))].slice(0, MAX_COMPARE);
      return { view, ids, params };
    }
    case 'scans': case 'alerts': case 'samples': case 'twin': case 'run':
      return { view, params };
    default: return { view: 'run', params: {} };
  }
}

export function routeHash(route) {
  const q = new URLSearchParams(Object.entries(route.params || {}).filter(([, v]) => v !== '' && v != null)).toString();
  let path = route.view;
  if (route.view === 'scan' || route.view === 'sample') path += `/${route.id}`;
  else if (route.view === 'compare') path += `/${(route.ids || []).join(',')}`;
  return `#/${path}${q ? `?${q}` : ''}`;
}

// ---- the scans' history -------------------------------------------------------------------
export const HISTORY_PAGE = 25;
export const SCAN_STATES = ['queued', 'running', 'paused', 'interrupted', 'completed', 'failed', 'cancelled'];

// scan.list params from the history's filters (the route's params: sample, state, from, to
// (days, YYYY-MM-DD, both included), text, page (1-based)). One row more than a page is asked
// for: its presence says there is a next page.
export function historyQuery(f = {}) {
  const p = { limit: HISTORY_PAGE + 1, offset: HISTORY_PAGE * Math.max(0, (Number(f.page) || 1) - 1) };
  if (f.sample) p.sample = /^\d+$/.test(f.sample) ? Number(f.sample) : f.sample;
  if (f.state) p.state = f.state;
  if (f.from) p.since = `${f.from}T00:00:00Z`;
  if (f.to) p.until = `${nextDay(f.to)}T00:00:00Z`;
  if (f.text && f.text.trim()) p.text = f.text.trim();
  return p;
}

// The day after an ISO date (YYYY-MM-DD), in UTC; the text itself when it is not a date (goniod
// then names the field).
export function nextDay(day) {
  if (!/^\d{4}-\d{2}-\d{2}$/.test(day)) return day;
  const t = new Date(`${day}T00:00:00Z`);
  if (Number.isNaN(t.getTime())) return day;
  t.setUTCDate(t.getUTCDate() + 1);
  return t.toISOString().slice(0, 10);
}

// The history's filter a scan.list error names (since → from, until → to).
export function historyField(path) {
  const f = formFieldOf(path);
  return { since: 'from', until: 'to' }[f] || f;
}

export function shortTime(iso) {
  return iso ? String(iso).replace('T', ' ').replace(/(:\d\d)\.\d+Z$/, '$1Z') : '–';
}

// States a scan is over in: they can be fitted, compared and are not live.
export function finished(state) {
  return state === 'completed' || state === 'failed' || state === 'cancelled';
}

// ---- verdicts and budgets -----------------------------------------------------------------
const VERDICT_TEXT = {
  agrees: 'agrees with its twin',
  out_of_tolerance: 'out of tolerance',
  instrument_out_of_spec: 'instrument out of spec',
  undecided: 'undecided',
};
// The badge for a scan's verdict (scan.get `verdict`; null before its first predicted point).
export function verdictBadge(verdict) {
  if (!verdict || !verdict.decision) return { decision: 'none', text: 'no verdict yet', tone: 'none' };
  const d = verdict.decision;
  const tone = d === 'agrees' ? 'good' : d === 'undecided' ? 'unsure' : 'bad';
  return { decision: d, text: VERDICT_TEXT[d] || d.replace(/_/g, ' '), tone };
}

// One channel's rows of a point's uncertainty budget (PointRecord.budget): u of the input,
// its sensitivity and its contribution to u(β) at channel c, largest contribution first, and
// the combined standard uncertainty √Σ contribution².
export function budgetRows(budget, c) {
  const at = (v) => (Array.isArray(v) ? v[Math.min(c, v.length - 1)] : v);
  const rows = (budget || []).map((e) => ({
    component: e.component, distribution: e.distribution, unit: e.unit || '', random: !!e.random,
    u: at(e.u), sensitivity: at(e.sensitivity), contribution: at(e.contribution),
  }));
  rows.sort((a, b) => Math.abs(b.contribution ?? 0) - Math.abs(a.contribution ?? 0));
  const combined = Math.sqrt(rows.reduce((s, r) => s + (Number.isFinite(r.contribution) ? r.contribution ** 2 : 0), 0));
  return { rows, combined };
}

// ---- the inverse twin ---------------------------------------------------------------------
// A fit's parameters beside the naive fit's: value ± u, the naive value and its bias
// (naive − fitted) in units of u.
export function fitRows(result) {
  const naive = new Map(((result && result.naive && result.naive.parameters) || []).map((p) => [p.name, p]));
  return ((result && result.parameters) || []).map((p) => {
    const n = naive.get(p.name);
    const bias = n && Number.isFinite(n.value) ? n.value - p.value : null;
    return {
      name: p.name, value: p.value, u: p.u ?? null, atBound: !!p.at_bound, identifiable: p.identifiable !== false,
      naive: n ? n.value : null, bias, biasInU: bias !== null && p.u > 0 ? bias / p.u : null,
    };
  });
}

// The catalogued sample's spec with its first plain number freed ("lambert:albedo=0.3" →
// "lambert:albedo=?"): a start for the fit's model, which the technician edits.
export function modelFromSpec(spec) {
  if (!spec) return 'lambert:albedo=?';
  return spec.replace(/=(-?\d+(\.\d+)?(e-?\d+)?)(?=[,+]|$)/, '=?');
}

// A model spec for scan.fit must free something: at least one '?'.
export function checkFitModel(model) {
  const m = String(model || '').trim();
  if (!m) return 'give a BSDF model';
  if (!m.includes('?')) return "mark the parameters to fit with '?' (e.g. lambert:albedo=?)";
  return null;
}

// ---- compare ------------------------------------------------------------------------------
export const MAX_COMPARE = 6;

// Adds or removes a scan from a comparison of at most MAX_COMPARE (the oldest pick is dropped).
export function toggleCompare(ids, id) {
  if (ids.includes(id)) return ids.filter((x) => x !== id);
  return [...ids, id].slice(-MAX_COMPARE);
}

// Measured β at one wavelength and incidence of several scans on one θr axis (the union of
// their θr; null where a scan has no point), and each scan's difference to the first at the
// θr both have. points: one array of point records per scan.
export function compareColumns(pointLists, nm, thetaI) {
  const curves = pointLists.map((pts) => {
    const m = new Map();
    for (const p of pts) {
      const g = p.planned || p.actual;
      if (thetaI !== null && thetaI !== undefined && Math.abs(g.theta_i - thetaI) > 1e-6) continue;
      const c = channelOf(p.measured.wavelengths_nm, nm);
      if (c < 0) continue;
      const key = Math.round(g.theta_r * 1e6) / 1e6;
      const prev = m.get(key);
      // Repeats at one geometry: their mean.
      m.set(key, prev ? { s: prev.s + p.measured.values[c], n: prev.n + 1 } : { s: p.measured.values[c], n: 1 });
    }
    return m;
  });
  const xs = [...new Set(curves.flatMap((m) => [...m.keys()]))].sort((a, b) => a - b);
  const ys = curves.map((m) => xs.map((x) => (m.has(x) ? m.get(x).s / m.get(x).n : null)));
  const diffs = ys.slice(1).map((y) => y.map((v, i) => (v !== null && ys[0][i] !== null ? v - ys[0][i] : null)));
  return { x: xs, ys, diffs };
}

// Differences' summary: max |Δ| and rms over the θr both scans have.
export function diffStats(diff) {
  const v = diff.filter((d) => d !== null);
  if (v.length === 0) return { n: 0, maxAbs: null, rms: null };
  return { n: v.length, maxAbs: Math.max(...v.map(Math.abs)), rms: Math.sqrt(v.reduce((s, d) => s + d * d, 0) / v.length) };
}

// ---- alerts grouped per scan --------------------------------------------------------------
// Alerts (newest first) in groups: one per scan (its alerts newest first), and one per alert
// that names no scan, in the order of each group's newest alert.
export function groupAlerts(alerts) {
  const groups = [];
  const byScan = new Map();
  for (const a of alerts) {
    if (a.scan_id) {
      let g = byScan.get(a.scan_id);
      if (!g) { g = { scan: a.scan_id, alerts: [] }; byScan.set(a.scan_id, g); groups.push(g); }
      g.alerts.push(a);
    } else groups.push({ scan: null, alerts: [a] });
  }
  return groups;
}

// ---- adaptive scans -----------------------------------------------------------------------
// An adaptive plan's geometries are candidates; goniod's twin chooses which to measure next
// (each point's geometry_index names its candidate). scan.get and every scan.progress carry
// the loop's status: {mode, state, points_used, parameters [{name, value, u}], chi2_per_dof,
// misfit, warnings} in parameters mode, {mode, state, points_used, estimated_error, warnings}
// in curve mode.
export const ADAPTIVE_MODES = ['off', 'parameters', 'curve'];

// A number as typed, or the text itself when it is not one (goniod then names the field).
const typed = (s) => {
  const t = String(s ?? '').trim();
  return t !== '' && Number.isFinite(Number(t)) ? Number(t) : t;
};

// The submit form's adaptive fields → scan.submit's `adaptive` (null for an ordinary scan).
export function adaptiveParams(form) {
  const mode = form.adaptive || 'off';
  if (mode === 'off') return null;
  if (mode === 'parameters') {
    return { mode, model: String(form.model || '').trim(), target_rel_u: typed(form.target_rel_u), max_points: typed(form.max_points) };
  }
  if (mode === 'curve') return { mode, tolerance: typed(form.tolerance), max_points: typed(form.max_points) };
  return { mode, max_points: typed(form.max_points) }; // an unknown mode: goniod names it
}

// The submit form's field for an error path of scan.submit: "adaptive.model" → model,
// "adaptive.target_rel_u" → target_rel_u, "adaptive.mode" or "adaptive" → adaptive (the mode);
// any other path its first segment.
const ADAPTIVE_FIELDS = ['model', 'target_rel_u', 'tolerance', 'max_points'];
export function submitFieldOf(path) {
  const f = formFieldOf(path);
  if (f !== 'adaptive') return f;
  const m = /^adaptive\.([A-Za-z_]+)/.exec(path);
  return m && ADAPTIVE_FIELDS.includes(m[1]) ? m[1] : 'adaptive';
}

// u/|value| of a parameter; null where it is not a positive finite number (a log plot's gap).
export function relativeU(p) {
  if (!p || !Number.isFinite(p.u) || !Number.isFinite(p.value) || p.value === 0) return null;
  const r = p.u / Math.abs(p.value);
  return r > 0 ? r : null;
}

// The loop's status as it went, one row per points_used (a later status for the same count
// replaces the earlier one: the final state comes after the last point's). Fed from scan.get
// when a view opens and from every scan.progress after.
export class AdaptiveTrack {
  constructor() { this.rows = new Map(); this.names = []; this.latest = null; this.version = 0; }
  get length() { return this.rows.size; }
  add(status) {
    if (!status || typeof status !== 'object' || !Number.isFinite(status.points_used)) return false;
    this.version++;
    const row = { n: status.points_used, rel: new Map(), error: null };
    for (const p of status.parameters || []) {
      if (!this.names.includes(p.name)) this.names.push(p.name);
      row.rel.set(p.name, relativeU(p));
    }
    if (Number.isFinite(status.estimated_error) && status.estimated_error > 0) row.error = status.estimated_error;
    this.rows.set(status.points_used, row);
    // The loop's final word (target reached, max_points) stands against a late "running" one
    // of the same count.
    const l = this.latest;
    if (!l || status.points_used > l.points_used || (status.points_used === l.points_used && (status.state !== 'running' || l.state === 'running'))) this.latest = status;
    return true;
  }
  // Plot columns against points used: parameters mode one column of u/|value| per parameter,
  // curve mode one of the estimated error. labels name the columns after x.
  columns() {
    const rows = [...this.rows.values()].sort((a, b) => a.n - b.n);
    const x = rows.map((r) => r.n);
    if (this.latest && this.latest.mode === 'curve') return { x, ys: [rows.map((r) => r.error)], labels: ['estimated error'] };
    return { x, ys: this.names.map((n) => rows.map((r) => r.rel.get(n) ?? null)), labels: this.names.map((n) => `u(${n})/|${n}|`) };
  }
}

// A log axis's range [lo, hi] in whole decades around the values and the target line, so that
// the line is always on the plot.
export function logRange(values, target = null) {
  const v = [...values, target].filter((x) => Number.isFinite(x) && x > 0);
  if (v.length === 0) return [1e-3, 1];
  const lo = 10 ** Math.floor(Math.log10(Math.min(...v)) + 1e-9);
  let hi = 10 ** Math.ceil(Math.log10(Math.max(...v)) - 1e-9);
  if (hi <= lo) hi = lo * 10;
  return [lo, hi];
}

// The loop's state for a badge, with the scan's: a loop that reports "running" in a scan that
// is no longer running was stopped with it (paused, cancelled, failed).
// The loop may reach its target while points it chose before are still being measured: it
// says so until the scan ends.
export function adaptiveState(status, scanState = 'running') {
  if (!status) return { state: 'none', text: 'no choice yet', tone: 'none' };
  const pending = scanState === 'running' ? '; measuring the points already chosen' : '';
  switch (status.state) {
    case 'target_reached': return { state: 'target_reached', text: `target reached in ${status.points_used} points${pending}`, tone: 'good' };
    case 'max_points': return { state: 'max_points', text: `stopped at max_points (${status.points_used}) before the target${pending}`, tone: 'bad' };
    default:
      if (scanState && scanState !== 'running' && scanState !== 'queued')
        return { state: 'running', text: `${scanState} after ${status.points_used} points`, tone: 'unsure' };
      return { state: 'running', text: `running: ${status.points_used} points`, tone: 'none' };
  }
}

// The warnings to show: the loop's own, and first, when the model misfits, that said plainly
// (the fit's own sentence about it when it has one, else one of ours).
const MISFIT_TEXT = /does not describe the data/;
export function adaptiveWarnings(status) {
  if (!status) return [];
  const w = (status.warnings || []).map((text) => ({ text: String(text), misfit: false }));
  if (!status.misfit) return w;
  const own = w.findIndex((x) => MISFIT_TEXT.test(x.text));
  if (own >= 0) return [{ ...w[own], misfit: true }, ...w.filter((_, i) => i !== own)];
  const chi = Number.isFinite(status.chi2_per_dof) ? ` (χ²/dof = ${fmt(status.chi2_per_dof, 3)})` : '';
  return [{ text: `the model does not describe the data${chi}: its uncertainties are not to be trusted`, misfit: true }, ...w];
}

// Each parameter's value ± u as text, with u relative to the value and whether it is at the
// target.
export function parameterLines(status, target = null) {
  return ((status && status.parameters) || []).map((p) => {
    const rel = relativeU(p);
    return {
      name: p.name, value: p.value, u: p.u, rel,
      text: `${p.name} = ${fmt(p.value, 5)} ± ${fmt(p.u, 2)}${rel === null ? '' : ` (${fmt(100 * rel, 2)} %)`}`,
      reached: rel !== null && Number.isFinite(target) && rel <= target,
    };
  });
}

// The points in the order the loop chose them: each with its candidate, the how-manieth
// reading of that candidate it is (1-based), and whether it is the latest.
export function chosenOrder(points) {
  const sorted = [...points].sort((a, b) => a.index - b.index);
  const reads = new Map();
  return sorted.map((p, i) => {
    const gi = p.geometry_index ?? null;
    const reading = (reads.get(gi) || 0) + 1;
    reads.set(gi, reading);
    const g = p.planned || p.actual || {};
    return { order: i + 1, index: p.index, candidate: gi, thetaI: g.theta_i, thetaR: g.theta_r, reading, latest: i === sorted.length - 1 };
  });
}

// What the β plot marks for an adaptive scan at one incidence: every candidate's θr (a faint
// tick) and each measured candidate once, with its readings, the order it was first chosen in
// and whether the latest point read it. thetaI null: every incidence.
export function candidateMarks(candidates, points, thetaI = null) {
  const at = (t) => thetaI === null || thetaI === undefined || Math.abs(t - thetaI) < 1e-6;
  const ticks = [...new Set((candidates || []).filter((g) => at(g.theta_i)).map((g) => g.theta_r))].sort((a, b) => a - b);
  const byCandidate = new Map();
  for (const c of chosenOrder(points)) {
    if (!at(c.thetaI)) continue;
    const m = byCandidate.get(c.candidate);
    if (m) { m.readings = c.reading; m.latest = m.latest || c.latest; } else byCandidate.set(c.candidate, { thetaR: c.thetaR, order: c.order, readings: 1, latest: c.latest, candidate: c.candidate });
  }
  return { ticks, chosen: [...byCandidate.values()] };
}

// Which labels to draw along an axis without overlap: items [{x (px), ...}] in priority order;
// an item is kept when it is at least `gap` px from every kept one.
export function spacedLabels(items, gap) {
  const kept = [];
  for (const it of items) if (kept.every((k) => Math.abs(k.x - it.x) >= gap)) kept.push(it);
  return kept;
}

// scan.material's answer (twin/material.md) as the lines shown beside its download: the glTF
// approximation's ΔE00 over the fitting geometries, then what the format approximates.
export function materialSummary(result) {
  const lines = [];
  const g = result && result.gltf && result.gltf.delta_e_geometries;
  if (g) lines.push(`glTF approximation: ΔE00 over ${g.samples} geometries mean ${fmt(g.mean, 3)}, p95 ${fmt(g.p95, 3)}, max ${fmt(g.max, 3)}`);
  for (const n of (result && result.notes) || []) lines.push(String(n));
  return lines;
}
