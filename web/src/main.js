// The dashboard: login, one WebSocket (rpc.js), and the views. State that many views share
// (instrument status, queue, alerts, samples) lives here; scan points go over a small bus so
// that a point redraws the plot without re-rendering the page.
import { render } from 'preact';
import { useCallback, useEffect, useRef, useState } from 'preact/hooks';
import 'uplot/dist/uPlot.min.css';
import './style.css';
import { html } from './ui.js';
import { Rpc, wsUrl } from './rpc.js';
import { mergeAlerts, unacknowledged } from './logic/alerts.js';
import { can } from './logic/roles.js';
import { parseRoute, routeHash } from './logic/routes.js';
import { coalesce } from './logic/timing.js';
import { InstrumentPanel } from './instrument.js';
import { QueuePanel, SubmitForm } from './queue.js';
import { ScanPanel } from './scanplot.js';
import { AlertsPanel } from './alerts.js';
import { SamplesPanel } from './samples.js';
import { TwinPanel } from './twin.js';
import { ScansPanel } from './scans.js';
import { ScanView } from './scanpage.js';
import { ComparePanel } from './compare.js';
import { SampleView } from './samplepage.js';

const TOKEN_KEY = 'gonio.token';

function makeBus() {
  const subs = new Map();
  return {
    on(topic, fn) {
      if (!subs.has(topic)) subs.set(topic, new Set());
      subs.get(topic).add(fn);
      return () => subs.get(topic).delete(fn);
    },
    emit(topic, value) { for (const fn of subs.get(topic) || []) fn(value); },
  };
}

function Login({ onLogin, error }) {
  const [token, setToken] = useState('');
  return html`<main class="login">
    <form onSubmit=${(e) => { e.preventDefault(); if (token) onLogin(token.trim()); }} aria-label="Log in">
      <h1>gonio</h1>
      <label for="token">Bearer token</label>
      <input id="token" type="password" autocomplete="off" data-testid="login-token" value=${token} onInput=${(e) => setToken(e.currentTarget.value)} />
      ${error && html`<div class="form-error" role="alert" data-testid="login-error">${error}</div>`}
      <button type="submit" data-testid="login-submit">Log in</button>
      <p class="muted">The token stays in this tab (sessionStorage) and is sent only to goniod.</p>
    </form>
  </main>`;
}

const VIEWS = [['run', 'Instrument & queue'], ['scans', 'Scans'], ['alerts', 'Alerts'], ['samples', 'Samples'], ['twin', 'Twin']];
// The nav entry a route belongs to.
const NAV_OF = { scan: 'scans', compare: 'scans', sample: 'samples' };

// The route in the URL's hash ("#/scan/12"): it survives a reload, and the login page leaves it
// alone, so a link opens its view once the token is given.
function useRoute() {
  const [route, setRoute] = useState(() => parseRoute(location.hash));
  useEffect(() => {
    const on = () => setRoute((cur) => (routeHash(cur) === routeHash(parseRoute(location.hash)) ? cur : parseRoute(location.hash)));
    addEventListener('hashchange', on);
    return () => removeEventListener('hashchange', on);
  }, []);
  // The view changes at once (as a click expects), and the hash follows (its hashchange
  // gives the same route again).
  const navigate = useCallback((r) => {
    const h = routeHash(r);
    setRoute((cur) => (routeHash(cur) === h ? cur : parseRoute(h)));
    if (location.hash !== h) location.hash = h;
  }, []);
  return [route, navigate];
}

function Dashboard({ token, onLogout, onRefused }) {
  const [link, setLink] = useState('connecting');
  const [me, setMe] = useState(null);
  const [route, navigate] = useRoute();
  const view = route.view;
  const setView = (v) => navigate({ view: v, params: {} });
  const [reloads, setReloads] = useState(0); // bumps when the views should read goniod again
  const [status, setStatus] = useState(null);
  const [queue, setQueue] = useState(null);
  const [alerts, setAlerts] = useState([]);
  const [samples, setSamples] = useState([]);
  const [thresholds, setThresholds] = useState(null);
  const [scanId, setScanId] = useState(null);
  const [toast, setToast] = useState(null);
  const bus = useRef(makeBus()).current;
  const rpc = useRef(null);
  // Views opened by a link mount with the page, and their effects run before this one's,
  // which makes the connection: their calls wait for it.
  const made = useRef(null);
  if (!made.current) { let resolve; made.current = { promise: new Promise((r) => { resolve = r; }), resolve }; }
  const call = useCallback((m, p) => (rpc.current ? rpc.current.call(m, p) : made.current.promise.then((r) => r.call(m, p))), []);
  const notify = useCallback((msg) => { setToast(msg); setTimeout(() => setToast((t) => (t === msg ? null : t)), 6000); }, []);

  // Answers may overtake each other (the poll and a scan.state's refresh): an older answer
  // never replaces a newer one, or a resumed scan could show as paused again.
  const queueAsked = useRef(0), queueShown = useRef(0);
  const refreshQueue = useCallback(async () => {
    const asked = ++queueAsked.current;
    const q = await call('queue.status'); // waiting: queued, paused and interrupted scans, in order
    if (asked > queueShown.current) {
      queueShown.current = asked;
      setQueue(q);
    }
    return q;
  }, []);

  useEffect(() => {
    let timer = null, opened = false;
    const reload = async () => {
      try {
        const [st, q, al, sm, info] = await Promise.all([
          call('instrument.status'), refreshQueue(), call('alert.list', { limit: 200 }), call('sample.list', { limit: 1000 }), call('system.info')]);
        setStatus(st);
        setAlerts(mergeAlerts([], al));
        setSamples(sm);
        setThresholds(info.divergence);
        setScanId((cur) => cur ?? (q.running ? q.running.id : null));
        if (opened) setReloads((n) => n + 1); // a reconnection: the views read goniod again
        opened = true;
      } catch (e) { notify(e.message); }
    };
    const progress = new Map(); // scan → its latest progress, applied together
    const applyProgress = coalesce(() => {
      const all = new Map(progress);
      progress.clear();
      setQueue((q) => (q && q.running && all.has(q.running.id) ? { ...q, running: { ...q.running, ...all.get(q.running.id), id: q.running.id } } : q));
    }, 250);
    const applyStatus = coalesce(setStatus, 250);
    const r = new Rpc({
      url: wsUrl(location), token, topics: ['progress', 'points', 'alerts', 'state'],
      onStatus: (s, detail) => {
        setLink(s);
        if (s === 'open') setMe(detail);
        if (s === 'refused') onRefused(detail);
      },
      onOpen: reload,
      onNotification: (method, params) => {
        bus.emit(method, params);
        if (method === 'alert') setAlerts((a) => mergeAlerts(a, [params]));
        else if (method === 'instrument.state') applyStatus(params);
        else if (method === 'scan.state') refreshQueue().catch(() => {});
        else if (method === 'scan.progress') { progress.set(params.scan, params); applyProgress(); }
      },
    });
    rpc.current = r;
    made.current.resolve(r);
    r.start();
    // Arm positions while a scan moves them (instrument.state is sent on state changes only),
    // and the queue, which other clients change without a notification (a scan queued by
    // gonioctl, a reorder).
    let ticks = 0;
    timer = setInterval(() => {
      if (!r.ready) return;
      call('instrument.status').then(setStatus, () => {});
      if (++ticks % 2 === 0) refreshQueue().catch(() => {});
    }, 1000);
    return () => { clearInterval(timer); r.stop(); };
  }, [token]);

  const role = me ? me.role : 'none';
  const open = (id) => navigate({ view: 'scan', id, params: {} });
  const nav = NAV_OF[view] || view;
  const count = unacknowledged(alerts);
  return html`<div class="app">
    <header>
      <h1>gonio</h1>
      <nav aria-label="views">${VIEWS.map(([k, label]) => html`<button class=${nav === k ? 'active' : ''} aria-current=${nav === k ? 'page' : undefined} data-testid=${`nav-${k}`} onClick=${() => setView(k)}>${label}${k === 'alerts' ? html` <span class=${`count${count ? ' hot' : ''}`} data-testid="alert-count" aria-label="unacknowledged alerts">${count}</span>` : ''}</button>`)}</nav>
      <span class=${`link link-${link}`} data-testid="link-state">${link === 'open' ? 'connected' : link}</span>
      <span class="who" data-testid="whoami">${me ? `${me.name} (${me.role})` : ''}</span>
      ${can(role, 'control') && status && html`<button class="stop" data-testid="instrument-stop" title="Stop the arms and pause the running scan" onClick=${() => call('instrument.stop').catch((e) => notify(e.message))}>Stop</button>`}
      <button onClick=${onLogout}>Log out</button>
    </header>
    ${link !== 'open' && link !== 'connecting' && html`<div class="banner" role="status" data-testid="disconnected">Disconnected from goniod — reconnecting…</div>`}
    ${toast && html`<div class="toast" role="alert" data-testid="toast">${toast}</div>`}
    <main>
      ${view === 'run' && html`<div class="grid">
        <div class="col">
          <${InstrumentPanel} status=${status} role=${role} call=${call} notify=${notify} />
          <${QueuePanel} queue=${queue} role=${role} call=${call} notify=${notify} selected=${scanId} onSelect=${setScanId} />
          ${can(role, 'submit') && html`<section class="panel"><h2>Submit a scan</h2>
            <${SubmitForm} samples=${samples} call=${call} onSubmitted=${(s) => { setScanId(s.id); refreshQueue().catch(() => {}); }} /></section>`}
        </div>
        <div class="col wide"><${ScanPanel} scanId=${scanId} call=${call} bus=${bus} thresholds=${thresholds} notify=${notify} /></div>
      </div>`}
      ${view === 'scans' && html`<${ScansPanel} params=${route.params} samples=${samples} call=${call} navigate=${navigate} reloads=${reloads} />`}
      ${view === 'scan' && html`<${ScanView} key=${route.id} scanId=${route.id} samples=${samples} status=${status} role=${role} call=${call} bus=${bus} thresholds=${thresholds} notify=${notify} navigate=${navigate} reloads=${reloads} />`}
      ${view === 'compare' && html`<${ComparePanel} ids=${route.ids} params=${route.params} samples=${samples} call=${call} navigate=${navigate} notify=${notify} />`}
      ${view === 'sample' && html`<${SampleView} sampleId=${route.id} samples=${samples} call=${call} navigate=${navigate} reloads=${reloads} />`}
      ${view === 'alerts' && html`<${AlertsPanel} alerts=${alerts} role=${role} call=${call} notify=${notify} onShowScan=${open} />`}
      ${view === 'samples' && html`<${SamplesPanel} samples=${samples} role=${role} call=${call} onCreated=${(s) => setSamples((l) => [...l, s])} />`}
      ${view === 'twin' && (can(role, 'predict') ? html`<${TwinPanel} call=${call} />` : html`<section class="panel"><p>The twin playground needs a technician's token.</p></section>`)}
    </main>
  </div>`;
}

function App() {
  const [token, setToken] = useState(() => sessionStorage.getItem(TOKEN_KEY));
  const [error, setError] = useState(null);
  if (!token) return html`<${Login} error=${error} onLogin=${(t) => { sessionStorage.setItem(TOKEN_KEY, t); setError(null); setToken(t); }} />`;
  const logout = (why) => { sessionStorage.removeItem(TOKEN_KEY); setError(typeof why === 'string' ? why : null); setToken(null); };
  return html`<${Dashboard} token=${token} onLogout=${() => logout()} onRefused=${(why) => logout(why)} />`;
}

render(html`<${App} />`, document.getElementById('app'));
