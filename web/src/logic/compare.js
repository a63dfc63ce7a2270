// Comparing scans: the picked scans, their β on one θr axis, and their differences.

import { channelOf } from './points.js';

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
