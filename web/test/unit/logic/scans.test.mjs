// src/logic/scans.js: scan.list's params from the history's filters and pages.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { shortTime } from '../../../src/logic/format.js';
import { HISTORY_PAGE, finished, historyField, historyQuery, nextDay } from '../../../src/logic/scans.js';

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
