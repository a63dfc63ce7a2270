// src/logic/timing.js: the reconnect back-off and coalesced re-renders.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { backoffDelay, coalesce } from '../../../src/logic/timing.js';

test('back-off doubles from the base to the cap, jittered within [½, 1]', () => {
  assert.equal(backoffDelay(0, { random: () => 1 }), 250);
  assert.equal(backoffDelay(3, { random: () => 1 }), 2000);
  assert.equal(backoffDelay(30, { random: () => 1 }), 8000);
  assert.equal(backoffDelay(1000, { random: () => 1 }), 8000);
  assert.equal(backoffDelay(2, { random: () => 0 }), 500);
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
