// Adaptive scans: a plan's geometries are candidates, and goniod's twin chooses which to
// measure next (each point's geometry_index names its candidate). scan.get and every
// scan.progress carry the loop's status: {mode, state, points_used, parameters [{name, value,
// u}], chi2_per_dof, misfit, warnings} in parameters mode, {mode, state, points_used,
// estimated_error, warnings} in curve mode (the modes: 'off', 'parameters', 'curve'). Here:
// the uncertainty track, the loop's state and warnings, and the points in the order chosen.

import { fmt } from './format.js';

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
