// src/logic/compare.js: scans on one θr axis and their differences.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { compareColumns, diffStats, toggleCompare } from '../../../src/logic/compare.js';

const pt = (ti, tr, v, idx = 0) => ({ index: idx, planned: { theta_i: ti, theta_r: tr }, measured: { wavelengths_nm: [500, 600], values: [v, v * 2] } });

test('compare: scans on one θr axis, repeats averaged, differences to the first', () => {
  const a = [pt(45, -10, 0.1), pt(45, 0, 0.2), pt(45, 0, 0.4), pt(30, 0, 9)];
  const b = [pt(45, 0, 0.35), pt(45, 10, 0.5)];
  const c = compareColumns([a, b], 600, 45);
  assert.deepEqual(c.x, [-10, 0, 10]);
  assert.deepEqual(c.ys[0].map((v) => v && +v.toFixed(6)), [0.2, 0.6, null]);
  assert.deepEqual(c.ys[1].map((v) => v && +v.toFixed(6)), [null, 0.7, 1]);
  assert.deepEqual(c.diffs[0].map((v) => v && +v.toFixed(6)), [null, 0.1, null]);
  const s = diffStats(c.diffs[0]);
  assert.equal(s.n, 1);
  assert.ok(Math.abs(s.maxAbs - 0.1) < 1e-12);
  assert.deepEqual(diffStats([null]), { n: 0, maxAbs: null, rms: null });
  let ids = [];
  for (let i = 1; i <= 8; ++i) ids = toggleCompare(ids, i);
  assert.deepEqual(ids, [3, 4, 5, 6, 7, 8]);
  assert.deepEqual(toggleCompare(ids, 5), [3, 4, 6, 7, 8]);
});
