// A real `goniod` on the mock instrument for the browser tests and the benchmark: its own
// state dir, an HTTP listener serving the built dashboard, and the same port after a restart
// (the page must find it again).
import { spawn } from 'node:child_process';
import { mkdtempSync, readFileSync, writeFileSync, existsSync, rmSync, openSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { setTimeout as sleep } from 'node:timers/promises';

export const TRUE_SAMPLE = 'lambert:albedo=0.6'; // the mock lab's hidden sample

export class Goniod {
  // exe: the goniod binary; webRoot: the built dist/ (null: server.web_root not set, so goniod
  // looks for its own); timeScale: the mock's real seconds per virtual second (small: fast
  // scans); sample: the mock lab's hidden sample; lab: more keys of the mock lab
  // ([instrument.motion], e.g. its detector's full scale); tls: { cert, key } files for an
  // https:// listener instead of the http:// one.
  constructor({ exe, webRoot, timeScale = 0.3, extra = '', sample = TRUE_SAMPLE, lab = '', tls = null }) {
    Object.assign(this, { exe, webRoot, timeScale, extra, sample, lab, tls });
    this.state = mkdtempSync(join(tmpdir(), 'gonio-web-'));
    this.port = 0;
  }

  config() {
    return `[server]
listen = ["${this.tls ? 'https' : 'http'}://127.0.0.1:${this.port}"]
${this.webRoot === null ? '' : `web_root = "${this.webRoot}"\n`}log_level = "debug"

[instrument.motion]
driver = "mock"
sample = "${this.sample}"
time_scale = ${this.timeScale}
${this.lab}

[instrument.photometer]
driver = "mock"

[twin]
threads = 1
rel_se = 0.01
replicates = 8
${this.tls ? `\n[server.tls]\ncert = "${this.tls.cert}"\nkey = "${this.tls.key}"\n` : ''}${this.extra}`;
  }

  async start() {
    writeFileSync(join(this.state, 'test.toml'), this.config());
    rmSync(join(this.state, 'endpoints.json'), { force: true });
    const log = openSync(join(this.state, 'goniod.log'), 'a');
    this.proc = spawn(this.exe, ['--state-dir', this.state, '--config', join(this.state, 'test.toml')], { stdio: ['ignore', log, log] });
    this.exited = new Promise((resolve) => this.proc.on('exit', (code, sig) => resolve(code ?? 128)));
    const until = Date.now() + 20000;
    while (!existsSync(join(this.state, 'endpoints.json'))) {
      if (this.proc.exitCode !== null) throw new Error(`goniod exited at start: ${this.log()}`);
      if (Date.now() > until) throw new Error(`goniod did not come up: ${this.log()}`);
      await sleep(50);
    }
    const ep = JSON.parse(readFileSync(join(this.state, 'endpoints.json'), 'utf8'));
    const scheme = this.tls ? 'https' : 'http';
    const http = ep.listen.find((u) => u.startsWith(`${scheme}://`));
    this.port = Number(http.slice(http.lastIndexOf(':') + 1));
    this.url = `${scheme}://127.0.0.1:${this.port}`;
    this.adminToken = readFileSync(join(this.state, 'admin.token'), 'utf8').trim();
    return this;
  }

  async stop(signal = 'SIGTERM') {
    if (!this.proc || this.proc.exitCode !== null) return;
    this.proc.kill(signal);
    const t = setTimeout(() => this.proc.kill('SIGKILL'), 20000);
    await this.exited;
    clearTimeout(t);
  }

  async restart() {
    await this.stop();
    await this.start();
  }

  log() {
    try { return readFileSync(join(this.state, 'goniod.log'), 'utf8').slice(-4000); } catch { return ''; }
  }

  // One JSON-RPC call over POST /rpc.
  async call(method, params = {}, token = this.adminToken) {
    const r = await fetch(`${this.url}/rpc`, {
      method: 'POST',
      headers: { 'Content-Type': 'application/json', Authorization: `Bearer ${token}` },
      body: JSON.stringify({ jsonrpc: '2.0', id: 1, method, params }),
    });
    const j = await r.json();
    if (j.error) throw Object.assign(new Error(`${method}: ${j.error.message}`), { rpc: j.error });
    return j.result;
  }

  async token(name, role) {
    return (await this.call('auth.create_token', { name, role })).token;
  }

  async dispose() {
    await this.stop('SIGKILL');
    rmSync(this.state, { recursive: true, force: true });
  }
}

// The browser the tests drive: GONIO_BROWSER=chromium (the default) or firefox.
export function browserName() {
  const name = process.env.GONIO_BROWSER || 'chromium';
  if (name !== 'chromium' && name !== 'firefox') throw new Error(`GONIO_BROWSER=${name}: chromium or firefox`);
  return name;
}

// The system's Chromium, headless; puppeteer-core drives it (no browser is downloaded).
export function chromiumPath() {
  for (const p of [process.env.GONIO_CHROMIUM, '/usr/bin/chromium', '/usr/bin/chromium-browser'])
    if (p && existsSync(p)) return p;
  return null;
}

// The system's Firefox (Debian's firefox-esr), driven over WebDriver BiDi.
export function firefoxPath() {
  for (const p of [process.env.GONIO_FIREFOX, '/usr/bin/firefox-esr', '/usr/bin/firefox'])
    if (p && existsSync(p)) return p;
  return null;
}

export function launchArgs() {
  // --no-sandbox: CI runs as root, where Chromium's sandbox refuses to start.
  return ['--headless=new', '--no-sandbox', '--disable-gpu', '--disable-dev-shm-usage', '--no-first-run', '--window-size=1280,800'];
}

// Starts `name` headless with a home and a profile of its own in a temporary directory, so
// that a run leaves nothing behind (Firefox writes ~/.config/mozilla, ~/.cache/mozilla and
// ~/Downloads; Chromium ~/.config/chromium). close() ends it and removes the directory.
export async function launchBrowser(puppeteer, name, executablePath) {
  const home = mkdtempSync(join(tmpdir(), `gonio-${name}-`));
  const common = { executablePath, headless: true, userDataDir: join(home, 'profile'), env: { ...process.env, HOME: home } };
  try {
    const browser = await puppeteer.launch(name === 'firefox' ? { ...common, browser: 'firefox' } : { ...common, args: launchArgs() });
    return { browser, close: async () => { try { await browser.close(); } finally { rmSync(home, { recursive: true, force: true }); } } };
  } catch (e) {
    rmSync(home, { recursive: true, force: true });
    throw e;
  }
}
