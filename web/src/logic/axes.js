// Plot axes: a log range in whole decades, and labels spaced so they do not overlap.

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

// Which labels to draw along an axis without overlap: items [{x (px), ...}] in priority order;
// an item is kept when it is at least `gap` px from every kept one.
export function spacedLabels(items, gap) {
  const kept = [];
  for (const it of items) if (kept.every((k) => Math.abs(k.x - it.x) >= gap)) kept.push(it);
  return kept;
}
