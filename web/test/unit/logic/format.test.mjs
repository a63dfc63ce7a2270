// src/logic/format.js: numbers as shown and the form field an API error names.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { describeError, fmt, formFieldOf } from '../../../src/logic/format.js';

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

test('numbers', () => {
  assert.equal(fmt(0.3000), '0.3');
  assert.equal(fmt(10.5), '10.5');
  assert.equal(fmt(1000), '1000');
  assert.equal(fmt(1.5e-5), '1.500e-5');
  assert.equal(fmt(null), '–');
});
