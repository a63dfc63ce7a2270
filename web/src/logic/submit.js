// The submit form: scan.submit's params from its text values (the adaptive plan too), and the
// form field a scan.submit error names.

import { formFieldOf } from './format.js';

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
