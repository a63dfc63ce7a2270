// src/logic/alerts.js: the alert list: upserts, counts, standing and resolved apart, groups per scan.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { groupAlerts, mergeAlerts, splitAlerts, unacknowledged } from '../../../src/logic/alerts.js';

test('alerts: upserted by id, newest first, unacknowledged counted', () => {
  const a = mergeAlerts([{ id: 1, acknowledged: false }, { id: 2, acknowledged: false }], [{ id: 1, acknowledged: true }, { id: 3, acknowledged: false }]);
  assert.deepEqual(a.map((x) => x.id), [3, 2, 1]);
  assert.equal(unacknowledged(a), 2);
});

test('alerts: resolved ones apart and not counted, a notification moves one across', () => {
  const standing = { id: 4, acknowledged: false, resolved_at: null };
  let a = mergeAlerts([], [standing, { id: 2, acknowledged: false, resolved_at: null }, { id: 1, acknowledged: true, resolved_at: null }]);
  assert.equal(unacknowledged(a), 2);
  // goniod publishes the alert again with resolved_at when the final verdict resolves it.
  a = mergeAlerts(a, [{ ...standing, resolved_at: '2026-01-01T00:00:00Z', resolution: 'resolved: final verdict agrees: fine' }]);
  assert.equal(unacknowledged(a), 1);
  const { standing: s, resolved: r } = splitAlerts(a);
  assert.deepEqual(s.map((x) => x.id), [2, 1]);
  assert.deepEqual(r.map((x) => x.id), [4]);
  assert.equal(r[0].resolution, 'resolved: final verdict agrees: fine');
  // An alert from a goniod that predates resolution stands.
  assert.deepEqual(splitAlerts([{ id: 7 }]).standing.map((x) => x.id), [7]);
});

test('alerts grouped per scan, in the order of each group\'s newest', () => {
  const al = [{ id: 9, scan_id: 2 }, { id: 8, scan_id: null }, { id: 7, scan_id: 1 }, { id: 6, scan_id: 2 }, { id: 5 }];
  const g = groupAlerts(al);
  assert.deepEqual(g.map((x) => [x.scan, x.alerts.map((a) => a.id)]), [[2, [9, 6]], [null, [8]], [1, [7]], [null, [5]]]);
});
