// src/logic/points.js: channels, sorted insertion, the β plot's columns as points stream in, and export chunks.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Curve, channelOf, exportFile, incidences, insertionIndex } from '../../../src/logic/points.js';

const point = (index, thetaI, thetaR, m, p) => ({
  index, scan_id: 1, z_max: index, delta_e00: index / 2,
  planned: { theta_i: thetaI, theta_r: thetaR }, actual: { theta_i: thetaI, theta_r: thetaR },
  measured: { wavelengths_nm: [500, 550, 600], values: [m, m + 1, m + 2], std_uncertainty: [0.1, 0.2, 0.3] },
  predicted: p === null ? null : { wavelengths_nm: [500, 550, 600], values: [p, p + 1, p + 2], std_uncertainty: [0.01, 0.02, 0.03] },
});

test('channels and sorted insertion', () => {
  assert.equal(channelOf([400, 450, 500], 470), 1);
  assert.equal(channelOf([400, 450, 500], 900), 2);
  assert.equal(channelOf([], 500), -1);
  assert.equal(insertionIndex([1, 2, 2, 4], 2), 3);
  assert.equal(insertionIndex([], 5), 0);
  assert.equal(insertionIndex([1, 3], 0), 0);
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

test('exports: chunks concatenate until next_offset is null', async () => {
  const chunks = [{ content: 'a', next_offset: 2, filename: 'f.csv', media_type: 'text/csv' }, { content: 'b', next_offset: null, filename: 'f.csv', media_type: 'text/csv' }];
  const calls = [];
  const f = await exportFile(async (m, p) => { calls.push(p.offset); return chunks.shift(); }, 1, 'csv');
  assert.deepEqual(f, { filename: 'f.csv', mediaType: 'text/csv', content: 'ab' });
  assert.deepEqual(calls, [undefined, 2]);
});
