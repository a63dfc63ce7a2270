import { test } from 'node:test';
import assert from 'node:assert/strict';
import { materialSummary } from '../../src/logic.js';

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
