// src/logic/submit.js: scan.submit's params from the form, adaptive plans included, and the field an error is shown at.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { describeError } from '../../../src/logic/format.js';
import { adaptiveParams, submitFieldOf, submitParams } from '../../../src/logic/submit.js';

test('submit params keep the typed values for goniod to validate', () => {
  assert.deepEqual(submitParams({ sample: '3', name: '', grids: 'in=45;out=0:10:5', wavelengths: ' 400:700:10 ', repeats: '2', priority: '0', reference: 'start' }),
    { sample: 3, grids: 'in=45;out=0:10:5', wavelengths: '400:700:10', repeats: 2, priority: 0, reference: 'start' });
  assert.deepEqual(submitParams({ sample: 'paint', grids: 'in=15;out=0\n\nin=45;out=0', reference: 'interval', interval: '5', repeats: '', priority: '' }),
    { sample: 'paint', grids: ['in=15;out=0', 'in=45;out=0'], reference: { mode: 'interval', interval: 5 } });
});

test('the form submits an adaptive plan in either mode, its values as typed', () => {
  const base = { sample: '2', grids: 'in=45;out=15:75:1', wavelengths: '450,550,650', repeats: '1', reference: 'every_point' };
  assert.equal(submitParams({ ...base, adaptive: 'off', model: 'x' }).adaptive, undefined);
  assert.equal(submitParams(base).adaptive, undefined);
  assert.deepEqual(submitParams({ ...base, adaptive: 'parameters', model: ' conductor:alpha=?,eta=0.2,k=3.9 ', target_rel_u: '0.01', tolerance: '0.5', max_points: '40' }).adaptive,
    { mode: 'parameters', model: 'conductor:alpha=?,eta=0.2,k=3.9', target_rel_u: 0.01, max_points: 40 });
  assert.deepEqual(adaptiveParams({ adaptive: 'curve', model: 'ignored', tolerance: '2e-2', target_rel_u: '0.1', max_points: '101' }),
    { mode: 'curve', tolerance: 0.02, max_points: 101 });
  // What is not a number goes as typed, for goniod to name.
  assert.deepEqual(adaptiveParams({ adaptive: 'parameters', model: '', target_rel_u: 'one percent', max_points: '' }),
    { mode: 'parameters', model: '', target_rel_u: 'one percent', max_points: '' });
});

test('an adaptive plan\'s error is shown at its own field', () => {
  assert.equal(submitFieldOf('adaptive.model'), 'model');
  assert.equal(submitFieldOf('adaptive.target_rel_u'), 'target_rel_u');
  assert.equal(submitFieldOf('adaptive.tolerance'), 'tolerance');
  assert.equal(submitFieldOf('adaptive.max_points'), 'max_points');
  assert.equal(submitFieldOf('adaptive.mode'), 'adaptive');
  assert.equal(submitFieldOf('adaptive'), 'adaptive');
  assert.equal(submitFieldOf('adaptive.something_else'), 'adaptive');
  assert.equal(submitFieldOf('grids[0].grid.out'), 'grids');
  assert.equal(submitFieldOf(''), null);
  const d = describeError({ code: -32602, message: 'adaptive.max_points: 500 is out of range [1, 183]', data: { field: 'adaptive.max_points' } });
  assert.equal(submitFieldOf(d.path), 'max_points');
});
