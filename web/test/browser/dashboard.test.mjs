// The dashboard in a real headless browser against a real `goniod --mock`: one browser and
// one goniod for the whole file. GONIO_BROWSER picks the browser: chromium (the default;
// ctest's web.browser) or firefox (web.browser.firefox, over WebDriver BiDi). Screenshots go
// to $GONIO_ARTIFACTS (default: ./artifacts, ./artifacts/firefox). Exits 77 (skipped) when
// the browser is not installed.
import { describe, it, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { copyFileSync, mkdirSync } from 'node:fs';
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
    await page.waitForSelector(`${$('queue')} [data-state="running"]`, { timeout: T });
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
    const views = [['alerts', 'alerts'], ['samples', 'samples'], ['twin', 'twin-form'], ['run', 'scan-submit']]; // the run view last: its controls are checked next
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
