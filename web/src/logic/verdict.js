// A scan's verdict badge and a point's uncertainty budget.

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
