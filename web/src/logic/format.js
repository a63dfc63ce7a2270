// How values and goniod's errors read on the page: numbers, times, and the form field an error names.

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

export function fmt(v, digits = 4) {
  if (v === null || v === undefined || Number.isNaN(v)) return '–';
  if (typeof v !== 'number') return String(v);
  const a = Math.abs(v);
  if (a !== 0 && (a < 1e-3 || a >= 1e5)) return v.toExponential(digits - 1);
  let s = v.toPrecision(digits);
  if (s.includes('.') && !s.includes('e')) s = s.replace(/0+$/, '').replace(/\.$/, '');
  return s;
}

export function shortTime(iso) {
  return iso ? String(iso).replace('T', ' ').replace(/(:\d\d)\.\d+Z$/, '$1Z') : '–';
}
