import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Rpc, RpcError, wsUrl } from '../../src/rpc.js';

// A scripted WebSocket: answers auth.login and subscribe, records what was sent.
class FakeSocket {
  static all = [];
  constructor(url) {
    this.url = url;
    this.sent = [];
    FakeSocket.all.push(this);
    queueMicrotask(() => this.onopen && this.onopen());
  }
  send(text) {
    const m = JSON.parse(text);
    this.sent.push(m);
    const reply = (body) => queueMicrotask(() => this.onmessage({ data: JSON.stringify({ jsonrpc: '2.0', id: m.id, ...body }) }));
    if (m.method === 'auth.login') reply(m.params.token === 'good' ? { result: { name: 't', role: 'technician' } } : { error: { code: -32000, message: 'unknown token' } });
    else if (m.method === 'subscribe') reply({ result: { topics: m.params.topics } });
    else if (m.method === 'fail') reply({ error: { code: -32602, message: 'bad', data: { errc: 'invalid_argument', field: 'grids[0]' } } });
    else reply({ result: m.method });
  }
  close() { queueMicrotask(() => this.onclose && this.onclose()); }
}

const tick = () => new Promise((r) => setTimeout(r, 0));

test('logs in, subscribes, answers calls and passes notifications', async () => {
  FakeSocket.all = [];
  const statuses = [], notes = [];
  const rpc = new Rpc({ url: 'ws://x/ws', token: 'good', topics: ['points'], WebSocketImpl: FakeSocket, onStatus: (s) => statuses.push(s), onNotification: (m, p) => notes.push([m, p]) });
  const early = rpc.call('queue.status'); // made before the login: sent after it
  rpc.start();
  assert.equal(await early, 'queue.status');
  const ws = FakeSocket.all[0];
  assert.deepEqual(ws.sent.map((m) => m.method), ['auth.login', 'subscribe', 'queue.status']);
  assert.deepEqual(statuses, ['connecting', 'open']);
  await assert.rejects(rpc.call('fail'), (e) => e instanceof RpcError && e.data.field === 'grids[0]');
  ws.onmessage({ data: JSON.stringify({ jsonrpc: '2.0', method: 'scan.point', params: { index: 1 } }) });
  assert.deepEqual(notes, [['scan.point', { index: 1 }]]);
  rpc.stop();
});

test('reconnects after a drop and subscribes again', async () => {
  FakeSocket.all = [];
  const statuses = [];
  const rpc = new Rpc({ url: 'ws://x/ws', token: 'good', topics: ['alerts'], WebSocketImpl: FakeSocket, onStatus: (s) => statuses.push(s), onNotification: () => {} });
  rpc.start();
  await tick(); await tick();
  const pending = rpc.send('slow', {});
  FakeSocket.all[0].sent.length = 0;
  rpc.ws.onclose();
  await assert.rejects(pending);
  assert.equal(statuses.at(-1), 'down');
  await new Promise((r) => setTimeout(r, 300)); // the first back-off is at most 250 ms
  await tick(); await tick();
  assert.equal(FakeSocket.all.length, 2);
  assert.deepEqual(FakeSocket.all[1].sent.map((m) => m.method), ['auth.login', 'subscribe']);
  assert.equal(statuses.at(-1), 'open');
  rpc.stop();
});

test('a refused token stops reconnecting', async () => {
  FakeSocket.all = [];
  const statuses = [];
  const rpc = new Rpc({ url: 'ws://x/ws', token: 'bad', topics: [], WebSocketImpl: FakeSocket, onStatus: (s) => statuses.push(s), onNotification: () => {} });
  rpc.start();
  await new Promise((r) => setTimeout(r, 50));
  assert.ok(statuses.includes('refused'));
  assert.equal(FakeSocket.all.length, 1);
});

test('the WebSocket URL follows the page', () => {
  assert.equal(wsUrl({ protocol: 'http:', host: 'lab:8080' }), 'ws://lab:8080/ws');
  assert.equal(wsUrl({ protocol: 'https:', host: 'lab' }), 'wss://lab/ws');
});
