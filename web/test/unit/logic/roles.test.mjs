// src/logic/roles.js: what each role may do and the actions each scan state offers.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { can, scanActions } from '../../../src/logic/roles.js';

test('roles and scan actions', () => {
  assert.ok(!can('viewer', 'control'));
  assert.ok(can('viewer', 'view'));
  assert.ok(can('technician', 'submit'));
  assert.ok(can('admin', 'ack'));
  assert.ok(!can('none', 'view'));
  assert.deepEqual(scanActions('running'), ['pause', 'cancel']);
  assert.deepEqual(scanActions('paused'), ['resume', 'cancel']);
  assert.deepEqual(scanActions('completed'), []);
});
