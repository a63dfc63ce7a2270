// src/logic/axes.js: log ranges in whole decades and labels spaced along an axis.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { logRange, spacedLabels } from '../../../src/logic/axes.js';

test('a log range spans whole decades around the values and the target', () => {
  assert.deepEqual(logRange([0.2, 0.05, null], 0.01), [0.01, 1]);
  assert.deepEqual(logRange([0.003, 0.02], 0.01), [0.001, 0.1]);
  assert.deepEqual(logRange([0.01], 0.01), [0.01, 0.1]); // one decade at least
  assert.deepEqual(logRange([], null), [1e-3, 1]);
  assert.deepEqual(logRange([0, -1, NaN], 0.05), [0.01, 0.1]);
});

test('labels along an axis are kept in priority order where there is room', () => {
  const kept = spacedLabels([{ x: 100, id: 'latest' }, { x: 10 }, { x: 20 }, { x: 30 }, { x: 95 }, { x: 120 }], 16);
  assert.deepEqual(kept.map((k) => k.x), [100, 10, 30, 120]);
  assert.deepEqual(spacedLabels([], 16), []);
});
