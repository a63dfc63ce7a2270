// A scan's points: paged reads, the β plot's columns kept sorted as points arrive, the
// incidences present, and the export's chunks.

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
