// src/logic/adaptive.js: the uncertainty track, the loop's state and warnings, and the points in the order chosen.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { AdaptiveTrack, adaptiveState, adaptiveWarnings, candidateMarks, chosenOrder, parameterLines, relativeU } from '../../../src/logic/adaptive.js';

const point = (index, gi, thetaR, thetaI = 45) => ({ index, geometry_index: gi, planned: { theta_i: thetaI, theta_r: thetaR } });
const status = (n, params, extra = {}) => ({ mode: 'parameters', state: 'running', points_used: n, parameters: params, chi2_per_dof: 1.1, misfit: false, warnings: [], ...extra });

test('relative u: u/|value|, none where it cannot go on a log axis', () => {
  assert.equal(relativeU({ value: -0.5, u: 0.01 }), 0.02);
  assert.equal(relativeU({ value: 0, u: 0.01 }), null);
  assert.equal(relativeU({ value: 0.05, u: 0 }), null);
  assert.equal(relativeU({ value: 0.05, u: null }), null);
  assert.equal(relativeU(null), null);
});

test('the track keeps one row per points used, in order, for each parameter', () => {
  const t = new AdaptiveTrack();
  assert.equal(t.add(null), false);
  assert.equal(t.add({ mode: 'parameters', state: 'running' }), false);
  t.add(status(3, [])); // before the first fit: no parameters yet
  t.add(status(6, [{ name: 'alpha', value: 0.05, u: 0.005 }]));
  t.add(status(5, [{ name: 'alpha', value: 0.05, u: 0.01 }])); // late, from a scan.get: sorted in
  t.add(status(7, [{ name: 'alpha', value: 0.05, u: 0.002 }, { name: 'eta', value: 0.2, u: 0.02 }]));
  t.add(status(7, [{ name: 'alpha', value: 0.05, u: 0.001 }, { name: 'eta', value: 0.2, u: 0.02 }])); // replaces
  const c = t.columns();
  assert.deepEqual(c.x, [3, 5, 6, 7]);
  assert.deepEqual(c.labels, ['u(alpha)/|alpha|', 'u(eta)/|eta|']);
  assert.deepEqual(c.ys[0].map((v) => (v === null ? null : Number(v.toFixed(6)))), [null, 0.2, 0.1, 0.02]);
  assert.deepEqual(c.ys[1].map((v) => (v === null ? null : Number(v.toFixed(6)))), [null, null, null, 0.1]);
  assert.equal(t.latest.points_used, 7);
  assert.equal(t.length, 4);
  assert.ok(t.version >= 5);
});

test('the loop\'s final word stands against a late running status of the same count', () => {
  const t = new AdaptiveTrack();
  t.add(status(12, [{ name: 'alpha', value: 0.05, u: 0.0004 }]));
  t.add(status(12, [{ name: 'alpha', value: 0.05, u: 0.0004 }], { state: 'target_reached' }));
  t.add(status(12, [{ name: 'alpha', value: 0.05, u: 0.0004 }])); // a progress event read after
  assert.equal(t.latest.state, 'target_reached');
  t.add(status(11, [{ name: 'alpha', value: 0.05, u: 0.0005 }]));
  assert.equal(t.latest.points_used, 12);
  assert.equal(t.columns().x.length, 2);
});

test('curve mode tracks the estimated error', () => {
  const t = new AdaptiveTrack();
  t.add({ mode: 'curve', state: 'running', points_used: 5, estimated_error: null, warnings: [] });
  t.add({ mode: 'curve', state: 'running', points_used: 6, estimated_error: 0.2, warnings: [] });
  t.add({ mode: 'curve', state: 'target_reached', points_used: 9, estimated_error: 0.015, warnings: [] });
  assert.deepEqual(t.columns(), { x: [5, 6, 9], ys: [[null, 0.2, 0.015]], labels: ['estimated error'] });
});

test('the state says why the loop stopped, or that its scan did', () => {
  assert.equal(adaptiveState(null).state, 'none');
  const s = adaptiveState(status(8, []));
  assert.deepEqual([s.state, s.tone], ['running', 'none']);
  assert.match(s.text, /running: 8 points/);
  const done = adaptiveState(status(14, [], { state: 'target_reached' }), 'completed');
  assert.deepEqual([done.state, done.tone, done.text], ['target_reached', 'good', 'target reached in 14 points']);
  const max = adaptiveState(status(12, [], { state: 'max_points' }), 'completed');
  assert.deepEqual([max.state, max.tone], ['max_points', 'bad']);
  assert.match(max.text, /max_points \(12\)/);
  assert.equal(adaptiveState(status(27, [], { state: 'target_reached' }), 'running').text, 'target reached in 27 points; measuring the points already chosen');
  const cancelled = adaptiveState(status(9, []), 'cancelled');
  assert.deepEqual([cancelled.state, cancelled.tone, cancelled.text], ['running', 'unsure', 'cancelled after 9 points']);
});

test('a misfit is said first and plainly, before the loop\'s own warnings', () => {
  assert.deepEqual(adaptiveWarnings(null), []);
  assert.deepEqual(adaptiveWarnings(status(5, [], { warnings: ['alpha at a bound'] })), [{ text: 'alpha at a bound', misfit: false }]);
  const w = adaptiveWarnings(status(12, [], { misfit: true, chi2_per_dof: 37.2, warnings: ['slow convergence'] }));
  assert.equal(w.length, 2);
  assert.equal(w[0].misfit, true);
  assert.match(w[0].text, /does not describe the data \(χ²\/dof = 37.2\)/);
  assert.deepEqual(w[1], { text: 'slow convergence', misfit: false });
  assert.match(adaptiveWarnings(status(12, [], { misfit: true, chi2_per_dof: null }))[0].text, /does not describe the data:/);
  // The fit's own sentence about it, when it has one, is the one shown first (once).
  const own = adaptiveWarnings(status(12, [], { misfit: true, chi2_per_dof: 9, warnings: ['slow', 'the model does not describe the data: χ²/dof = 9'] }));
  assert.deepEqual(own, [{ text: 'the model does not describe the data: χ²/dof = 9', misfit: true }, { text: 'slow', misfit: false }]);
});

test('parameters as value ± u, relative u in per cent, and whether each is at its target', () => {
  const l = parameterLines(status(9, [{ name: 'alpha', value: 0.05012, u: 0.0004 }, { name: 'eta', value: 0.2, u: 0.01 }]), 0.01);
  assert.deepEqual(l.map((p) => [p.name, p.text, p.reached]), [
    ['alpha', 'alpha = 0.05012 ± 4.0e-4 (0.8 %)', true],
    ['eta', 'eta = 0.2 ± 0.01 (5 %)', false],
  ]);
  assert.deepEqual(parameterLines(null), []);
  assert.equal(parameterLines(status(2, [{ name: 'alpha', value: 0, u: 0.1 }]), 0.01)[0].reached, false);
});

test('the points in the order chosen, repeats counted, the latest marked', () => {
  const pts = [point(2, 30, 45), point(0, 10, 25), point(1, 30, 45), point(3, 31, 46), point(4, 30, 45)];
  const o = chosenOrder(pts);
  assert.deepEqual(o.map((c) => [c.order, c.index, c.candidate, c.reading, c.latest]), [
    [1, 0, 10, 1, false], [2, 1, 30, 1, false], [3, 2, 30, 2, false], [4, 3, 31, 1, false], [5, 4, 30, 3, true],
  ]);
  assert.deepEqual(chosenOrder([]), []);
});

test('the β plot marks every candidate and each measured one once, at the plotted incidence', () => {
  const cands = [{ theta_i: 45, theta_r: 15 }, { theta_i: 45, theta_r: 30 }, { theta_i: 45, theta_r: 45 }, { theta_i: 60, theta_r: 45 }, { theta_i: 45, theta_r: 60 }];
  const pts = [point(0, 1, 30), point(1, 2, 45), point(2, 3, 45, 60), point(3, 2, 45)];
  const m = candidateMarks(cands, pts, 45);
  assert.deepEqual(m.ticks, [15, 30, 45, 60]);
  assert.deepEqual(m.chosen.map((c) => [c.candidate, c.thetaR, c.order, c.readings, c.latest]), [[1, 30, 1, 1, false], [2, 45, 2, 2, true]]);
  const all = candidateMarks(cands, pts, null);
  assert.deepEqual(all.ticks, [15, 30, 45, 60]); // θr once, whatever the incidence
  assert.equal(all.chosen.length, 3);
  assert.deepEqual(candidateMarks(null, [], 45), { ticks: [], chosen: [] });
});
