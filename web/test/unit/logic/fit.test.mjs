// src/logic/fit.js: fit rows beside the naive fit, the model to start from, and the material export's summary.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { checkFitModel, fitRows, materialSummary, modelFromSpec } from '../../../src/logic/fit.js';
import { can } from '../../../src/logic/roles.js';

test('fit rows: value ± u beside the naive fit and its bias in u', () => {
  const rows = fitRows({
    parameters: [{ name: 'lambert.albedo', value: 0.6, u: 0.002 }, { name: 'coat.alpha', value: 0.05, u: null, identifiable: false, at_bound: true }],
    naive: { parameters: [{ name: 'lambert.albedo', value: 0.61 }] },
  });
  assert.equal(rows[0].naive, 0.61);
  assert.ok(Math.abs(rows[0].bias - 0.01) < 1e-12);
  assert.ok(Math.abs(rows[0].biasInU - 5) < 1e-9);
  assert.deepEqual([rows[1].naive, rows[1].bias, rows[1].biasInU, rows[1].identifiable, rows[1].atBound], [null, null, null, false, true]);
  assert.deepEqual(fitRows(null), []);
  assert.equal(checkFitModel('lambert:albedo=?'), null);
  assert.match(checkFitModel('lambert:albedo=0.5'), /\?/);
  assert.match(checkFitModel('  '), /model/);
  assert.equal(modelFromSpec('lambert:albedo=0.3'), 'lambert:albedo=?');
  assert.equal(modelFromSpec('lambert:albedo=400:0.06,500:0.12+coat:alpha=0.06,ior=1.5'), 'lambert:albedo=400:0.06,500:0.12+coat:alpha=?,ior=1.5');
  assert.equal(modelFromSpec(null), 'lambert:albedo=?');
  assert.equal(can('viewer', 'fit'), false);
  assert.equal(can('technician', 'fit'), true);
  assert.equal(can('technician', 'calibrate'), false);
  assert.equal(can('admin', 'calibrate'), true);
});

test("a glTF export's summary states its ΔE00, then the notes", () => {
  const r = {
    format: 'gltf', notes: ['a note'],
    gltf: { spec: 'gltf:base_color=0.5', delta_e_geometries: { mean: 0.6123, p95: 1.9, max: 3.44, samples: 523 } },
  };
  assert.deepEqual(materialSummary(r), [
    'glTF approximation: ΔE00 over 523 geometries mean 0.612, p95 1.9, max 3.44',
    'a note',
  ]);
});

test('a Mitsuba export has its notes alone; nothing is no lines', () => {
  assert.deepEqual(materialSummary({ format: 'mitsuba', notes: ['conductor: masking'] }), ['conductor: masking']);
  assert.deepEqual(materialSummary(undefined), []);
});
