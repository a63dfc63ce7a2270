import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  backoffDelay, formFieldOf, describeError, submitParams, channelOf, insertionIndex, Curve,
  incidences, mergeAlerts, splitAlerts, coalesce, unacknowledged, can, scanActions, armEnd, collisionWedge, exportFile, fmt,
} from '../../src/logic.js';

test('back-off doubles from the base to the cap, jittered within [½, 1]', () => {
  assert.equal(backoffDelay(0, { random: () => 1 }), 250);
  assert.equal(backoffDelay(3, { random: () => 1 }), 2000);
  assert.equal(backoffDelay(30, { random: () => 1 }), 8000);
  assert.equal(backoffDelay(1000, { random: () => 1 }), 8000);
  assert.equal(backoffDelay(2, { random: () => 0 }), 500);
});

test('the form field of an API error path is its first segment', () => {
  assert.equal(formFieldOf('grids[0].grid.out'), 'grids');
  assert.equal(formFieldOf('geometries[12]'), 'geometries');
  assert.equal(formFieldOf('wavelengths'), 'wavelengths');
  assert.equal(formFieldOf(''), null);
  assert.equal(formFieldOf(undefined), null);
  const d = describeError({ code: -32602, message: "grids[0].grid.out: 'bad' is not a number", data: { errc: 'invalid_argument', field: 'grids[0].grid.out' } });
  assert.deepEqual([d.field, d.errc, d.path], ['grids', 'invalid_argument', 'grids[0].grid.out']);
  assert.equal(describeError({ code: -32603, message: 'x' }).field, null);
});

test('submit params keep the typed values for goniod to validate', () => {
  assert.deepEqual(submitParams({ sample: '3', name: '', grids: 'in=45;out=0:10:5', wavelengths: ' 400:700:10 ', repeats: '2', priority: '0', reference: 'start' }),
    { sample: 3, grids: 'in=45;out=0:10:5', wavelengths: '400:700:10', repeats: 2, priority: 0, reference: 'start' });
  assert.deepEqual(submitParams({ sample: 'paint', grids: 'in=15;out=0\n\nin=45;out=0', reference: 'interval', interval: '5', repeats: '', priority: '' }),
    { sample: 'paint', grids: ['in=15;out=0', 'in=45;out=0'], reference: { mode: 'interval', interval: 5 } });
});

test('channels and sorted insertion', () => {
  assert.equal(channelOf([400, 450, 500], 470), 1);
  assert.equal(channelOf([400, 450, 500], 900), 2);
  assert.equal(channelOf([], 500), -1);
  assert.equal(insertionIndex([1, 2, 2, 4], 2), 3);
  assert.equal(insertionIndex([], 5), 0);
  assert.equal(insertionIndex([1, 3], 0), 0);
});

const point = (index, thetaI, thetaR, m, p) => ({
  index, scan_id: 1, z_max: index, delta_e00: index / 2,
  planned: { theta_i: thetaI, theta_r: thetaR }, actual: { theta_i: thetaI, theta_r: thetaR },
  measured: { wavelengths_nm: [500, 550, 600], values: [m, m + 1, m + 2], std_uncertainty: [0.1, 0.2, 0.3] },
  predicted: p === null ? null : { wavelengths_nm: [500, 550, 600], values: [p, p + 1, p + 2], std_uncertainty: [0.01, 0.02, 0.03] },
});

test('a curve keeps its columns sorted by θr at one incidence and wavelength', () => {
  const c = new Curve(560, 45);
  assert.ok(c.add(point(0, 45, 30, 1, 2)));
  assert.ok(c.add(point(1, 45, -10, 3, 4)));
  assert.ok(!c.add(point(2, 15, 0, 5, 6)), 'another incidence is left out');
  assert.ok(c.add(point(3, 45, 10, 7, null)));
  assert.deepEqual(c.cols[0], [-10, 10, 30]);
  assert.deepEqual(c.cols[1], [4, 8, 2]);
  assert.deepEqual(c.cols[2], [0.2, 0.2, 0.2]);
  assert.deepEqual(c.cols[3], [5, null, 3]);
  assert.deepEqual(c.cols[7], [1, 3, 0]);
  assert.equal(c.length, 3);
  assert.deepEqual(incidences([point(0, 45, 0, 1, 1), point(1, 15, 0, 1, 1), point(2, 45, 5, 1, 1)]), [15, 45]);
});

test('1000 points stream into a curve in order', () => {
  const c = new Curve(550, null);
  for (let i = 0; i < 1000; i++) c.add(point(i, 45, ((i * 7919) % 1000) / 10, i, i));
  assert.equal(c.length, 1000);
  for (let i = 1; i < 1000; i++) assert.ok(c.cols[0][i - 1] <= c.cols[0][i]);
});

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

test('roles and scan actions', () => {
  assert.ok(!can('viewer', 'control'));
  assert.ok(can('viewer', 'view'));
  assert.ok(can('technician', 'submit'));
  assert.ok(can('admin', 'ack'));
  assert.ok(!can('none', 'view'));
  assert.deepEqual(scanActions('running'), ['pause', 'cancel']);
  assert.deepEqual(scanActions('paused'), ['resume', 'cancel']);
  assert.deepEqual(scanActions('completed'), []);
});

test('the diagram: arms along ωi and ωr, the collision wedge around the source arm', () => {
  const near = (a, b) => Math.abs(a - b) < 1e-9;
  const s = armEnd(90, 10, 0, 0, -1);
  assert.ok(near(s.x, -10) && near(s.y, 0));
  const r = armEnd(0, 10, 0, 0, 1);
  assert.ok(near(r.x, 0) && near(r.y, -10));
  // θi = 30: the wedge spans θr = −40…−20, left of the normal like the source arm.
  const w = collisionWedge(30, 10, 10, 0, 0);
  const nums = w.match(/-?\d+\.\d+/g).map(Number);
  assert.ok(nums[2] < 0 && nums[2] > -10, w);
  assert.match(w, /^M0\.00,0\.00 L/);
});

test('exports: chunks concatenate until next_offset is null', async () => {
  const chunks = [{ content: 'a', next_offset: 2, filename: 'f.csv', media_type: 'text/csv' }, { content: 'b', next_offset: null, filename: 'f.csv', media_type: 'text/csv' }];
  const calls = [];
  const f = await exportFile(async (m, p) => { calls.push(p.offset); return chunks.shift(); }, 1, 'csv');
  assert.deepEqual(f, { filename: 'f.csv', mediaType: 'text/csv', content: 'ab' });
  assert.deepEqual(calls, [undefined, 2]);
});

test('numbers', () => {
  assert.equal(fmt(0.3000), '0.3');
  assert.equal(fmt(10.5), '10.5');
  assert.equal(fmt(1000), '1000');
  assert.equal(fmt(1.5e-5), '1.500e-5');
  assert.equal(fmt(null), '–');
});

test('coalesce: the latest value, at most once per period', () => {
  const pending = [];
  const timers = { setTimeout: (f) => pending.push(f) };
  const seen = [];
  const f = coalesce((v) => seen.push(v), 250, timers);
  f(1); f(2); f(3);
  assert.equal(pending.length, 1);
  pending.shift()();
  assert.deepEqual(seen, [3]);
  f(4);
  pending.shift()();
  assert.deepEqual(seen, [3, 4]);
});
