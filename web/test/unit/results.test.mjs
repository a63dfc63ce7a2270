// The second pass's pure logic: routes, the history's query, verdicts, budgets, fits,
// comparisons and grouped alerts.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  parseRoute, routeHash, historyQuery, historyField, nextDay, HISTORY_PAGE, finished, verdictBadge, budgetRows,
  fitRows, checkFitModel, modelFromSpec, toggleCompare, MAX_COMPARE, compareColumns, diffStats, groupAlerts, can, shortTime,
} from '../../src/logic.js';

test('routes: a hash names a view and its object, and comes back the same', () => {
  assert.deepEqual(parseRoute('#/scan/12'), { view: 'scan', id: 12, params: {} });
  assert.deepEqual(parseRoute('#/sample/3'), { view: 'sample', id: 3, params: {} });
  assert.deepEqual(parseRoute('#/scans?state=failed&text=gloss'), { view: 'scans', params: { state: 'failed', text: 'gloss' } });
  assert.deepEqual(parseRoute('#/compare/4,7,4,0,x,9'), { view: 'compare', ids: [4, 7, 9], params: {} });
  assert.equal(parseRoute('#/compare/1,2,3,4,5,6,7,8').ids.length, MAX_COMPARE);
  assert.equal(parseRoute('').view, 'run');
  assert.equal(parseRoute('#/nowhere').view, 'run');
  assert.equal(parseRoute('#/scan/0').view, 'scans'); // not an id
  assert.equal(parseRoute('#/scan/abc').view, 'scans');
  for (const h of ['#/scan/12', '#/sample/3', '#/scans?state=failed&text=gloss', '#/compare/4,7', '#/alerts', '#/run'])
    assert.equal(routeHash(parseRoute(h)), h);
  assert.equal(routeHash({ view: 'scans', params: { state: '', text: 'a b', page: null } }), '#/scans?text=a+b');
});

test('the history asks for one page and one row more, with its filters as scan.list params', () => {
  assert.deepEqual(historyQuery({}), { limit: HISTORY_PAGE + 1, offset: 0 });
  assert.deepEqual(historyQuery({ page: '3', sample: '2', state: 'completed', from: '2026-12-01', to: '2026-12-31', text: '  gloss ' }), {
    limit: HISTORY_PAGE + 1, offset: 2 * HISTORY_PAGE, sample: 2, state: 'completed',
    since: '2026-12-01T00:00:00Z', until: '2027-01-01T00:00:00Z', text: 'gloss',
  });
  assert.equal(historyQuery({ sample: 'grey' }).sample, 'grey');
  assert.equal(historyQuery({ text: '   ' }).text, undefined);
  assert.equal(nextDay('2024-02-28'), '2024-02-29');
  assert.equal(nextDay('2026-12-31'), '2027-01-01');
  assert.equal(nextDay('yesterday'), 'yesterday'); // goniod names the field
  assert.equal(historyField('since'), 'from');
  assert.equal(historyField('until'), 'to');
  assert.equal(historyField('sample'), 'sample');
  assert.equal(shortTime('2026-12-04T11:23:09.123Z'), '2026-12-04 11:23:09Z');
  assert.equal(shortTime(null), '–');
  assert.deepEqual(['completed', 'failed', 'cancelled', 'running', 'paused', 'queued', 'interrupted'].map(finished), [true, true, true, false, false, false, false]);
});

test('verdict badges', () => {
  assert.equal(verdictBadge(null).decision, 'none');
  assert.deepEqual(verdictBadge({ decision: 'agrees' }), { decision: 'agrees', text: 'agrees with its twin', tone: 'good' });
  assert.equal(verdictBadge({ decision: 'out_of_tolerance' }).tone, 'bad');
  assert.equal(verdictBadge({ decision: 'instrument_out_of_spec' }).tone, 'bad');
  assert.equal(verdictBadge({ decision: 'undecided' }).tone, 'unsure');
  assert.equal(verdictBadge({ decision: 'something_new' }).text, 'something new');
});

test('a budget at one channel: largest contribution first, combined in quadrature', () => {
  const budget = [
    { component: 'arm accuracy', distribution: 'rectangular', unit: '°', u: 0.29, sensitivity: [0.01, 0.03], contribution: [0.003, 0.0087] },
    { component: 'white certificate', distribution: 'normal', unit: '', u: [0.004, 0.005], sensitivity: [1, 1], contribution: [0.004, 0.005], random: false },
  ];
  const { rows, combined } = budgetRows(budget, 1);
  assert.deepEqual(rows.map((r) => r.component), ['arm accuracy', 'white certificate']);
  assert.equal(rows[1].u, 0.005);
  assert.equal(rows[0].u, 0.29);
  assert.ok(Math.abs(combined - Math.hypot(0.0087, 0.005)) < 1e-12);
  assert.deepEqual(budgetRows(budget, 0).rows.map((r) => r.component), ['white certificate', 'arm accuracy']);
  assert.deepEqual(budgetRows(undefined, 0), { rows: [], combined: 0 });
});

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

const pt = (ti, tr, v, idx = 0) => ({ index: idx, planned: { theta_i: ti, theta_r: tr }, measured: { wavelengths_nm: [500, 600], values: [v, v * 2] } });

test('compare: scans on one θr axis, repeats averaged, differences to the first', () => {
  const a = [pt(45, -10, 0.1), pt(45, 0, 0.2), pt(45, 0, 0.4), pt(30, 0, 9)];
  const b = [pt(45, 0, 0.35), pt(45, 10, 0.5)];
  const c = compareColumns([a, b], 600, 45);
  assert.deepEqual(c.x, [-10, 0, 10]);
  assert.deepEqual(c.ys[0].map((v) => v && +v.toFixed(6)), [0.2, 0.6, null]);
  assert.deepEqual(c.ys[1].map((v) => v && +v.toFixed(6)), [null, 0.7, 1]);
  assert.deepEqual(c.diffs[0].map((v) => v && +v.toFixed(6)), [null, 0.1, null]);
  const s = diffStats(c.diffs[0]);
  assert.equal(s.n, 1);
  assert.ok(Math.abs(s.maxAbs - 0.1) < 1e-12);
  assert.deepEqual(diffStats([null]), { n: 0, maxAbs: null, rms: null });
  let ids = [];
  for (let i = 1; i <= 8; ++i) ids = toggleCompare(ids, i);
  assert.deepEqual(ids, [3, 4, 5, 6, 7, 8]);
  assert.deepEqual(toggleCompare(ids, 5), [3, 4, 6, 7, 8]);
});

test('alerts grouped per scan, in the order of each group\'s newest', () => {
  const al = [{ id: 9, scan_id: 2 }, { id: 8, scan_id: null }, { id: 7, scan_id: 1 }, { id: 6, scan_id: 2 }, { id: 5 }];
  const g = groupAlerts(al);
  assert.deepEqual(g.map((x) => [x.scan, x.alerts.map((a) => a.id)]), [[2, [9, 6]], [null, [8]], [1, [7]], [null, [5]]]);
});
