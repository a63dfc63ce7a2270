// src/logic/verdict.js: verdict badges and a point's uncertainty budget at one channel.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { budgetRows, verdictBadge } from '../../../src/logic/verdict.js';

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
