// Adaptive scans in a real headless browser against a real `goniod --mock` whose hidden sample
// is a glossy conductor: the submit form's adaptive plan (its errors at their fields), the
// twin's choices arriving on the β plot and in the list, the uncertainty shrinking towards its
// target, the final state; a finished scan's page seeded from scan.get; and a model that
// cannot describe the sample, stopped at max_points with the misfit said. GONIO_BROWSER picks
// the browser as for dashboard.test.mjs; exits 77 (skipped) without it.
import { describe, it, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { copyFileSync, mkdirSync } from 'node:fs';
import { join, resolve, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import puppeteer from 'puppeteer-core';
import { Goniod, browserName, chromiumPath, firefoxPath, launchBrowser } from './goniod.mjs';

const here = dirname(fileURLToPath(import.meta.url));
const name = browserName();
const firefox = name === 'firefox';
const executable = firefox ? firefoxPath() : chromiumPath();
if (!executable) {
  console.log(firefox ? 'SKIP: no Firefox (install the firefox-esr package, or set GONIO_FIREFOX)'
    : 'SKIP: no Chromium (install the chromium package, or set GONIO_CHROMIUM)');
  process.exit(77);
}
const exe = process.env.GONIO_GONIOD;
const webRoot = resolve(process.env.GONIO_WEB_DIST || join(here, '..', '..', 'dist'));
const artifacts = resolve(process.env.GONIO_ARTIFACTS || (firefox ? 'artifacts/firefox' : 'artifacts'));
mkdirSync(artifacts, { recursive: true });
if (!exe) throw new Error('GONIO_GONIOD must name the goniod binary');

const T = 60000; // one step's longest wait; never a measurement
const SCAN = 240000; // an adaptive scan's, refitting at every point on a busy 2-core machine

// The hidden sample and a model that frees its roughness; readings whose noise the points' u
// states (no saturation, the mock's own twin estimate precise).
const HIDDEN = 'conductor:alpha=0.05,eta=0.2,k=3.9';
const MODEL = 'conductor:alpha=?,eta=0.2,k=3.9';
// The mock's own detector noise (its default gain), so that the seeds alone do not reach the
// target and the loop's own choices follow them.
const LAB = 'full_scale_counts = 1e12\nestimator = { rel_se = 0.002, max_samples = 1048576, replicates = 8 }';
const TARGET = 0.0005;
const GRID = 'in=45;out=15:75:1';

describe('adaptive scans', () => {
  let g, launched, page, tech, scanId;
  const problems = [];
  const $ = (id) => `[data-testid="${id}"]`;
  const shot = (n) => page.screenshot({ path: join(artifacts, `adaptive-${n}.png`), fullPage: true });
  const fill = async (sel, text) => {
    await page.$eval(sel, (e) => { e.value = ''; e.dispatchEvent(new Event('input', { bubbles: true })); });
    await page.type(sel, text);
  };
  // Waits until the element `sel` has data-`key` that is (op: 'eq', 'ge', 'in') `want`
  // (numbers compared as numbers).
  const waitData = (sel, key, op, want, timeout = T) => page.waitForFunction((s, k, o, w) => {
    const e = document.querySelector(s);
    if (!e || e.dataset[k] === undefined) return false;
    const v = typeof w === 'number' || (o === 'ge') ? Number(e.dataset[k]) : e.dataset[k];
    return o === 'eq' ? v === w : o === 'in' ? w.includes(v) : v >= w;
  }, { timeout }, sel, key, op, want);

  before(async () => {
    g = await new Goniod({ exe, webRoot, timeScale: 0.1, sample: HIDDEN, lab: LAB }).start();
    tech = await g.token('lab-tech', 'technician');
    await g.call('sample.create', { name: 'brushed' }); // no twin of its own: the loop's model is the one
    launched = await launchBrowser(puppeteer, name, executable);
    page = await launched.browser.newPage();
    await page.setViewport({ width: 1280, height: 800 });
    page.on('pageerror', (e) => problems.push(`pageerror: ${e.message}`));
    page.on('console', (m) => { if (/Content.Security.Policy|Refused to/.test(m.text())) problems.push(`console: ${m.text()}`); });
  });

  after(async () => {
    if (launched) await launched.close();
    if (g) {
      await g.stop();
      copyFileSync(join(g.state, 'goniod.log'), join(artifacts, 'adaptive-goniod.log'));
      await g.dispose();
    }
  });

  it('names a bad adaptive plan\'s field in the form', async () => {
    await page.goto(g.url, { waitUntil: 'load' });
    await page.waitForSelector($('login-token'), { timeout: T });
    await page.type($('login-token'), tech);
    await page.click($('login-submit'));
    await page.waitForSelector(`${$('scan-submit')} select[name=sample] option`, { timeout: T });
    const form = $('scan-submit');
    await fill(`${form} textarea[name=grids]`, GRID);
    await fill(`${form} input[name=wavelengths]`, '450,550,650');
    await page.select(`${form} select[name=adaptive]`, 'parameters');
    await page.waitForSelector(`${form} input[name=model]`, { timeout: T });
    // No model: goniod says it is required, at the model's field.
    await page.click($('scan-submit-button'));
    await page.waitForSelector($('field-error-model'), { timeout: T });
    assert.match(await page.$eval($('field-error-model'), (e) => e.textContent), /adaptive\.model/);
    assert.equal(await page.$eval(`${form} input[name=model]`, (e) => e.getAttribute('aria-invalid')), 'true');
    // More points than three readings of every candidate: at the max_points field.
    await fill(`${form} input[name=model]`, MODEL);
    await fill(`${form} input[name=max_points]`, '500');
    await page.click($('scan-submit-button'));
    await page.waitForSelector($('field-error-max_points'), { timeout: T });
    assert.match(await page.$eval($('field-error-max_points'), (e) => e.textContent), /adaptive\.max_points/);
    assert.equal(await page.$(`${$('field-error-model')}`), null, 'the model\'s error went with the fix');
    await shot('01-bad-max-points');
  });

  it('shows the twin\'s choices and the uncertainty shrinking as the scan runs, then its target reached', async () => {
    const form = $('scan-submit');
    await fill(`${form} input[name=target_rel_u]`, String(TARGET));
    await fill(`${form} input[name=max_points]`, '60');
    await page.click($('scan-submit-button'));
    await page.waitForSelector(`${$('queue')} li[data-state], ${form} .form-error, ${form} .field-error`, { timeout: T });
    assert.equal(await page.$eval(form, (f) => f.querySelector('.form-error, .field-error')?.textContent ?? null), null);
    scanId = (await g.call('scan.list', { limit: 1 }))[0].id;
    // The panel appears with the scan, and the choices come in while it runs.
    await page.waitForSelector(`${$('adaptive')}[data-mode="parameters"]`, { timeout: T });
    await waitData($('adaptive-chosen'), 'count', 'ge', 3, SCAN);
    await shot('02-running');
    // The loop may reach its target before the points it had chosen are all in: the scan
    // ends after them.
    await waitData($('adaptive-state'), 'state', 'in', ['target_reached', 'max_points'], SCAN);
    await waitData($('adaptive'), 'scanState', 'eq', 'completed', SCAN);
    await shot('03-finished');
    const s = await g.call('scan.get', { scan: scanId });
    assert.equal(s.state, 'completed', JSON.stringify(s));
    assert.equal(s.adaptive.state, 'target_reached', JSON.stringify(s.adaptive));
    assert.equal(await page.$eval($('adaptive-state'), (e) => e.dataset.state), 'target_reached');
    assert.match(await page.$eval($('adaptive-state'), (e) => e.textContent), /target reached in \d+ points/);
    // Every point chosen is listed in order, the last one marked latest.
    const used = s.adaptive.points_used;
    await waitData($('adaptive-chosen'), 'count', 'eq', used);
    const picks = await page.$$eval($('adaptive-pick'), (l) => l.map((e) => ({ c: Number(e.dataset.candidate), r: Number(e.dataset.reading), latest: e.dataset.latest === 'true' })));
    const pts = (await g.call('scan.points', { scan: scanId, offset: 0, limit: 1000 })).points;
    assert.deepEqual(picks.map((p) => p.c), pts.map((p) => p.geometry_index));
    assert.deepEqual(picks.map((p) => p.r), pts.map((p) => p.repeat + 1));
    assert.deepEqual(picks.map((p) => p.latest), pts.map((_, i) => i === pts.length - 1));
    // The uncertainty against the points used: several rows from the progress events, one
    // series (alpha), drawn.
    await waitData($('adaptive-plot'), 'rows', 'ge', 2);
    assert.equal(await page.$eval($('adaptive-plot'), (e) => e.dataset.series), '1');
    assert.ok(await page.$(`${$('adaptive-plot')} canvas`), 'the u plot is drawn');
    const alpha = await page.$eval(`${$('adaptive-param')}[data-name$="alpha"]`, (e) => ({ rel: Number(e.dataset.rel), text: e.textContent }));
    assert.ok(alpha.rel > 0 && alpha.rel <= TARGET, `u/|alpha| ${alpha.rel}`);
    assert.match(alpha.text, /alpha = 0\.0\d+ ± /);
    // Beyond the seeds: the twin chose points of its own.
    assert.ok(used > 5, `${used} points`);
    assert.equal(await page.$($('adaptive-misfit')), null);
    // The β plot spans the candidates (15° to 75°) with the chosen points on it.
    assert.equal(await page.$eval($('scan-plot'), (e) => Number(e.dataset.points)), used);
  });

  it('opens a finished adaptive scan\'s page from its state in scan.get', async () => {
    await page.goto(`${g.url}/#/scan/${scanId}`, { waitUntil: 'load' });
    await page.waitForSelector(`${$('scan-view')}[data-scan="${scanId}"] ${$('adaptive')}`, { timeout: T });
    await waitData($('adaptive-state'), 'state', 'eq', 'target_reached');
    const used = (await g.call('scan.get', { scan: scanId })).adaptive.points_used;
    await waitData($('adaptive-chosen'), 'count', 'eq', used);
    await waitData($('adaptive-plot'), 'rows', 'ge', 1);
    assert.equal(await page.$$eval(`${$('adaptive-pick')}[data-latest="true"]`, (l) => l.length), 1);
    await shot('04-page');
  });

  it('says plainly that a model which cannot describe the sample misfits, stopped at max_points', async () => {
    const s = await g.call('scan.submit', {
      sample: 'brushed', name: 'misfit', grids: [GRID], wavelengths: '450,550,650',
      adaptive: { mode: 'parameters', model: 'lambert:albedo=?', target_rel_u: 0.01, max_points: 12 },
    });
    await page.goto(`${g.url}/#/scan/${s.id}`, { waitUntil: 'load' });
    await page.waitForSelector(`${$('scan-view')}[data-scan="${s.id}"] ${$('adaptive')}`, { timeout: T });
    await waitData($('adaptive'), 'scanState', 'eq', 'completed', SCAN);
    await waitData($('adaptive-state'), 'state', 'eq', 'max_points');
    await page.waitForSelector($('adaptive-misfit'), { visible: true, timeout: T });
    assert.match(await page.$eval($('adaptive-misfit'), (e) => e.textContent), /does not describe the data/);
    assert.match(await page.$eval($('adaptive-state'), (e) => e.textContent), /max_points \(12\)/);
    await waitData($('adaptive-chosen'), 'count', 'eq', 12);
    await shot('05-misfit');
  });

  it('shows a curve-mode scan\'s estimated error against its tolerance', async () => {
    const tolerance = 0.02;
    const s = await g.call('scan.submit', {
      sample: 'brushed', name: 'curve', grids: ['in=45;out=-20:80:1'], wavelengths: '550',
      adaptive: { mode: 'curve', tolerance, max_points: 101 },
    });
    await page.goto(`${g.url}/#/scan/${s.id}`, { waitUntil: 'load' });
    await page.waitForSelector(`${$('scan-view')}[data-scan="${s.id}"] ${$('adaptive')}[data-mode="curve"]`, { timeout: T });
    await waitData($('adaptive'), 'scanState', 'eq', 'completed', SCAN);
    const a = (await g.call('scan.get', { scan: s.id })).adaptive;
    await waitData($('adaptive-state'), 'state', 'eq', a.state);
    await waitData($('adaptive-error'), 'value', 'eq', String(a.estimated_error));
    assert.match(await page.$eval($('adaptive-error'), (e) => e.textContent), /estimated error [\d.]+ % \(tolerance 2 %\)/);
    await waitData($('adaptive-chosen'), 'count', 'eq', a.points_used);
    await waitData($('adaptive-plot'), 'rows', 'ge', 2);
    assert.equal(await page.$eval($('adaptive-plot'), (e) => e.dataset.series), '1');
    assert.equal(await page.$$($('adaptive-param')).then((l) => l.length), 0);
    await shot('06-curve');
  });

  it('met no page errors and no CSP violations', () => {
    assert.deepEqual(problems, []);
  });
});
