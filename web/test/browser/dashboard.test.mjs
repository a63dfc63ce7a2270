// The dashboard in a real headless browser against a real `goniod --mock`: one browser and
// one goniod for the whole file. GONIO_BROWSER picks the browser: chromium (the default;
// ctest's web.browser) or firefox (web.browser.firefox, over WebDriver BiDi). Screenshots go
// to $GONIO_ARTIFACTS (default: ./artifacts, ./artifacts/firefox). Exits 77 (skipped) when
// the browser is not installed.
import { describe, it, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { copyFileSync, mkdirSync, readFileSync } from 'node:fs';
import { join, resolve, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { setTimeout as sleep } from 'node:timers/promises';
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

const T = 60000; // the longest wait for one step: generous for a loaded 2-core CI machine; never a measurement

describe('dashboard', () => {
  let g, launched, browser, page, tech, viewer;
  const problems = []; // page errors and CSP violations, checked at the end

  const $ = (id) => `[data-testid="${id}"]`;
  const shot = (name) => page.screenshot({ path: join(artifacts, `${name}.png`), fullPage: true });
  // Replaces a field's text through input events, as a user would: a value set behind the
  // UI's back is put back by its next render.
  const fill = async (sel, text) => {
    await page.$eval(sel, (e) => { e.value = ''; e.dispatchEvent(new Event('input', { bubbles: true })); });
    await page.type(sel, text);
  };
  const attr = (sel, name) => page.$eval(sel, (e, n) => e.getAttribute(n), name);
  const points = () => page.$eval($('scan-plot'), (e) => Number(e.dataset.points || 0));
  const waitPoints = (n) => page.waitForFunction((s, k) => Number(document.querySelector(s)?.dataset.points || 0) >= k, { timeout: T }, $('scan-plot'), n);
  // Chromium reports a CSP violation on the console ("Refused to …", "… violates the following
  // Content Security Policy directive …"), Firefox as a page error ("Content-Security-Policy:
  // The page's settings blocked …"): both are caught. Firefox also reports a failed WebSocket
  // connection as a page error ("Firefox can’t establish a connection to the server at
  // ws://…"; Chromium's goes to the console): expected while goniod is stopped on purpose
  // (`down`), a problem at any other time.
  let down = false;
  const watch = (p, sink = problems) => {
    p.on('pageerror', (e) => { if (!(down && /establish a connection to the server at ws:/.test(e.message))) sink.push(`pageerror: ${e.message}`); });
    p.on('console', (m) => { if (/Content.Security.Policy|Refused to/.test(m.text())) sink.push(`console: ${m.text()}`); });
  };
  const login = async (p, token) => {
    await p.goto(g.url, { waitUntil: 'load' });
    await p.waitForSelector($('login-token'), { timeout: T });
    await p.type($('login-token'), token);
    await p.click($('login-submit'));
    await p.waitForSelector($('instrument-state'), { timeout: T });
    await p.waitForFunction((s) => document.querySelector(s)?.textContent === 'connected', { timeout: T }, $('link-state'));
  };

  // Polls goniod (or anything outside the page) until ok() holds.
  const until = async (what, ok) => {
    for (const end = Date.now() + T; !(await ok()); await sleep(100)) assert.ok(Date.now() < end, what);
  };

  // The form controls on the page without an accessible name: one needs a <label> (for= or
  // wrapping it) with text of its own, an aria-label, or an aria-labelledby naming text.
  const unlabelled = (p) => p.evaluate(() => {
    const own = (label) => {
      const c = label.cloneNode(true);
      for (const e of c.querySelectorAll('input, select, textarea')) e.remove();
      return c.textContent.trim() !== '';
    };
    const named = (e) => [...e.labels].some(own) || (e.getAttribute('aria-label') || '').trim() !== ''
      || (e.getAttribute('aria-labelledby') || '').split(/\s+/).some((id) => id && (document.getElementById(id)?.textContent || '').trim() !== '');
    return [...document.querySelectorAll('input:not([type=hidden]), select, textarea')].filter((e) => !named(e))
      .map((e) => e.id || e.name || e.outerHTML.slice(0, 80));
  });

  // Where the keyboard focus is: the focused control's data-testid (or tag and text), whether
  // it shows a focus ring, and whether it is the first or last control that Tab reaches. Tab
  // never goes past the last control here: Firefox then moves the focus to its own toolbar,
  // and neither a click in the page nor bringToFront gives it back to the page under BiDi.
  const focus = (p, sel = null) => p.evaluate((sel) => {
    const e = document.activeElement;
    if (!e || e === document.body || !document.hasFocus()) return null;
    const tabbable = [...document.querySelectorAll('button, input, select, textarea, a[href], [tabindex]')]
      .filter((c) => !c.disabled && c.tabIndex >= 0 && c.getClientRects().length > 0);
    const st = getComputedStyle(e);
    return {
      id: e.dataset.testid || `${e.tagName.toLowerCase()} ${(e.textContent || e.name || '').trim().slice(0, 20)}`,
      ring: e.matches(':focus-visible') && st.outlineStyle !== 'none' && parseFloat(st.outlineWidth) > 0,
      first: e === tabbable[0], last: e === tabbable[tabbable.length - 1], here: sel ? e.matches(sel) : false,
    };
  }, sel);
  const press = async (p, key) => {
    if (key !== 'Shift+Tab') return p.keyboard.press(key);
    await p.keyboard.down('Shift');
    await p.keyboard.press('Tab');
    await p.keyboard.up('Shift');
  };
  // Tab from the first control to the last: the focus stops, in order.
  const tabWalk = async (p) => {
    for (let i = 0; i < 300 && !(await focus(p))?.first; ++i) await press(p, 'Shift+Tab');
    const stops = [];
    for (let i = 0; i < 300; ++i) {
      const f = await focus(p);
      assert.ok(f, `the focus left the page after ${stops.map((s) => s.id).join(', ')}`);
      stops.push(f);
      if (f.last) return stops;
      await press(p, 'Tab');
    }
    assert.fail(`no last control after 300 Tabs: ${stops.map((s) => s.id).join(', ')}`);
  };
  // Moves the focus to `sel` with Tab (forward to the last control, then back with Shift+Tab).
  const tabTo = async (p, sel) => {
    for (const key of ['Tab', 'Shift+Tab']) {
      for (let i = 0; i < 300; ++i) {
        const f = await focus(p, sel);
        if (f?.here) return;
        if (f && (key === 'Tab' ? f.last : f.first)) break;
        await press(p, key);
      }
    }
    assert.fail(`${sel} is not reachable with Tab`);
  };

  before(async () => {
    g = await new Goniod({ exe, webRoot, timeScale: 0.5 }).start();
    tech = await g.token('lab-tech', 'technician');
    viewer = await g.token('lab-viewer', 'viewer');
    // The mock's true sample is lambert:albedo=0.6: "grey" diverges from it.
    await g.call('sample.create', { name: 'grey', bsdf: 'lambert:albedo=0.3' });
    launched = await launchBrowser(puppeteer, name, executable);
    browser = launched.browser;
    page = await browser.newPage();
    await page.setViewport({ width: 1280, height: 800 });
    watch(page);
  });

  after(async () => {
    if (launched) await launched.close();
    if (g) {
      await g.stop();
      copyFileSync(join(g.state, 'goniod.log'), join(artifacts, 'goniod.log')); // an artefact like the screenshots
      await g.dispose();
    }
  });

  it('serves the page with a strict CSP and logs in with a token', async () => {
    const res = await fetch(g.url + '/');
    const csp = res.headers.get('content-security-policy');
    assert.match(csp, /default-src 'self'/);
    assert.doesNotMatch(csp, /unsafe-inline|unsafe-eval/);
    assert.equal(res.headers.get('cache-control'), 'no-cache');
    await login(page, tech);
    assert.equal(await page.$eval($('whoami'), (e) => e.textContent), 'lab-tech (technician)');
    assert.equal(await page.evaluate(() => sessionStorage.getItem('gonio.token') !== null), true);
    assert.doesNotMatch(page.url(), /token|[0-9a-f]{64}/);
    await shot('01-logged-in');
  });

  // server.web_root not set: a build tree's goniod serves the tree's own dashboard, beside
  // its executable (<build>/bin/goniod → <build>/web/dist), and says so at start.
  const beside = resolve(dirname(exe), '..', 'web', 'dist');
  it('serves a build tree\'s own dashboard when server.web_root is not set', { skip: beside !== webRoot && `the dashboard under test (${webRoot}) is not beside goniod` }, async () => {
    const own = await new Goniod({ exe, webRoot: null }).start();
    try {
      const res = await fetch(own.url + '/');
      assert.equal(res.status, 200);
      assert.equal(await res.text(), readFileSync(join(webRoot, 'index.html'), 'utf8'));
      await until('goniod did not say which dashboard it serves', async () => /dashboard: /.test(own.log()));
      assert.match(own.log(), new RegExp(`dashboard: \\d+ files from ${webRoot.replace(/[.*+?^${}()|[\]\\]/g, '\\$&')} \\(beside goniod\\)`));
    } finally { await own.dispose(); }
  });

  it('shows the API error of a bad grid at the field', async () => {
    await page.waitForSelector(`${$('scan-submit')} select[name=sample] option`, { timeout: T });
    const grid = `${$('scan-submit')} textarea[name=grids]`;
    await fill(grid, 'in=45;out=-30:80:bad');
    await page.click($('scan-submit-button'));
    await page.waitForSelector($('field-error-grids'), { timeout: T });
    const text = await page.$eval($('field-error-grids'), (e) => e.textContent);
    assert.match(text, /grids\[0\]/);
    assert.equal(await attr(grid, 'aria-invalid'), 'true');
    await shot('02-bad-grid');
  });

  // Before the scan: its predictions would queue ahead of these in the (one-thread) twin pool.
  it('previews a sample\'s predicted curve, then creates it', async () => {
    await page.click($('nav-samples'));
    const form = $('sample-create');
    await page.waitForSelector(form, { timeout: T });
    await page.type(`${form} #f-name`, 'glossy');
    await page.type(`${form} #f-bsdf`, 'lambert:albedo=0.5+coat:alpha=0.05,ior=1.5');
    await page.click($('sample-preview'));
    await page.waitForSelector(`${$('sample-preview-plot')} canvas`, { timeout: T });
    await page.click(`${form} button[type=submit]`);
    await page.waitForFunction((s) => [...document.querySelectorAll(`${s} td`)].some((td) => td.textContent === 'glossy'), { timeout: T }, $('samples'));
    assert.equal((await g.call('sample.get', { sample: 'glossy' })).name, 'glossy');
    await shot('02a-samples');
  });

  it('predicts in the twin playground', async () => {
    await page.click($('nav-twin'));
    await page.waitForSelector(`${$('twin-form')} button[type=submit]`, { timeout: T });
    await fill(`${$('twin-form')} #f-grids`, 'in=45;out=-60:60:20');
    await fill(`${$('twin-form')} #f-wavelengths`, '500:600:50');
    await page.click(`${$('twin-form')} button[type=submit]`);
    await page.waitForSelector(`${$('twin-plot')} canvas, ${$('twin-form')} .form-error, ${$('twin-form')} .field-error`, { timeout: T });
    assert.equal(await page.$eval($('twin-form'), (f) => f.querySelector('.form-error, .field-error')?.textContent ?? null), null);
    await shot('02b-twin');
    await page.click($('nav-run'));
    await page.waitForSelector($('scan-plot'), { timeout: T });
  });

  it('submits a scan from the form and plots its points as they arrive', async () => {
    const grid = `${$('scan-submit')} textarea[name=grids]`;
    await fill(grid, 'in=45;out=-30:80:1');
    await page.click($('scan-submit-button'));
    await page.waitForSelector(`${$('queue')} ${$('queue-item-1')}, ${$('scan-submit')} .form-error, ${$('scan-submit')} .field-error`, { timeout: T });
    assert.equal(await page.$eval($('scan-submit'), (f) => f.querySelector('.form-error, .field-error')?.textContent ?? null), null);
    await page.waitForSelector(`${$('queue')} [data-state="running"]`, { timeout: T });
    await waitPoints(3);
    const first = await points();
    await waitPoints(first + 2);
    assert.ok((await points()) > first, 'more points after the first ones');
    await shot('03-scan-running');
  });

  it('pauses and resumes the scan', async () => {
    await page.click(`${$('queue')} [data-state="running"] ${$('scan-pause')}`);
    await page.waitForSelector(`${$('queue')} [data-state="paused"]`, { timeout: T });
    const held = await points();
    await shot('04-paused');
    // The scan's state is the server's: nothing is committed while paused (one point may
    // have been in progress when the pause arrived).
    const scan = (await g.call('scan.list', { state: 'paused' }))[0];
    assert.ok(scan && scan.points_done <= held + 1);
    await page.click(`${$('queue')} [data-state="paused"] ${$('scan-resume')}`);
    // goniod took the click (the scan left paused), then the row shows it running; if not,
    // the failure says what goniod and the row held.
    await until('the scan is still paused after Resume', async () => (await g.call('scan.get', { scan: scan.id })).state !== 'paused');
    await page.waitForSelector(`${$('queue')} [data-state="running"]`, { timeout: T }).catch(async (e) => {
      const got = await g.call('scan.get', { scan: scan.id });
      const row = await page.$eval($('queue'), (q) => q.outerHTML).catch(() => null);
      throw new Error(`${e.message}; goniod: scan ${scan.id} ${got.state} (${got.reason}); the queue: ${row}`);
    });
    await waitPoints(held + 2);
  });

  it('raises a divergence alert and acknowledges it', async () => {
    await page.waitForFunction((s) => Number(document.querySelector(s)?.textContent) > 0, { timeout: T }, $('alert-count'));
    const before = Number(await page.$eval($('alert-count'), (e) => e.textContent));
    await page.click($('nav-alerts'));
    await page.waitForSelector(`${$('alerts')} [data-kind="divergence"]`, { timeout: T });
    await shot('05-alerts');
    // Aim at one alert by its id: the list moves under the pointer while it is clicked (new
    // alerts arrive at the top, a diagnosis lengthens a row), so a click that the move made
    // land beside the button is made again, as a technician would.
    const row = await page.$eval(`${$('alerts')} [data-kind="divergence"][data-acknowledged="false"]`, (e) => e.dataset.testid);
    const acked = `${$(row)}[data-acknowledged="true"]`;
    for (let attempt = 0; !(await page.$(acked)); ++attempt) {
      assert.ok(attempt < 10, `${row} is still unacknowledged after ${attempt} clicks`);
      await page.click(`${$(row)} ${$('alert-ack')}`).catch(() => {}); // gone once acknowledged
      await page.waitForSelector(acked, { timeout: 5000 }).catch(() => {});
    }
    // The running scan may raise a new divergence alert at once (an acknowledged alert no
    // longer absorbs repeats): the counter is the number of unacknowledged ones listed.
    await page.waitForFunction((c, l) => Number(document.querySelector(c).textContent) === document.querySelectorAll(`${l} [data-acknowledged="false"]`).length,
      { timeout: T }, $('alert-count'), $('alerts'));
    assert.ok(before > 0);
    await page.click($('nav-run'));
    await page.waitForSelector($('scan-plot'), { timeout: T });
  });

  it('shows a clicked point’s spectra and colours', async () => {
    await waitPoints(1);
    const box = await (await page.$(`${$('scan-plot')} .u-over`)).boundingBox();
    // Sweep across the plot until the cursor lands on a point.
    for (let x = 5; x < box.width && !(await page.$($('point-details'))); x += box.width / 12) {
      await page.mouse.click(box.x + x, box.y + box.height / 2);
    }
    await page.waitForSelector(`${$('point-details')} .chip`, { timeout: T });
    const lab = await page.$eval($('point-details'), (e) => e.textContent);
    assert.match(lab, /L\* \d/);
    await shot('06-point-details');
  });

  it('keeps working across a goniod restart', async () => {
    // A scan long enough to be running through the restart, shown in the plot.
    if (!(await g.call('queue.status')).running) {
      const s = await g.call('scan.submit', { sample: 'grey', grids: 'in=45;out=-30:80:1', repeats: 2 });
      await page.waitForSelector(`${$(`queue-item-${s.id}`)} button.link`, { timeout: T });
      await page.click(`${$(`queue-item-${s.id}`)} button.link`);
    }
    await waitPoints(2);
    const n = await points();
    down = true;
    await g.stop();
    await page.waitForSelector($('disconnected'), { timeout: T });
    await shot('07-disconnected');
    await g.start(); // the same port; the interrupted scan resumes first
    await page.waitForFunction((s) => !document.querySelector(s), { timeout: T }, $('disconnected'));
    await page.waitForFunction((s) => document.querySelector(s)?.textContent === 'connected', { timeout: T }, $('link-state'));
    down = false;
    await waitPoints(n + 2); // notifications flow again: the page subscribed anew
    await shot('08-reconnected');
  });

  it('shows a viewer no controls', async () => {
    const ctx = await browser.createBrowserContext();
    const v = await ctx.newPage();
    await v.setViewport({ width: 1280, height: 800 });
    watch(v);
    await login(v, viewer);
    await v.waitForSelector(`${$('queue')} li`, { timeout: T });
    for (const id of ['instrument-stop', 'scan-submit', 'scan-pause', 'scan-resume', 'scan-cancel', 'queue-up'])
      assert.equal(await v.$($(id)), null, `a viewer sees ${id}`);
    await v.click($('nav-alerts'));
    await v.waitForSelector(`${$('alerts')} li`, { timeout: T });
    assert.equal(await v.$($('alert-ack')), null, 'a viewer sees alert-ack');
    await v.screenshot({ path: join(artifacts, '09-viewer.png'), fullPage: true });
    await ctx.close();
  });

  it('labels every form field on every view', async () => {
    await page.bringToFront();
    await page.click($('nav-run'));
    await page.waitForSelector($('plot-wavelength'), { timeout: T }); // the scan's controls too
    assert.deepEqual(await unlabelled(page), [], 'unlabelled on the run view');
    await page.click($('nav-alerts'));
    await page.waitForSelector($('alerts'), { timeout: T });
    assert.deepEqual(await unlabelled(page), [], 'unlabelled on the alerts view');
    await page.click($('nav-samples'));
    await page.waitForSelector($('sample-create'), { timeout: T });
    assert.deepEqual(await unlabelled(page), [], 'unlabelled on the samples view');
    await page.click($('nav-twin'));
    await fill(`${$('twin-form')} #f-grids`, 'in=45;out=-60:60:20');
    await fill(`${$('twin-form')} #f-wavelengths`, '500:600:50');
    await page.click(`${$('twin-form')} button[type=submit]`);
    await page.waitForSelector(`${$('twin-plot')} canvas`, { timeout: T }); // and its result's λ
    assert.deepEqual(await unlabelled(page), [], 'unlabelled on the twin view');
    // The check sees a field without a name.
    await page.evaluate(() => document.body.append(Object.assign(document.createElement('input'), { id: 'nameless' })));
    assert.deepEqual(await unlabelled(page), ['nameless']);
    await page.evaluate(() => document.getElementById('nameless').remove());
    await page.click($('nav-run'));
    await page.waitForSelector($('scan-plot'), { timeout: T });
  });

  it('is reachable and operable with the keyboard alone', async () => {
    // A fresh page, as a keyboard user opens it: the first Tab lands on the views' nav.
    await page.bringToFront();
    await page.reload({ waitUntil: 'load' });
    await page.waitForFunction((s) => document.querySelector(s)?.textContent === 'connected', { timeout: T }, $('link-state'));
    await page.waitForSelector(`${$('scan-submit')} select[name=sample] option`, { timeout: T });
    await press(page, 'Tab');
    assert.equal((await focus(page))?.id, 'nav-run');
    const ids = (stops) => stops.map((s) => s.id);
    const walk = async (view, want) => {
      const stops = await tabWalk(page);
      for (const id of want) assert.ok(ids(stops).includes(id), `${id} is not reached by Tab on the ${view} view: ${ids(stops).join(', ')}`);
      assert.deepEqual(ids(stops.filter((s) => !s.ring)), [], `focus not shown on the ${view} view`);
    };
    await walk('run', ['nav-run', 'nav-alerts', 'nav-samples', 'nav-twin', 'instrument-stop', 'scan-submit-button']);

    // A scan submitted from the keyboard, paused with Space, resumed with Enter and, after the
    // alerts, cancelled. Its receiver swings 110° between points: the mock's moves take wall
    // time (time_scale), so its 40 points last well over a minute on any machine.
    const retype = async (sel, text) => {
      await tabTo(page, sel);
      await page.keyboard.down('Control');
      await page.keyboard.press('a');
      await page.keyboard.up('Control');
      await page.keyboard.type(text);
      assert.equal(await page.$eval(sel, (e) => e.value), text);
    };
    await retype(`${$('scan-submit')} #f-name`, 'keyboard');
    await retype(`${$('scan-submit')} #f-grids`, `in=45;out=${Array(20).fill('-30,80').join(',')}`);
    await tabTo(page, $('scan-submit-button'));
    await press(page, 'Enter');
    let id;
    await until('no scan submitted from the keyboard', async () => (id = (await g.call('scan.list', { limit: 20 })).find((x) => x.plan.name === 'keyboard')?.id));
    const row = $(`queue-item-${id}`);
    await page.waitForSelector(`${row}[data-state="running"] ${$('scan-pause')}`, { timeout: T }); // once a scan before it is done
    await tabTo(page, `${row} ${$('scan-pause')}`);
    await press(page, ' ');
    await page.waitForSelector(`${row}[data-state="paused"] ${$('scan-resume')}`, { timeout: T });
    // The focus stayed on the button, now Resume (nothing else waits: the row kept its place).
    assert.ok((await focus(page, `${row} ${$('scan-resume')}`))?.here, `the focus left Pause: ${JSON.stringify(await focus(page))}`);
    await press(page, 'Enter');
    await page.waitForSelector(`${row}[data-state="running"]`, { timeout: T });

    // The alerts view by keyboard; an alert acknowledged with Space.
    await tabTo(page, $('nav-alerts'));
    await press(page, 'Enter');
    await page.waitForSelector(`${$('alerts')} [data-acknowledged="false"] ${$('alert-ack')}`, { timeout: T });
    await walk('alerts', ['nav-run', 'instrument-stop', 'alert-ack']);
    await tabTo(page, `${$('alerts')} [data-acknowledged="false"] ${$('alert-ack')}`);
    const alert = await page.evaluate(() => document.activeElement.closest('li').dataset.testid);
    await press(page, ' ');
    await page.waitForSelector(`${$(alert)}[data-acknowledged="true"]`, { timeout: T });
    await shot('10-keyboard');

    for (const [view, ready] of [['samples', 'sample-create'], ['twin', 'twin-form'], ['run', 'scan-plot']]) {
      await tabTo(page, $(`nav-${view}`));
      await press(page, view === 'twin' ? ' ' : 'Enter');
      await page.waitForSelector($(ready), { timeout: T });
    }
    await tabTo(page, `${row} ${$('scan-cancel')}`);
    await press(page, 'Enter');
    await until('the keyboard\'s scan is not cancelled', async () => (await g.call('scan.get', { scan: id })).state === 'cancelled');
  });

  it('is usable on a tablet by touch', async () => {
    const ctx = await browser.createBrowserContext();
    const t = await ctx.newPage();
    watch(t);
    // Chromium emulates a touch screen (touch events, pointer: coarse, a mobile viewport);
    // Firefox 153's BiDi has no touch emulation (puppeteer skips its unknown
    // emulation.setTouchOverride), so there it is the tablet's viewport. page.tap is a touch
    // pointer action in both.
    const tablet = (width, height) => t.setViewport({ width, height, hasTouch: true, isMobile: true });
    await tablet(820, 1180);
    await t.goto(g.url, { waitUntil: 'load' });
    await t.waitForSelector($('login-token'), { timeout: T });
    assert.deepEqual(await unlabelled(t), [], 'unlabelled on the login page');
    await t.tap($('login-token'));
    await t.keyboard.type(await g.token('lab-tablet', 'technician'));
    await t.tap($('login-submit'));
    await t.waitForFunction((s) => document.querySelector(s)?.textContent === 'connected', { timeout: T }, $('link-state'));
    await t.waitForSelector(`${$('scan-submit')} select[name=sample] option`, { timeout: T });

    // A control a finger can hit: inside the viewport once scrolled to, on top (not under the
    // sticky header) and at least 44 px square, the usual minimum touch target, where the page
    // knows it is on a touch screen or narrow (Firefox's landscape tablet is neither: there
    // 24 px, the least any pointer should have to hit).
    const reachable = (sel) => t.$eval(sel, (e) => {
      e.scrollIntoView({ block: 'center' });
      const r = e.getBoundingClientRect();
      return { inside: r.left >= 0 && r.right <= innerWidth && r.top >= 0 && r.bottom <= innerHeight,
        onTop: e.contains(document.elementFromPoint(r.x + r.width / 2, r.y + r.height / 2)),
        w: Math.round(r.width), h: Math.round(r.height), least: matchMedia('(pointer: coarse), (max-width: 900px)').matches ? 44 : 24 };
    });
    const overflow = () => t.evaluate(() => document.documentElement.scrollWidth - innerWidth);
    const views = [['scans', 'scans'], ['alerts', 'alerts'], ['samples', 'samples'], ['twin', 'twin-form'], ['run', 'scan-submit']]; // the run view last: its controls are checked next
    for (const [width, height] of [[820, 1180], [1180, 820]]) {
      await tablet(width, height);
      for (const [view, ready] of views) {
        await t.tap($(`nav-${view}`));
        await t.waitForSelector(`${$(`nav-${view}`)}[aria-current="page"]`, { timeout: T });
        await t.waitForSelector($(ready), { timeout: T });
        assert.ok((await overflow()) <= 0, `the ${view} view is ${await overflow()} px wider than ${width}×${height}`);
      }
      for (const id of ['nav-run', 'nav-alerts', 'nav-samples', 'nav-twin', 'instrument-stop', 'scan-submit-button']) {
        const r = await reachable($(id));
        assert.ok(r.inside && r.onTop && r.w >= r.least && r.h >= r.least, `${id} at ${width}×${height}: ${JSON.stringify(r)}`);
      }
      await t.evaluate(() => scrollTo(0, 0));
      await t.screenshot({ path: join(artifacts, `11-tablet-${width}x${height}.png`) }); // the tablet's screen
    }

    // A scan submitted and the instrument stopped by tapping.
    await t.tap(`${$('scan-submit')} #f-name`);
    await t.keyboard.type('tapped');
    await t.tap($('scan-submit-button'));
    await until('no scan submitted from the tablet', async () => (await g.call('scan.list', { limit: 20 })).some((x) => x.plan.name === 'tapped' && x.submitted_by === 'lab-tablet'));
    await t.tap($('instrument-stop'));
    await until('no instrument.stop from the tablet', async () => (await g.call('system.audit', { limit: 20 })).some((e) => e.action === 'instrument.stop' && e.actor === 'lab-tablet'));
    await ctx.close();
  });

  // ---- the past: the scans' history, a finished scan and its links, the inverse twin ------
  // Three short scans, finished before the page opens them: of a sample as the mock's true
  // one ('true'), and of two that differ from it ('grey', 'glossy').
  const hist = {};
  it('lists the scans of the past, newest first, filtered and paged', async () => {
    const q = await g.call('queue.status'); // the tablet stopped the arms: nothing may wait now
    for (const s of [q.running, ...q.waiting].filter(Boolean)) await g.call('scan.cancel', { scan: s.id, reason: 'before the history' }).catch(() => {});
    const st = await g.call('instrument.status');
    if (st.fault_latched) await g.call('instrument.reset');
    await g.call('sample.create', { name: 'true', bsdf: 'lambert:albedo=0.6' });
    // 26 cancelled scans: more than a page of the history.
    for (let i = 0; i < 26; ++i) {
      const s = await g.call('scan.submit', { sample: 'true', name: `bulk ${i}`, grids: 'in=45;out=0', not_before: '2099-01-01T00:00:00Z' });
      await g.call('scan.cancel', { scan: s.id, reason: 'bulk' });
    }
    const submit = async (sample, name) => (await g.call('scan.submit', { sample, name, grids: 'in=45;out=-30:60:15', wavelengths: '400:700:20' })).id;
    hist.grey = await submit('grey', 'history grey');
    hist.glossy = await submit('glossy', 'history glossy');
    hist.true = await submit('true', 'history true');
    await until('the history\'s scans did not finish', async () => (await g.call('scan.get', { scan: hist.true })).state === 'completed');
    for (const k of ['grey', 'glossy']) assert.equal((await g.call('scan.get', { scan: hist[k] })).state, 'completed');

    await page.bringToFront();
    await page.click($('nav-scans'));
    const rows = (sel = '') => page.$$eval(`${$('scans')}[data-loaded="true"] ${$('scan-row')}${sel}`, (r) => r.map((e) => ({ id: Number(e.dataset.scan), state: e.dataset.state, text: e.textContent })));
    await page.waitForSelector(`${$('scans')}[data-loaded="true"] ${$('scan-row')}[data-scan="${hist.true}"]`, { timeout: T });
    const first = await rows();
    assert.equal(first.length, 25, 'a page of 25');
    assert.equal(first[0].id, hist.true, 'the newest first');
    assert.deepEqual(first.map((r) => r.id), first.map((r) => r.id).sort((a, b) => b - a));
    // The next page: older scans only.
    await page.click($('scans-next'));
    await page.waitForSelector(`${$('scans')}[data-page="2"][data-loaded="true"] ${$('scan-row')}`, { timeout: T });
    await page.waitForFunction((s, last) => [...document.querySelectorAll(s)].every((e) => Number(e.dataset.scan) < last), { timeout: T }, `${$('scans')}[data-page="2"] ${$('scan-row')}`, first[24].id);
    assert.match(page.url(), /#\/scans\?page=2$/);
    await page.click($('scans-prev'));
    await page.waitForSelector(`${$('scans')}[data-page="1"] ${$('scan-row')}[data-scan="${hist.true}"]`, { timeout: T });

    // Text in the label, then a state.
    await fill(`${$('scans-filter')} input[name=text]`, 'HISTORY');
    await page.click($('scans-apply'));
    const only = async (what, want) => {
      await page.waitForFunction((s, n) => document.querySelectorAll(s).length === n, { timeout: T }, `${$('scans')}[data-loaded="true"] ${$('scan-row')}`, want.length);
      assert.deepEqual((await rows()).map((r) => r.id), want, what);
    };
    await only('label text', [hist.true, hist.glossy, hist.grey]);
    await page.select(`${$('scans-filter')} select[name=sample]`, String((await g.call('sample.get', { sample: 'glossy' })).id));
    await page.click($('scans-apply'));
    await only('label text and sample', [hist.glossy]);
    await page.select(`${$('scans-filter')} select[name=sample]`, '');
    await fill(`${$('scans-filter')} input[name=text]`, 'bulk 1');
    await page.select(`${$('scans-filter')} select[name=state]`, 'cancelled');
    await page.click($('scans-apply'));
    await page.waitForFunction((s) => document.querySelectorAll(s).length > 0 && [...document.querySelectorAll(s)].every((e) => e.dataset.state === 'cancelled' && /bulk 1/.test(e.textContent)), { timeout: T }, `${$('scans')}[data-loaded="true"] ${$('scan-row')}`);
    assert.equal((await rows()).length, 11, "'bulk 1' and 'bulk 10'…'bulk 19'");
    await page.select(`${$('scans-filter')} select[name=state]`, 'failed');
    await page.click($('scans-apply'));
    await only('no failed bulk scan', []);
    // Days, in the link: today (UTC) has them all, tomorrow none; a bad day is named.
    const today = new Date().toISOString().slice(0, 10);
    const tomorrow = new Date(Date.now() + 86400000).toISOString().slice(0, 10);
    await page.evaluate((d) => { location.hash = `#/scans?from=${d}&to=${d}&text=history`; }, today);
    await only('today', [hist.true, hist.glossy, hist.grey]);
    await page.evaluate((d) => { location.hash = `#/scans?from=${d}&text=history`; }, tomorrow);
    await only('from tomorrow', []);
    await page.evaluate(() => { location.hash = '#/scans?from=soon'; });
    await page.waitForSelector(`${$('scans-error')}[data-field="from"]`, { timeout: T });
    assert.equal(await attr(`${$('scans-filter')} input[name=from]`, 'aria-invalid'), 'true');
    // goniod names the field of a bad filter.
    await assert.rejects(g.call('scan.list', { until: '2026-01-01T00:00:00Z', since: '2026-02-01T00:00:00Z' }), (e) => e.rpc.data.field === 'until');
    await assert.rejects(g.call('scan.list', { text: 'x'.repeat(201) }), (e) => e.rpc.data.field === 'text');
    await shot('12-history');
  });

  it('opens a finished scan from the history with its points, verdict and budget', async () => {
    await page.evaluate(() => { location.hash = '#/scans?text=history'; });
    await page.waitForSelector(`${$('scan-row')}[data-scan="${hist.grey}"] ${$('scan-open')}`, { timeout: T });
    await page.click(`${$('scan-row')}[data-scan="${hist.grey}"] ${$('scan-open')}`);
    await page.waitForSelector(`${$('scan-view')}[data-scan="${hist.grey}"]`, { timeout: T });
    assert.match(page.url(), new RegExp(`#/scan/${hist.grey}$`));
    const scan = await g.call('scan.get', { scan: hist.grey });
    await waitPoints(scan.points_done);
    assert.equal(await points(), 7);
    // The badge says what goniod's verdict says.
    await page.waitForSelector($('verdict'), { timeout: T });
    assert.ok(scan.verdict && scan.verdict.decision, 'goniod has a verdict');
    await page.waitForFunction((s, d) => document.querySelector(s)?.dataset.decision === d, { timeout: T }, $('verdict'), scan.verdict.decision);
    // A point's budget: a row per input, as stored.
    const stored = (await g.call('scan.points', { scan: hist.grey, offset: 3, limit: 1 })).points[0];
    assert.ok(stored.budget.length > 0, 'the point has a budget');
    await fill($('point-index'), '3');
    await page.$eval($('point-index'), (e) => e.dispatchEvent(new Event('change', { bubbles: true })));
    // The details of the point shown before stay until point 3's arrive: wait for those.
    await page.waitForFunction((s) => /Point 3/.test(document.querySelector(s)?.textContent || ''), { timeout: T }, $('point-details'));
    await page.waitForSelector(`${$('point-details')} ${$('point-budget')}`, { timeout: T });
    assert.equal((await page.$$(`${$('point-budget')} ${$('budget-row')}`)).length, stored.budget.length);
    assert.match(await page.$eval($('point-details'), (e) => e.textContent), /Point 3/);
    await shot('13-finished-scan');
  });

  it('keeps a deep link across a reload, a login and a goniod restart', async () => {
    const link = `${g.url}/#/scan/${hist.grey}`;
    const atScan = async (p) => {
      await p.waitForSelector(`${$('scan-view')}[data-scan="${hist.grey}"]`, { timeout: T });
      await p.waitForFunction((s) => Number(document.querySelector(s)?.dataset.points || 0) === 7, { timeout: T }, $('scan-plot'));
    };
    await page.reload({ waitUntil: 'load' });
    await atScan(page);
    // A colleague's link, opened in a fresh session: the login, then the same view.
    const ctx = await browser.createBrowserContext();
    const p = await ctx.newPage();
    await p.setViewport({ width: 1280, height: 800 });
    watch(p);
    await p.goto(link, { waitUntil: 'load' });
    await p.waitForSelector($('login-token'), { timeout: T });
    await p.type($('login-token'), tech);
    await p.click($('login-submit'));
    await atScan(p);
    assert.equal(p.url(), link);
    // A goniod restart: both pages come back to the scan.
    down = true;
    await g.restart();
    await page.waitForFunction((s) => document.querySelector(s)?.textContent === 'connected', { timeout: T }, $('link-state'));
    down = false;
    await atScan(page);
    await p.reload({ waitUntil: 'load' });
    await atScan(p);
    await ctx.close();
  });

  it('shows a viewer the scan, its verdict and fits, but no fit or calibrate control', async () => {
    const ctx = await browser.createBrowserContext();
    const v = await ctx.newPage();
    await v.setViewport({ width: 1280, height: 800 });
    watch(v);
    await v.goto(`${g.url}/#/scan/${hist.grey}`, { waitUntil: 'load' });
    await v.waitForSelector($('login-token'), { timeout: T });
    await v.type($('login-token'), viewer);
    await v.click($('login-submit'));
    await v.waitForSelector(`${$('scan-view')}[data-scan="${hist.grey}"] ${$('verdict')}`, { timeout: T });
    await v.waitForSelector($('fits'), { timeout: T });
    for (const id of ['fit-form', 'fit-run', 'calibrate-form', 'calibrate-dry', 'calibrate-apply'])
      assert.equal(await v.$($(id)), null, `a viewer sees ${id}`);
    await ctx.close();
    // …where a technician has the fit and an admin the calibration too.
    await page.bringToFront();
    await page.waitForSelector($('fit-form'), { timeout: T });
    assert.equal(await page.$($('calibrate-form')), null, 'a technician sees calibrate-form');
  });

  it('fits a model from the page and draws it over the points', async () => {
    await page.bringToFront();
    await page.waitForSelector(`${$('scan-view')}[data-scan="${hist.grey}"] ${$('fit-form')}`, { timeout: T });
    assert.equal(await page.$eval('#fit-model', (e) => e.value), 'lambert:albedo=?', 'the catalogued spec, freed');
    // Bad models are named at the field: one without '?' (the page), one goniod refuses.
    await fill('#fit-model', 'lambert:albedo=0.5');
    await page.click($('fit-run'));
    await page.waitForSelector($('fit-error-model'), { timeout: T });
    await fill('#fit-model', 'nosuchmodel:x=?');
    await page.click($('fit-run'));
    await page.waitForFunction((s) => /nosuchmodel|model/i.test(document.querySelector(s)?.textContent || '') && document.querySelector('#fit-model').getAttribute('aria-invalid') === 'true', { timeout: T }, $('fit-error-model'));
    // The fit: progress while it runs, then the parameter ± u. The mock's true sample is
    // lambert:albedo=0.6, whatever the catalog says.
    await fill('#fit-model', 'lambert:albedo=?');
    await fill('#fit-samples', '2048');
    await page.evaluate((s) => {
      window.__sawProgress = false;
      new MutationObserver(() => { if (document.querySelector(s)) window.__sawProgress = true; }).observe(document.body, { childList: true, subtree: true });
    }, $('fit-progress'));
    await page.click($('fit-run'));
    await page.waitForSelector(`${$('fit-result')} ${$('fit-param')}`, { timeout: T * 3 });
    assert.equal(await page.evaluate(() => window.__sawProgress), true, 'no progress shown while fitting');
    const p = await page.$eval($('fit-param'), (e) => ({ name: e.dataset.name, value: Number(e.dataset.value), u: Number(e.dataset.u) }));
    assert.match(p.name, /albedo/);
    assert.ok(Math.abs(p.value - 0.6) < 0.06, `albedo ${p.value} ± ${p.u}, the mock's is 0.6`);
    assert.ok(p.u > 0);
    assert.match(await page.$eval($('fit-result'), (e) => e.textContent), /naive/);
    // Stored with the scan, listed, and its curve drawn over the points.
    const fits = (await g.call('scan.get', { scan: hist.grey })).fits;
    assert.equal(fits[0].kind, 'fit');
    assert.equal(fits[0].model, 'lambert:albedo=?');
    await page.waitForSelector(`${$('fits')} ${$('fit-item')}[data-kind="fit"]`, { timeout: T });
    await page.waitForSelector(`${$('fit-curve')}[data-drawn="true"]`, { timeout: T * 2 });
    await page.waitForFunction((s) => /fitted model/.test(document.querySelector(s)?.textContent || ''), { timeout: T }, `${$('scan-plot')} .u-legend`);
    await shot('14-fit');
    // The fitted material saved for a renderer (scan.material): a glTF sphere, its ΔE00 shown.
    await page.evaluate(() => {
      window.__saved = [];
      const create = URL.createObjectURL.bind(URL);
      URL.createObjectURL = (blob) => { window.__saved.push(blob); return create(blob); };
    });
    await page.click($('material-gltf'));
    await page.waitForFunction((s) => /glTF approximation: ΔE00 over \d+ geometries mean/.test(document.querySelector(s)?.textContent || ''), { timeout: T * 2 }, $('material-summary'));
    const gltf = JSON.parse(await page.evaluate(() => window.__saved[0].text()));
    assert.equal(gltf.asset.version, '2.0');
    assert.ok(gltf.materials[0].pbrMetallicRoughness.metallicFactor < 0.5, 'a grey diffuser is not a metal');
    await shot('14-fit-material');
  });

  it('calibrates as an admin: a dry run first, the profile kept', async () => {
    const ctx = await browser.createBrowserContext();
    const a = await ctx.newPage();
    await a.setViewport({ width: 1280, height: 800 });
    watch(a);
    const before = (await g.call('instrument.status')).profile;
    await a.goto(`${g.url}/#/scan/${hist.true}`, { waitUntil: 'load' });
    await a.waitForSelector($('login-token'), { timeout: T });
    await a.type($('login-token'), g.adminToken);
    await a.click($('login-submit'));
    await a.waitForSelector($('calibrate-form'), { timeout: T });
    // The version arrives with instrument.status, which the page asks for after it draws the
    // form: wait for it rather than read it once.
    await a.waitForFunction((s, v) => (document.querySelector(s)?.textContent || '').includes(`#${v}`),
      { timeout: T }, $('profile-version'), before.version);
    assert.equal(await a.$eval($('calibrate-apply'), (e) => e.disabled), true, 'apply before a dry run');
    // Gain alone: quick, and separable on one scan.
    await a.$$eval(`${$('calibrate-form')} input[name=fit]`, (boxes) => boxes.forEach((b) => { if (b.checked !== (b.value === 'gain')) b.click(); }));
    await a.click($('calibrate-dry'));
    await a.waitForSelector(`${$('fit-result')}[data-kind="calibrate"] ${$('fit-param')}`, { timeout: T * 3 });
    assert.match(await a.$eval($('fit-param'), (e) => e.dataset.name), /gain/);
    await a.waitForSelector(`${$('calibrate-applied')}[data-applied="false"]`, { timeout: T });
    assert.equal(await a.$eval($('calibrate-apply'), (e) => e.disabled), false, 'apply after the dry run');
    assert.deepEqual((await g.call('instrument.status')).profile, before, 'a dry run keeps the profile');
    assert.ok((await g.call('scan.get', { scan: hist.true })).fits.some((f) => f.kind === 'calibrate'));
    await a.screenshot({ path: join(artifacts, '15-calibrate.png'), fullPage: true });
    await ctx.close();
  });

  it('compares two scans from the history', async () => {
    await page.bringToFront();
    await page.evaluate(() => { location.hash = '#/scans?text=history'; });
    await page.waitForSelector(`${$('scan-row')}[data-scan="${hist.grey}"]`, { timeout: T });
    await page.click(`${$('scan-row')}[data-scan="${hist.grey}"] ${$('compare-pick')}`);
    await page.click(`${$('scan-row')}[data-scan="${hist.true}"] ${$('compare-pick')}`);
    await page.click($('compare-open'));
    await page.waitForSelector(`${$('compare')}[data-scans="${hist.grey},${hist.true}"] ${$('compare-plot')} canvas`, { timeout: T });
    assert.equal((await page.$$($('compare-row'))).length, 2);
    assert.equal(await page.$eval($('compare'), (e) => e.dataset.x), '7');
    // grey (albedo 0.3 in the catalog) and true measure the same sample: what differs is the
    // mock's noise and drift, a few per cent of β ≈ 0.6 at most.
    const d = Number(await page.$eval($('compare-maxdiff'), (e) => e.textContent));
    assert.ok(d >= 0 && d < 0.1, `max |Δβ| ${d}`);
    await page.reload({ waitUntil: 'load' });
    await page.waitForSelector(`${$('compare')}[data-scans="${hist.grey},${hist.true}"] ${$('compare-plot')} canvas`, { timeout: T });
    await shot('16-compare');
  });

  it('links samples to their scans and groups alerts per scan', async () => {
    await page.click($('nav-samples'));
    const grey = (await g.call('sample.get', { sample: 'grey' })).id;
    await page.waitForSelector(`${$('samples')} a[href="#/sample/${grey}"]`, { timeout: T });
    await page.click(`${$('samples')} a[href="#/sample/${grey}"]`);
    await page.waitForSelector(`${$('sample-view')}[data-sample="${grey}"] ${$('scans')}[data-loaded="true"] ${$('scan-row')}[data-scan="${hist.grey}"]`, { timeout: T });
    const ofGrey = (await g.call('scan.list', { sample: 'grey', limit: 25 })).map((s) => s.id);
    assert.deepEqual(await page.$$eval($('scan-row'), (r) => r.map((e) => Number(e.dataset.scan))), ofGrey);
    await page.click($('nav-alerts'));
    const ofScan = (await g.call('alert.list', { scan: hist.grey })).map((a) => a.id);
    assert.ok(ofScan.length > 0, 'grey diverges: the scan has alerts');
    await page.waitForSelector(`${$('alert-group')}[data-scan="${hist.grey}"]`, { timeout: T });
    const grouped = await page.$$eval(`${$('alert-group')}[data-scan="${hist.grey}"] li.alert`, (l) => l.map((e) => Number(e.dataset.testid.slice(6))));
    assert.deepEqual(grouped, [...grouped].sort((x, y) => y - x), 'newest first');
    assert.deepEqual([...grouped].sort(), [...ofScan].sort());
    assert.equal((await page.$$(`${$('alert-group')}[data-scan="${hist.grey}"]`)).length, 1, 'one group per scan');
    await page.click(`${$('alert-group')}[data-scan="${hist.grey}"] .group-head button`);
    await page.waitForSelector(`${$('scan-view')}[data-scan="${hist.grey}"]`, { timeout: T });
    await shot('17-alert-groups');
  });

  it('met no page errors and no CSP violations', async () => {
    assert.deepEqual(problems, []);
    // …and would have seen one: a style element the policy refuses.
    const seen = [];
    const p = await browser.newPage();
    watch(p, seen);
    await p.goto(g.url, { waitUntil: 'load' });
    await p.evaluate(() => document.head.append(Object.assign(document.createElement('style'), { textContent: 'body { color: red }' })));
    await until('a refused style went unseen', () => seen.length > 0);
    assert.match(seen.join('\n'), /Content.Security.Policy/);
    await p.close();
  });
});
