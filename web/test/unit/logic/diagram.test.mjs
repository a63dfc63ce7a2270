// src/logic/diagram.js: the goniometer diagram's arms and collision wedge.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { armEnd, collisionWedge } from '../../../src/logic/diagram.js';

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
