// One WebSocket per tab for JSON-RPC calls and the `subscribe` notifications. It logs in with
// the bearer token as its first call (a browser cannot set headers on a WebSocket), subscribes
// again after every reconnect, and reconnects with back-off (logic.js backoffDelay).
import { backoffDelay } from './logic/timing.js';

export class RpcError extends Error {
  constructor(error) {
    super(error.message);
    this.code = error.code;
    this.data = error.data;
  }
}

export class Rpc {
  // onStatus(status, detail): 'connecting' | 'open' | 'down' | 'refused' (the token failed)
  constructor({ url, token, topics, onStatus, onNotification, onOpen, WebSocketImpl = globalThis.WebSocket }) {
    Object.assign(this, { url, token, topics, onStatus, onNotification, onOpen, WebSocketImpl });
    this.nextId = 1;
    this.pending = new Map();
    this.attempt = 0;
    this.stopped = false;
    this.ready = false;
    this.waiting = []; // calls made while down: sent once logged in again
  }

  start() {
    this.stopped = false;
    this.connect();
  }

  stop() {
    this.stopped = true;
    clearTimeout(this.timer);
    if (this.ws) this.ws.close();
    this.failAll('the connection was closed');
  }

  connect() {
    this.onStatus('connecting');
    const ws = new this.WebSocketImpl(this.url);
    this.ws = ws;
    ws.onopen = async () => {
      try {
        const me = await this.send('auth.login', { token: this.token });
        await this.send('subscribe', { topics: this.topics });
        this.attempt = 0;
        this.ready = true;
        this.onStatus('open', me);
        for (const w of this.waiting.splice(0)) this.send(w.method, w.params).then(w.resolve, w.reject);
        if (this.onOpen) this.onOpen(me);
      } catch (e) {
        if (e instanceof RpcError && (e.code === -32000 || e.code === -32001)) {
          this.stopped = true;
          this.onStatus('refused', e.message);
          ws.close();
        }
      }
    };
    ws.onmessage = (ev) => this.receive(ev.data);
    ws.onclose = () => {
      if (this.ws !== ws) return;
      this.ready = false;
      this.failAll('disconnected from goniod');
      if (this.stopped) return;
      const delay = backoffDelay(this.attempt++);
      this.onStatus('down', delay);
      this.timer = setTimeout(() => this.connect(), delay);
    };
  }

  failAll(why) {
    for (const p of this.pending.values()) p.reject(new RpcError({ code: -32009, message: why, data: { errc: 'disconnected' } }));
    this.pending.clear();
  }

  receive(text) {
    let msg;
    try { msg = JSON.parse(text); } catch { return; }
    for (const m of Array.isArray(msg) ? msg : [msg]) {
      if (m.id === undefined || m.id === null) {
        if (m.method) this.onNotification(m.method, m.params);
        continue;
      }
      const p = this.pending.get(m.id);
      if (!p) continue;
      this.pending.delete(m.id);
      if (m.error) p.reject(new RpcError(m.error));
      else p.resolve(m.result);
    }
  }

  send(method, params) {
    const id = this.nextId++;
    return new Promise((resolve, reject) => {
      this.pending.set(id, { resolve, reject });
      this.ws.send(JSON.stringify({ jsonrpc: '2.0', id, method, params: params || {} }));
    });
  }

  // A call: sent now when logged in, else when the connection is back.
  call(method, params) {
    if (this.ready) return this.send(method, params);
    return new Promise((resolve, reject) => this.waiting.push({ method, params, resolve, reject }));
  }
}

// ws://host/ws for the page's own origin (https pages get wss).
export function wsUrl(loc) {
  return `${loc.protocol === 'https:' ? 'wss' : 'ws'}://${loc.host}/ws`;
}
