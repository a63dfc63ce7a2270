// The dashboard over https:// and wss:// in headless Chromium against a real goniod whose
// certificate a test CA made by the openssl command signed: the page loads, a technician logs
// in and the live link connects over wss://. Chromium trusts that certificate's key alone
// (--ignore-certificate-errors-spki-list: the SHA-256 of its public key, as RFC 7469's pins);
// any other certificate still fails. Firefox is not driven here: short of accepting every
// certificate it has no such switch, and that would test nothing.
import { describe, it, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync, execSync } from 'node:child_process';
import { mkdtempSync, rmSync, writeFileSync, chmodSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import puppeteer from 'puppeteer-core';
import { Goniod, chromiumPath, launchArgs } from './goniod.mjs';

const here = dirname(fileURLToPath(import.meta.url));
const chromium = chromiumPath();
if (process.env.GONIO_BROWSER === 'firefox' || !chromium) {
  console.log('SKIP: the TLS page runs in Chromium only (install the chromium package, or set GONIO_CHROMIUM)');
  process.exit(77);
}
const exe = process.env.GONIO_GONIOD;
if (!exe) throw new Error('GONIO_GONIOD must name the goniod binary');
const webRoot = resolve(process.env.GONIO_WEB_DIST || join(here, '..', '..', 'dist'));
const T = 60000; // the longest wait for one step, never a measurement

// A CA and a server certificate for 127.0.0.1 that it signed; the pin of the server's key.
function makePki(dir) {
  const sh = (cmd) => execSync(cmd, { cwd: dir, stdio: ['ignore', 'pipe', 'pipe'] });
  writeFileSync(join(dir, 'server.ext'), 'subjectAltName=IP:127.0.0.1\n');
  sh("openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -keyout ca.key -out ca.pem -subj '/CN=gonio web test CA' -days 2");
  sh("openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -keyout server.key -out server.csr -subj '/CN=goniod'");
  sh('openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 1 -out server.pem -extfile server.ext');
  chmodSync(join(dir, 'server.key'), 0o600);
  const pin = sh('openssl x509 -in server.pem -pubkey -noout | openssl pkey -pubin -outform der | openssl dgst -sha256 -binary | base64')
    .toString().trim();
  return { cert: join(dir, 'server.pem'), key: join(dir, 'server.key'), ca: join(dir, 'ca.pem'), pin };
}

describe('dashboard over https and wss', () => {
  let g, browser, home, pki;
  const pkiDir = mkdtempSync(join(tmpdir(), 'gonio-web-pki-'));

  before(async () => {
    pki = makePki(pkiDir);
    g = new Goniod({ exe, webRoot, tls: { cert: pki.cert, key: pki.key } });
    await g.start();
    home = mkdtempSync(join(tmpdir(), 'gonio-chromium-'));
    browser = await puppeteer.launch({
      executablePath: chromium, headless: true, userDataDir: join(home, 'profile'), env: { ...process.env, HOME: home },
      args: [...launchArgs(), `--ignore-certificate-errors-spki-list=${pki.pin}`],
    });
  });

  after(async () => {
    await browser?.close();
    await g?.dispose();
    for (const d of [home, pkiDir]) if (d) rmSync(d, { recursive: true, force: true });
  });

  it('is served over https and keeps its live link over wss', async () => {
    assert.match(g.url, /^https:\/\/127\.0\.0\.1:\d+$/);
    // curl with the CA: the certificate chain and name check out (what the pin does not test).
    const head = execFileSync('curl', ['-sS', '-o', '/dev/null', '-w', '%{http_code}', '--cacert', pki.ca, `${g.url}/`]).toString();
    assert.equal(head, '200');
    const page = await browser.newPage();
    const sockets = [];
    page.on('request', (r) => { if (r.url().startsWith('wss://') || r.url().startsWith('ws://')) sockets.push(r.url()); });
    const client = await page.createCDPSession();
    await client.send('Network.enable');
    client.on('Network.webSocketCreated', (e) => sockets.push(e.url));
    const $ = (id) => `[data-testid="${id}"]`;
    await page.goto(g.url, { waitUntil: 'load' });
    await page.waitForSelector($('login-token'), { timeout: T });
    await page.type($('login-token'), g.adminToken);
    await page.click($('login-submit'));
    await page.waitForSelector($('instrument-state'), { timeout: T });
    await page.waitForFunction((s) => document.querySelector(s)?.textContent === 'connected', { timeout: T }, $('link-state'));
    assert.ok(sockets.length > 0, 'the page opened no WebSocket');
    for (const u of sockets) assert.match(u, /^wss:\/\/127\.0\.0\.1:\d+\/ws/);
  });
});
