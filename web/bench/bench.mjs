// The dashboard's figures (web/README.md, "Benchmark"): bundle size gzipped, first paint on
// loopback, and a 1,000-point scan streamed into the plot with the frame rate measured in
// headless Chromium while it updates. Prints the figures; asserts nothing.
//   node bench/bench.mjs --goniod PATH [--dist DIR] [--points 1000] [--time-scale 0.05]
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
  console.log(`first contentful paint (loopback, cold): median ${median(paints).toFixed(0)} ms of ${paints.map((x) => x.toFixed(0)).join(', ')} (target ≤ 1000 ms)`);
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
} finally {
  await browser.close();
  await g.dispose();
}
