// One scan on a page of its own (#/scan/ID): any scan, running or long finished, with its plot,
// verdict, points, exports, alerts, the stored fits and — for a technician — the inverse twin
// (scan.fit), for an admin the instrument's calibration (instrument.calibrate, dry run first).
import { useCallback, useEffect, useMemo, useRef, useState } from 'preact/hooks';
import { html, download } from './ui.js';
import { checkFitModel, modelFromSpec, fitRows, materialSummary } from './logic/fit.js';
import { describeError, fmt, shortTime } from './logic/format.js';
import { finished } from './logic/scans.js';
import { channelOf } from './logic/points.js';
import { can } from './logic/roles.js';
import { verdictBadge } from './logic/verdict.js';
import { ScanPanel } from './scanplot.js';

const CAL_PARAMS = ['incidence_offset_deg', 'receive_offset_deg', 'sample_tilt_deg', 'source_aperture_scale', 'receiver_aperture_scale', 'gain'];

// Seconds since a call started, while it runs: scan.fit and instrument.calibrate answer once,
// at the end (seconds to minutes).
function useElapsed(running) {
  const [s, setS] = useState(0);
  useEffect(() => {
    if (!running) return undefined;
    const t0 = Date.now();
    setS(0);
    const id = setInterval(() => setS(Math.round((Date.now() - t0) / 1000)), 500);
    return () => clearInterval(id);
  }, [running]);
  return s;
}

// A stored fit's material for a renderer (scan.material, twin/material.md): Mitsuba 3 XML or
// glTF 2.0 (fitted by ΔE00, whose error is shown), saved as a file.
function MaterialExport({ scan, fit, call, notify }) {
  const [busy, setBusy] = useState(null);
  const [summary, setSummary] = useState([]);
  const elapsed = useElapsed(!!busy);
  const save = async (format) => {
    setBusy(format);
    try {
      const r = await call('scan.material', { scan: scan.id, fit: fit.id, format });
      download(r.filename, r.media_type, r.content);
      setSummary(materialSummary(r));
    } catch (e) {
      notify(`scan.material: ${describeError(e).message || e.message}`);
    } finally {
      setBusy(null);
    }
  };
  return html`<div class="material-export" data-testid="material-export">
    <span>Material for a renderer:</span>
    <button data-testid="material-mitsuba" disabled=${!!busy} onClick=${() => save('mitsuba')}>Mitsuba 3 XML</button>
    <button data-testid="material-gltf" disabled=${!!busy} onClick=${() => save('gltf')}>glTF 2.0</button>
    ${busy && html`<span role="status" data-testid="material-progress"><progress aria-label="writing the material"></progress> ${busy === 'gltf' ? 'fitting the glTF material…' : 'writing…'} ${elapsed} s</span>`}
    ${summary.length > 0 && html`<ul class="muted" data-testid="material-summary">${summary.map((l) => html`<li>${l}</li>`)}</ul>`}
  </div>`;
}

// A FitResult (twin/fitting.md): the parameters ± u beside the naive fit and its bias, χ²/dof
// of both, the correlation, the warnings.
export function FitResult({ fit, testid = 'fit-result' }) {
  const r = fit.result || {};
  const rows = fitRows(r);
  const names = rows.map((p) => p.name);
  const corr = Array.isArray(r.correlation) && r.correlation.length > 1 ? r.correlation : null;
  const warnings = [...(r.warnings || []), ...(r.degenerate || []).map((d) => `not separable: ${typeof d === 'string' ? d : JSON.stringify(d)}`)];
  return html`<div class="fit-result" data-testid=${testid} data-kind=${fit.kind} data-converged=${String(!!r.converged)}>
    <p><b>${fit.kind}</b> #${fit.id ?? ''} · ${fit.model} · ${r.converged ? 'converged' : html`<span class="warn">not converged</span>`} · χ²/dof ${fmt(r.chi2_per_dof, 4)}
      (naive ${fmt(r.naive && r.naive.chi2_per_dof, 4)}) · ${r.points ?? '–'} points, ${r.iterations ?? '–'} iterations, ${fmt(r.seconds, 3)} s${fit.created_by ? ` · ${fit.created_by}, ${shortTime(fit.created_at)}` : ''}</p>
    ${r.spec && html`<p class="muted">fitted spec: <code data-testid="fit-spec">${r.spec}</code></p>`}
    <table class="fit-params">
      <thead><tr><th>parameter</th><th>value ± u (k = 1)</th><th>naive fit</th><th>naive − fitted</th></tr></thead>
      <tbody>${rows.map((p) => html`<tr data-testid="fit-param" data-name=${p.name} data-value=${p.value} data-u=${p.u ?? ''}>
        <td>${p.name}${p.atBound ? html` <span class="warn">at a bound</span>` : ''}${p.identifiable ? '' : html` <span class="warn">not identifiable</span>`}</td>
        <td>${fmt(p.value, 5)} ± ${p.u === null ? '–' : fmt(p.u, 2)}</td>
        <td>${fmt(p.naive, 5)}</td>
        <td>${p.bias === null ? '–' : `${fmt(p.bias, 3)}${p.biasInU === null ? '' : ` (${fmt(p.biasInU, 2)} u)`}`}</td>
      </tr>`)}</tbody>
    </table>
    ${corr && html`<table class="correlation" data-testid="fit-correlation"><caption>correlation</caption>
      <thead><tr><th></th>${names.map((n) => html`<th>${n}</th>`)}</tr></thead>
      <tbody>${corr.map((row, i) => html`<tr><th>${names[i] || i}</th>${row.map((v, j) => html`<td class=${i !== j && Math.abs(v) > 0.95 ? 'warn' : ''}>${fmt(v, 3)}</td>`)}</tr>`)}</tbody></table>`}
    ${warnings.length > 0 && html`<ul class="warnings" data-testid="fit-warnings">${warnings.map((w) => html`<li>${w}</li>`)}</ul>`}
    ${fit.applied !== undefined && html`<p data-testid="calibrate-applied" data-applied=${String(fit.applied)}>${fit.applied ? 'applied: ' : `not applied${fit.reason ? ` (${fit.reason})` : ''}; profile in use: `}${fit.profile ? `${fit.profile.name} #${fit.profile.version}` : ''}</p>`}
  </div>`;
}

function FitForm({ scan, sampleSpec, call, onFitted, notify }) {
  const [model, setModel] = useState(() => modelFromSpec(sampleSpec));
  const [paths, setPaths] = useState('8192');
  const [iterations, setIterations] = useState('60');
  const [error, setError] = useState(null);
  const [busy, setBusy] = useState(false);
  const elapsed = useElapsed(busy);
  const run = async (e) => {
    e.preventDefault();
    const bad = checkFitModel(model);
    if (bad) { setError({ field: 'model', message: bad }); return; }
    setBusy(true);
    setError(null);
    try {
      const fit = await call('scan.fit', { scan: scan.id, model: model.trim(), samples: Number(paths), max_iterations: Number(iterations) });
      onFitted(fit);
    } catch (err) {
      const d = describeError(err);
      setError({ field: d.field, message: d.message });
      if (!['model', 'samples', 'max_iterations'].includes(d.field)) notify(`scan.fit: ${d.message}`);
    }
    setBusy(false);
  };
  const err = (k) => (error && error.field === k ? html`<div class="field-error" role="alert" id=${`fit-${k}-err`} data-testid=${`fit-error-${k}`}>${error.message}</div>` : null);
  return html`<form class="fit-form" data-testid="fit-form" onSubmit=${run} novalidate aria-label="Fit a model to this scan">
    <div class="field"><label for="fit-model">Model (free parameters marked ?)</label>
      <input id="fit-model" name="model" value=${model} onInput=${(e) => setModel(e.currentTarget.value)} aria-invalid=${error && error.field === 'model' ? 'true' : 'false'} aria-describedby=${error && error.field === 'model' ? 'fit-model-err' : undefined} />
      <small class="hint">e.g. lambert:albedo=?  ·  lambert:albedo=?*+coat:alpha=?0.05[0.005,0.5],ior=1.5</small>${err('model')}</div>
    <div class="row">
      <div class="field"><label for="fit-samples">Paths per geometry</label>
        <input id="fit-samples" type="number" min="1024" max="4194304" step="1024" value=${paths} onInput=${(e) => setPaths(e.currentTarget.value)} />${err('samples')}</div>
      <div class="field"><label for="fit-iterations">Iterations at most</label>
        <input id="fit-iterations" type="number" min="1" max="1000" value=${iterations} onInput=${(e) => setIterations(e.currentTarget.value)} />${err('max_iterations')}</div>
    </div>
    ${error && !['model', 'samples', 'max_iterations'].includes(error.field) && html`<div class="form-error" role="alert" data-testid="fit-error">${error.message}</div>`}
    <div class="row"><button type="submit" data-testid="fit-run" disabled=${busy}>Fit</button>
      ${busy && html`<span data-testid="fit-progress" role="status"><progress aria-label="fitting"></progress> fitting through the twin… ${elapsed} s</span>`}</div>
  </form>`;
}

function CalibrateForm({ scan, status, call, onDone, notify }) {
  const [params, setParams] = useState(['receive_offset_deg', 'gain']);
  const [spec, setSpec] = useState('');
  const [dry, setDry] = useState(null); // the dry run's result, for these parameters
  const [busy, setBusy] = useState(false);
  const [error, setError] = useState(null);
  const elapsed = useElapsed(!!busy);
  const key = JSON.stringify([params, spec]);
  const run = async (dryRun) => {
    setBusy(dryRun ? 'dry' : 'apply');
    setError(null);
    try {
      const p = { scan: scan.id, fit: params, dry_run: dryRun };
      if (spec.trim()) p.sample = spec.trim();
      const r = await call('instrument.calibrate', p);
      if (dryRun) setDry({ key, result: r });
      else setDry(null);
      onDone(r);
    } catch (err) {
      const d = describeError(err);
      setError(d.message);
      notify(`instrument.calibrate: ${d.message}`);
    }
    setBusy(false);
  };
  const toggle = (name) => setParams((l) => (l.includes(name) ? l.filter((x) => x !== name) : [...l, name]));
  const profile = status && status.profile;
  return html`<form class="calibrate-form" data-testid="calibrate-form" onSubmit=${(e) => { e.preventDefault(); run(true); }} aria-label="Calibrate the instrument on this scan">
    <p class="muted" data-testid="profile-version">Profile in use: ${profile ? `${profile.name} #${profile.version}${profile.calibrated_at ? `, calibrated ${shortTime(profile.calibrated_at)}` : ' (as configured)'}` : '–'}</p>
    <fieldset><legend>Instrument parameters to fit</legend>
      ${CAL_PARAMS.map((n) => html`<label class="check"><input type="checkbox" name="fit" value=${n} checked=${params.includes(n)} onChange=${() => toggle(n)} /> ${n}</label>`)}
    </fieldset>
    <div class="field"><label for="cal-sample">Known sample's BSDF (empty: the catalogued one)</label>
      <input id="cal-sample" value=${spec} onInput=${(e) => setSpec(e.currentTarget.value)} /></div>
    ${error && html`<div class="form-error" role="alert" data-testid="calibrate-error">${error}</div>`}
    <div class="row">
      <button type="submit" data-testid="calibrate-dry" disabled=${!!busy || params.length === 0}>Dry run</button>
      <button type="button" class="danger" data-testid="calibrate-apply" disabled=${!!busy || !dry || dry.key !== key}
        title="Fits again and stores the corrected profile for the scans started from now on" onClick=${() => run(false)}>Calibrate and apply</button>
      ${busy && html`<span role="status" data-testid="calibrate-progress"><progress aria-label="calibrating"></progress> ${busy === 'dry' ? 'dry run' : 'calibrating'}… ${elapsed} s</span>`}
    </div>
    <p class="muted">The dry run fits and stores the result with the scan but keeps the profile; apply is offered after a dry run of the same parameters.</p>
  </form>`;
}

export function ScanView({ scanId, samples, status, role, call, bus, thresholds, notify, navigate, reloads }) {
  const [scan, setScan] = useState(null);
  const [shown, setShown] = useState(null); // the fit whose curve is drawn
  const [curve, setCurve] = useState(null); // {key → β per channel, wavelengths}
  const [extraFits, setExtraFits] = useState([]); // fits made here, before scan.get lists them
  const [alerts, setAlerts] = useState([]);
  const geometries = useRef(null);

  useEffect(() => {
    call('alert.list', { scan: scanId, limit: 50 }).then(setAlerts, () => {});
  }, [scanId, reloads, scan && scan.state]);

  const onScan = useCallback((s) => setScan(s), []);
  const sample = scan ? samples.find((x) => x.id === scan.plan.sample) : null;
  const fits = useMemo(() => {
    const seen = new Set();
    // An adaptive scan's loop state is stored as a fit of its own kind: its panel shows it.
    return [...extraFits, ...((scan && scan.fits) || [])].filter((f) => f.kind !== 'adaptive' && (f.id == null || !seen.has(f.id)) && (seen.add(f.id), true))
      .sort((a, b) => (b.id || 0) - (a.id || 0));
  }, [scan, extraFits]);

  // The fitted model's curve: the twin (current profile) predicts the scan's geometries with
  // the fitted spec, at every channel of the scan.
  const draw = async (fit) => {
    setShown(fit);
    setCurve(null);
    const spec = fit && fit.result && fit.result.spec;
    if (!spec || fit.kind !== 'fit') return;
    try {
      if (!geometries.current) geometries.current = (await call('scan.get', { scan: scanId, geometries: true })).plan.geometries;
      const r = await call('twin.predict', { bsdf: spec, geometries: geometries.current.slice(0, 1000), wavelengths: scan.plan.wavelengths });
      const m = new Map();
      for (const q of r.predictions) m.set(`${q.geometry.theta_i}/${q.geometry.theta_r}`, q);
      setCurve(m);
    } catch (e) { notify(`fitted curve: ${e.message}`); }
  };
  const fitted = useMemo(() => (curve ? (ti, tr, nm) => {
    const q = curve.get(`${ti}/${tr}`);
    return q ? q.radiance_factor[channelOf(q.wavelengths_nm, nm)] : null;
  } : null), [curve]);

  const done = scan && finished(scan.state);
  const v = verdictBadge(scan && scan.verdict);
  return html`<div class="scan-view" data-testid="scan-view" data-scan=${scanId}>
    <section class="panel scan-meta">
      <h2>Scan ${scanId}${scan && scan.plan.name ? ` · ${scan.plan.name}` : ''}</h2>
      ${scan ? html`<p data-testid="scan-meta" data-state=${scan.state} data-verdict=${v.decision}>
        sample <a href=${`#/sample/${scan.plan.sample}`}>${sample ? sample.name : scan.plan.sample}</a>${` · ${scan.state}${scan.reason ? ` (${scan.reason})` : ''} · submitted ${shortTime(scan.submitted_at)} by ${scan.submitted_by} · finished ${shortTime(scan.finished_at)} · `}<a href=${`#/scans?sample=${scan.plan.sample}`}>this sample's scans</a></p>` : html`<p class="muted">loading…</p>`}
    </section>
    <${ScanPanel} scanId=${scanId} call=${call} bus=${bus} thresholds=${thresholds} notify=${notify} fitted=${fitted} onScan=${onScan} reloads=${reloads} />
    <section class="panel" aria-labelledby="h-scan-alerts">
      <h2 id="h-scan-alerts">This scan's alerts</h2>
      <ul class="alerts" data-testid="scan-alerts">
        ${alerts.length === 0 && html`<li class="muted">none</li>`}
        ${alerts.map((a) => html`<li key=${a.id} class=${`alert sev-${a.severity}${a.acknowledged ? ' acked' : ''}${a.resolved_at ? ' resolved' : ''}`}><span class="badge">${a.severity}</span>
          <span class="kind">${a.kind}${a.count > 1 ? ` ×${a.count}` : ''}</span> <span class="msg">${a.message}</span>
          ${a.resolved_at && html`<span class="resolution" data-testid="alert-resolution">${a.resolution}</span>`}</li>`)}
      </ul>
    </section>
    <section class="panel" aria-labelledby="h-fits">
      <h2 id="h-fits">Inverse twin</h2>
      <ul class="fits" data-testid="fits">
        ${fits.length === 0 && html`<li class="muted">no stored fits</li>`}
        ${fits.map((f) => html`<li key=${f.id} data-testid="fit-item" data-kind=${f.kind}>
          <button class="link" onClick=${() => draw(f)} aria-pressed=${shown && shown.id === f.id ? 'true' : 'false'}>${f.kind} #${f.id}</button>
          <code>${f.model}</code> <span class="muted">χ²/dof ${fmt(f.result && f.result.chi2_per_dof, 3)} · ${f.created_by} · ${shortTime(f.created_at)}</span></li>`)}
      </ul>
      ${shown && html`<${FitResult} fit=${shown} />`}
      ${shown && shown.kind === 'fit' && shown.id != null && can(role, 'fit') && html`<${MaterialExport} scan=${scan} fit=${shown} call=${call} notify=${notify} />`}
      ${shown && shown.kind === 'fit' && html`<p class="muted" data-testid="fit-curve" data-drawn=${String(!!curve)}>${curve ? 'The fitted model, through the twin, is drawn over the points.' : 'Predicting the fitted curve…'}</p>`}
      ${can(role, 'fit') && scan && (scan.points_done > 0
        ? html`<h3>Fit a model</h3><${FitForm} scan=${scan} sampleSpec=${sample && sample.bsdf} call=${call} notify=${notify}
            onFitted=${(f) => { setExtraFits((l) => [f, ...l]); draw(f); }} />`
        : html`<p class="muted">A fit needs measured points.</p>`)}
      ${can(role, 'calibrate') && scan && scan.points_done > 0 && html`<h3>Calibrate the instrument</h3>
        ${!done && html`<p class="muted">The scan is ${scan.state}: a calibration uses the points measured so far.</p>`}
        <${CalibrateForm} scan=${scan} status=${status} call=${call} notify=${notify} onDone=${(r) => { setExtraFits((l) => [r, ...l]); setShown(r); }} />`}
    </section>
  </div>`;
}
