// src/logic/routes.js: the view in the URL's hash, read and written back the same.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { MAX_COMPARE } from '../../../src/logic/compare.js';
import { parseRoute, routeHash } from '../../../src/logic/routes.js';

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
