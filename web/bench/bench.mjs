// The dashboard's figures (web/README.md, "Benchmark"): bundle size gzipped, first paint on
// loopback, a 1,000-point scan streamed into the plot with the frame rate measured in
// headless Chromium while it updates, the finished scan opened by its link, and the scans'
// history with 10,000 scans in the store. Prints the figures; asserts nothing.
//   node bench/bench.mjs --goniod PATH [--dist DIR] [--points 1000] [--time-scale 0.05] [--scans 10000]
import { readdirSync, readFileSync } from 'node:fs';
import { gzipSync } from 'node:zlib';
import { join, dirname, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import puppeteer from 'puppeteer-core';
import { Goniod, chromiumPath, launchArgs } from '../test/browser/goniod.mjs';

const here = dirname(fileURLToPath(import.meta.url));
const arg = (name, fallback) => {
  const i = process.argv.indexOf(name);
  return i > 0 ? process.argv[i + 1] : fallback;
};
const exe = arg('--goniod', process.env.GONIO_GONIOD);
const dist = resolve(arg('--dist', process.env.GONIO_WEB_DIST || join(here, '..', 'dist')));
const npoints = Number(arg('--points', 1000));
const timeScale = Number(arg('--time-scale', 0.2));
if (!exe) throw new Error('--goniod PATH (or GONIO_GONIOD) names the goniod binary');
const chromium = chromiumPath();
if (!chromium) throw new Error('no Chromium (install the chromium package or set GONIO_CHROMIUM)');

const median = (xs) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];

// 1. The bundle.
const assets = readdirSync(join(dist, 'assets')).filter((f) => /\.(js|css)$/.test(f));
let raw = 0, gz = 0;
for (const f of assets) {
  const b = readFileSync(join(dist, 'assets', f));
  raw += b.length;
  gz += gzipSync(b, { level: 9 }).length;
}
console.log(`bundle: ${assets.join(', ')}: ${(raw / 1024).toFixed(1)} kB, ${(gz / 1024).toFixed(1)} kB gzipped (target ≤ 200 kB)`);

const g = await new Goniod({ exe, webRoot: dist, timeScale }).start();
const browser = await puppeteer.launch({ executablePath: chromium, headless: true, args: launchArgs() });
try {
  // 2. First paint of a cold page (a fresh browser context each time: nothing cached).
  const paints = [], ready = [];
  for (let i = 0; i < 5; i++) {
    const ctx = await browser.createBrowserContext();
    const p = await ctx.newPage();
    await p.setViewport({ width: 1280, height: 800 });
    await p.goto(g.url, { waitUntil: 'load' });
    await p.waitForSelector('[data-testid="login-token"]');
    const fp = await p.evaluate(() => {
      const e = performance.getEntriesByName('first-contentful-paint')[0] || performance.getEntriesByName('first-paint')[0];
      return e ? e.startTime : null;
    });
    paints.push(fp);
    await p.type('[data-testid="login-token"]', g.adminToken);
    const t0 = Date.now();
    await p.click('[data-testid="login-submit"]');
    await p.waitForSelector('[data-testid="instrument-state"]');
    ready.push(Date.now() - t0);
    await ctx.close();
  }
  const painted = paints.filter((x) => x !== null); // a page may report no paint entry
  console.log(`first contentful paint (loopback, cold): median ${painted.length ? median(painted).toFixed(0) : '–'} ms of ${paints.map((x) => (x === null ? 'none' : x.toFixed(0))).join(', ')} (target ≤ 1000 ms)`);
  console.log(`login to the instrument panel: median ${median(ready)} ms`);

  // 3. A scan of npoints geometries streamed into the plot.
  await g.call('sample.create', { name: 'bench', bsdf: 'lambert:albedo=0.6' });
  const step = 0.1;
  // It starts a few seconds from now, once the page shows it and records.
  const notBefore = new Date(Date.now() + 4000).toISOString();
  const scan = await g.call('scan.submit', { sample: 'bench', grids: `in=45;out=-30:${(-30 + step * (npoints - 1)).toFixed(1)}:${step}`, wavelengths: '400:700:10', reference: 'start', not_before: notBefore });
  const page = await browser.newPage();
  await page.setViewport({ width: 1280, height: 800 });
  await page.goto(g.url);
  await page.type('[data-testid="login-token"]', g.adminToken);
  await page.click('[data-testid="login-submit"]');
  await page.waitForSelector(`[data-testid="queue-item-${scan.id}"] button.link`);
  await page.click(`[data-testid="queue-item-${scan.id}"] button.link`);
  // Frames and point counts, recorded in the page from the first point to the last.
  await page.evaluate((total) => {
    const host = () => document.querySelector('[data-testid="scan-plot"]');
    const s = (window.__bench = { frames: [], first: null, done: null, total });
    const tick = (t) => {
      const n = Number(host()?.dataset.points || 0);
      if (n > 0 && s.first === null) s.first = t;
      if (s.first !== null && s.done === null) s.frames.push(t);
      if (n >= total && s.done === null) s.done = t;
      if (s.done === null) requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  }, npoints);
  await page.waitForFunction(() => window.__bench.done !== null, { timeout: 600000, polling: 500 });
  const r = await page.evaluate(() => {
    const s = window.__bench;
    let worst = 0;
    for (let i = 1; i < s.frames.length; i++) worst = Math.max(worst, s.frames[i] - s.frames[i - 1]);
    return { seconds: (s.done - s.first) / 1000, frames: s.frames.length, worst, shown: Number(document.querySelector('[data-testid="scan-plot"]').dataset.points) };
  });
  console.log(`${npoints}-point scan: ${r.shown} points shown, streamed over ${r.seconds.toFixed(1)} s at ${(r.frames / r.seconds).toFixed(1)} frames/s (longest frame ${r.worst.toFixed(0)} ms; target ≥ 30 frames/s)`);
  await page.screenshot({ path: join(process.cwd(), 'bench-1000.png') });

  // 4. The finished scan opened by its link (#/scan/ID) from another view: scan.get, its
  // points in pages of 1,000 and the first draw.
  await until(async () => (await g.call('scan.get', { scan: scan.id })).state === 'completed');
  const opens = [];
  for (let i = 0; i < 5; i++) opens.push(await timeView(page, '#/scans', `#/scan/${scan.id}`,
    'scan', [scan.id, npoints]));
  console.log(`a finished ${npoints}-point scan opened by its link, drawn: median ${median(opens).toFixed(0)} ms of ${opens.map((x) => x.toFixed(0)).join(', ')} (target ≤ 1000 ms)`);
} finally {
  await browser.close();
  await g.dispose();
}

// 5. The history's first page with `--scans` (10,000) scans in the store, on a goniod of its
// own. They are submitted and cancelled in JSON-RPC batches (a plan that is not due, so none
// runs); the store writes with synchronous = normal, which only makes the filling faster.
{
  const nscans = Number(arg('--scans', 10000));
  const h = await new Goniod({ exe, webRoot: dist, timeScale, extra: '\n[store]\nsynchronous = "normal"\n' }).start();
  const b = await puppeteer.launch({ executablePath: chromium, headless: true, args: launchArgs() });
  try {
    await h.call('sample.create', { name: 'history', bsdf: 'lambert:albedo=0.6' });
    const t0 = Date.now();
    for (let done = 0; done < nscans;) {
      const n = Math.min(100, nscans - done);
      const ids = (await batch(h, Array.from({ length: n }, (_, i) => ['scan.submit', { sample: 'history', name: `history ${done + i}`, grids: 'in=45;out=0', not_before: '2099-01-01T00:00:00Z' }]))).map((r) => r.id);
      await batch(h, ids.map((id) => ['scan.cancel', { scan: id, reason: 'bench' }]));
      done += n;
    }
    console.log(`history: ${nscans} scans stored in ${((Date.now() - t0) / 1000).toFixed(1)} s`);
    const page = await b.newPage();
    await page.setViewport({ width: 1280, height: 800 });
    await page.goto(h.url);
    await page.type('[data-testid="login-token"]', h.adminToken);
    await page.click('[data-testid="login-submit"]');
    await page.waitForSelector('[data-testid="instrument-state"]');
    for (const [what, hash, want] of [['first page', '#/scans', 25], ['first page, label text matching none (every row read)', '#/scans?text=no%20such%20label', 0], ['page 400', '#/scans?page=400', Math.min(25, Math.max(0, nscans - 399 * 25))]]) {
      const ts = [];
      for (let i = 0; i < 5; i++) ts.push(await timeView(page, '#/alerts', hash, 'rows', [want]));
      console.log(`history, ${nscans} scans, ${what}: median ${median(ts).toFixed(0)} ms of ${ts.map((x) => x.toFixed(0)).join(', ')} (target for the first page ≤ 200 ms)`);
    }
  } finally {
    await b.close();
    await h.dispose();
  }
}

async function until(ok) {
  for (const end = Date.now() + 600000; !(await ok());) {
    if (Date.now() > end) throw new Error('timed out');
    await new Promise((r) => setTimeout(r, 200));
  }
}

// JSON-RPC calls in one batch over POST /rpc: their results in order (an error throws).
async function batch(gd, calls) {
  const r = await fetch(`${gd.url}/rpc`, {
    method: 'POST',
    headers: { 'Content-Type': 'application/json', Authorization: `Bearer ${gd.adminToken}` },
    body: JSON.stringify(calls.map(([method, params], id) => ({ jsonrpc: '2.0', id, method, params }))),
  });
  const out = await r.json();
  out.sort((x, y) => x.id - y.id);
  for (const x of out) if (x.error) throw new Error(`${calls[x.id][0]}: ${x.error.message}`);
  return out.map((x) => x.result);
}

// Milliseconds from setting the hash to the view being ready at an animation frame, in the
// page, after first going to `from` (so the view mounts afresh). ready: 'rows' (args: the
// history's row count) or 'scan' (args: scan id, points drawn).
async function timeView(page, from, to, ready, args) {
  await page.evaluate((h) => { location.hash = h; }, from);
  await page.waitForFunction((h) => location.hash === h, {}, from);
  await new Promise((r) => setTimeout(r, 100));
  // No eval in the page (its CSP refuses it): the conditions are named.
  return page.evaluate((h, kind, a) => new Promise((resolve, reject) => {
    const ok = kind === 'rows'
      ? (want) => document.querySelectorAll('[data-testid="scans"][data-loaded="true"] [data-testid="scan-row"]').length === want
        && !!document.querySelector('[data-testid="scans"][data-loaded="true"]')
      : (id, n) => document.querySelector(`[data-testid="scan-view"][data-scan="${id}"] [data-testid="scan-plot"]`)?.dataset.points === String(n)
        && !!document.querySelector('[data-testid="scan-view"] [data-testid="scan-plot"] canvas');
    const t0 = performance.now();
    location.hash = h;
    const tick = () => {
      if (ok(...a)) resolve(performance.now() - t0);
      else if (performance.now() - t0 > 60000) reject(new Error(`${h}: not ready after 60 s`));
      else requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  }), to, ready, args);
}
