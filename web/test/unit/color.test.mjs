import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync, existsSync } from 'node:fs';
import { parseCgats, colorOf, xyzToLab, xyzToSrgb, hex } from '../../src/color.js';

const colord = process.env.GONIO_COLORD_DIR || '/usr/share/colord';
const have = existsSync(`${colord}/cmf/CIE1964-10deg-XYZ.cmf`);
const tables = have ? {
  cmf: parseCgats(readFileSync(`${colord}/cmf/CIE1964-10deg-XYZ.cmf`, 'utf8')),
  illuminant: parseCgats(readFileSync(`${colord}/illuminant/CIE-D65.sp`, 'utf8')),
} : null;
const grid = Array.from({ length: 31 }, (_, i) => 400 + 10 * i);

test('CGATS tables parse with their band count', { skip: !have && 'colord-data is not installed' }, () => {
  assert.equal(tables.cmf.sets.length, 3);
  assert.equal(tables.cmf.wavelengths[0], 360);
  assert.equal(tables.cmf.sets[0].length, tables.cmf.wavelengths.length);
  assert.equal(tables.illuminant.sets.length, 1);
  assert.throws(() => parseCgats('SPECTRAL_START_NM 1\nSPECTRAL_END_NM 2\nSPECTRAL_BANDS 3\nBEGIN_DATA\n1 2\nEND_DATA'));
});

test('a flat spectrum is neutral: L* from β, a* = b* = 0', { skip: !have && 'colord-data is not installed' }, () => {
  const white = colorOf(grid, grid.map(() => 1), tables);
  assert.ok(Math.abs(white.lab[0] - 100) < 1e-9);
  // (the 10° white through the 2° sRGB matrix is within a step of #ffffff)
  assert.ok(/^#f[cdef]f[cdef]f[cdef]$/.test(white.hex), white.hex);
  const grey = colorOf(grid, grid.map(() => 0.18), tables);
  assert.ok(Math.abs(grey.lab[0] - 49.5) < 0.1, String(grey.lab[0]));
  assert.ok(Math.abs(grey.lab[1]) < 1e-9 && Math.abs(grey.lab[2]) < 1e-9);
  // A long-wave reflector is reddish: a* > 0, b* > 0.
  const orange = colorOf(grid, grid.map((w) => (w > 580 ? 0.6 : 0.08)), tables);
  assert.ok(orange.lab[1] > 20 && orange.lab[2] > 20, JSON.stringify(orange.lab));
});

test('Lab and sRGB', () => {
  assert.deepEqual(xyzToLab([95, 100, 108], [95, 100, 108]).map((v) => Math.round(v * 1e9) / 1e9), [100, 0, 0]);
  assert.deepEqual(xyzToSrgb([0, 0, 0]), { rgb: [0, 0, 0], clipped: false });
  assert.equal(xyzToSrgb([0, 0, 200]).clipped, true);
  assert.equal(hex([255, 0, 16]), '#ff0010');
});
