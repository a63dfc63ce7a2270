// The inverse twin on a scan's page: the fit's parameters beside the naive fit's, the model to
// start from, and the material export's summary.

import { fmt } from './format.js';

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

// scan.material's answer (twin/material.md) as the lines shown beside its download: the glTF
// approximation's ΔE00 over the fitting geometries, then what the format approximates.
export function materialSummary(result) {
  const lines = [];
  const g = result && result.gltf && result.gltf.delta_e_geometries;
  if (g) lines.push(`glTF approximation: ΔE00 over ${g.samples} geometries mean ${fmt(g.mean, 3)}, p95 ${fmt(g.p95, 3)}, max ${fmt(g.max, 3)}`);
  for (const n of (result && result.notes) || []) lines.push(String(n));
  return lines;
}
