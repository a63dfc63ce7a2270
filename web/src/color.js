// Colours of a spectrum for the point details: CIE XYZ under D65 with the 10° observer, CIELAB
// and an sRGB swatch, as goniod computes ΔE00 (daemon/README.md, "Divergence"). The tables are
// colord-data's, read at build time (build.mjs), never typed in (docs/architecture.md §2).

// A CGATS file of colord-data (.cmf, .sp): the wavelengths and the data sets.
export function parseCgats(text) {
  const num = (key) => {
    const m = new RegExp(`^${key}\\s+([-0-9.eE+]+)`, 'm').exec(text);
    if (!m) throw new Error(`CGATS: no ${key}`);
    return Number(m[1]);
  };
  const start = num('SPECTRAL_START_NM'), end = num('SPECTRAL_END_NM'), bands = num('SPECTRAL_BANDS');
  const body = /BEGIN_DATA\s*\n([\s\S]*?)END_DATA/.exec(text.replace(/BEGIN_DATA_FORMAT[\s\S]*?END_DATA_FORMAT/, ''));
  if (!body) throw new Error('CGATS: no data');
  const sets = body[1].trim().split('\n').map((l) => l.trim().split(/\s+/).map(Number));
  for (const s of sets) if (s.length !== bands) throw new Error(`CGATS: ${s.length} values, ${bands} bands`);
  const step = (end - start) / (bands - 1);
  return { wavelengths: Array.from({ length: bands }, (_, i) => start + i * step), sets };
}

function interp(wl, values, nm) {
  if (nm <= wl[0]) return values[0];
  if (nm >= wl[wl.length - 1]) return values[values.length - 1];
  const step = wl[1] - wl[0];
  const i = Math.min(wl.length - 2, Math.floor((nm - wl[0]) / step));
  const t = (nm - wl[i]) / step;
  return values[i] * (1 - t) + values[i + 1] * t;
}

// XYZ (Y of the perfect diffuser = 100) of a radiance factor spectrum sampled at `nm`, with
// the trapezoid rule over the sampled channels; `tables` = {cmf, illuminant} from parseCgats.
export function spectrumToXyz(nm, beta, tables) {
  const { cmf, illuminant } = tables;
  let X = 0, Y = 0, Z = 0, N = 0;
  for (let i = 0; i < nm.length; i++) {
    const w = nm.length === 1 ? 1 : i === 0 ? (nm[1] - nm[0]) / 2 : i === nm.length - 1 ? (nm[i] - nm[i - 1]) / 2 : (nm[i + 1] - nm[i - 1]) / 2;
    const S = interp(illuminant.wavelengths, illuminant.sets[0], nm[i]);
    const x = interp(cmf.wavelengths, cmf.sets[0], nm[i]);
    const y = interp(cmf.wavelengths, cmf.sets[1], nm[i]);
    const z = interp(cmf.wavelengths, cmf.sets[2], nm[i]);
    X += w * S * x * beta[i];
    Y += w * S * y * beta[i];
    Z += w * S * z * beta[i];
    N += w * S * y;
  }
  const k = 100 / N;
  return [X * k, Y * k, Z * k];
}

export function xyzToLab([X, Y, Z], white) {
  const f = (t) => (t > (6 / 29) ** 3 ? Math.cbrt(t) : t / (3 * (6 / 29) ** 2) + 4 / 29);
  const fx = f(X / white[0]), fy = f(Y / white[1]), fz = f(Z / white[2]);
  return [116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)];
}

// IEC 61966-2-1: XYZ (D65) → 8-bit sRGB, clipped to the gamut. The observer is the 10° one of
// the ΔE00 figures, so the swatch is a display aid, not a colorimetric reference.
export function xyzToSrgb([X, Y, Z]) {
  const x = X / 100, y = Y / 100, z = Z / 100;
  const lin = [
    3.2406 * x - 1.5372 * y - 0.4986 * z,
    -0.9689 * x + 1.8758 * y + 0.0415 * z,
    0.0557 * x - 0.204 * y + 1.057 * z,
  ];
  const clipped = lin.some((c) => c < 0 || c > 1);
  const rgb = lin.map((c) => {
    const v = Math.min(1, Math.max(0, c));
    const g = v <= 0.0031308 ? 12.92 * v : 1.055 * v ** (1 / 2.4) - 0.055;
    return Math.round(255 * g);
  });
  return { rgb, clipped };
}

export function hex([r, g, b]) {
  return '#' + [r, g, b].map((c) => c.toString(16).padStart(2, '0')).join('');
}

// Everything the point details show for one spectrum.
export function colorOf(nm, beta, tables) {
  const xyz = spectrumToXyz(nm, beta, tables);
  const white = spectrumToXyz(nm, nm.map(() => 1), tables);
  const lab = xyzToLab(xyz, white);
  const { rgb, clipped } = xyzToSrgb(xyz);
  return { xyz, lab, hex: hex(rgb), clipped };
}
