// The sample catalog; technicians create samples and see the twin's predicted curve first.
import { useState } from 'preact/hooks';
import { html, Field, setter, fieldErrors, PlotHost } from './ui.js';
import { fmt } from './logic/format.js';
import { can } from './logic/roles.js';
import { predictionColumns, predictionPlot } from './plot.js';

const PREVIEW_GRID = 'in=45;out=-80:80:4';
const PREVIEW_NM = 550;

export function SamplesPanel({ samples, role, call, onCreated }) {
  const [form, setForm] = useState({ name: '', bsdf: '', tolerance: '0.02', notes: '' });
  const [errors, setErrors] = useState({});
  const [preview, setPreview] = useState(null);
  const [busy, setBusy] = useState(false);
  const set = setter(setForm);
  const run = async (what) => {
    setBusy(true);
    try {
      if (what === 'preview') {
        const r = await call('twin.predict', { bsdf: form.bsdf, grids: [PREVIEW_GRID], wavelengths: String(PREVIEW_NM) });
        setPreview(predictionColumns(r.predictions, PREVIEW_NM));
        setErrors({});
      } else {
        const params = { name: form.name, tolerance: Number(form.tolerance) };
        if (form.bsdf) params.bsdf = form.bsdf;
        if (form.notes) params.notes = form.notes;
        const s = await call('sample.create', params);
        setErrors({});
        onCreated(s);
      }
    } catch (e) { setErrors(fieldErrors(e, ['name', 'bsdf', 'tolerance', 'notes'])); }
    setBusy(false);
  };
  const input = (k, type = 'text', extra = {}) => (id, d) => html`<input id=${id} type=${type} value=${form[k]} onInput=${set(k)} aria-invalid=${errors[k] ? 'true' : 'false'} aria-describedby=${d} ...${extra} />`;
  return html`<section class="panel" aria-labelledby="h-samples">
    <h2 id="h-samples">Samples</h2>
    <table class="samples" data-testid="samples">
      <thead><tr><th>id</th><th>name</th><th>BSDF</th><th>tolerance</th><th>notes</th><th>scans</th></tr></thead>
      <tbody>${samples.map((s) => html`<tr key=${s.id}><td>${s.id}</td><td><a href=${`#/sample/${s.id}`} data-testid="sample-link">${s.name}</a></td><td><code>${s.bsdf || '–'}</code></td><td>${fmt(s.tolerance, 3)}</td><td>${s.notes}</td>
        <td><a href=${`#/scans?sample=${s.id}`} data-testid="sample-scans">scans</a></td></tr>`)}</tbody>
    </table>
    ${can(role, 'create') && html`<form class="sample-form" data-testid="sample-create" onSubmit=${(e) => { e.preventDefault(); run('create'); }} novalidate>
      <h3>New sample</h3>
      <${Field} name="name" label="Name" error=${errors.name}>${input('name')}<//>
      <${Field} name="bsdf" label="BSDF spec" error=${errors.bsdf} hint="e.g. lambert:albedo=0.5+coat:alpha=0.05,ior=1.5">${input('bsdf')}<//>
      <${Field} name="tolerance" label="Tolerance (relative)" error=${errors.tolerance}>${input('tolerance', 'number', { step: '0.001', min: 0, max: 1 })}<//>
      <${Field} name="notes" label="Notes" error=${errors.notes}>${input('notes')}<//>
      ${errors._form && html`<div class="form-error" role="alert">${errors._form}</div>`}
      <div class="row">
        <button type="button" data-testid="sample-preview" disabled=${busy || !form.bsdf} onClick=${() => run('preview')}>Preview the twin's curve</button>
        <button type="submit" disabled=${busy || !form.name}>Save sample</button>
      </div>
      ${preview && html`<p class="muted">${PREVIEW_GRID}, ${PREVIEW_NM} nm</p>
        <${PlotHost} testid="sample-preview-plot" deps=${[preview]} height=${220} make=${(el, w, h) => predictionPlot(el, preview, { nm: PREVIEW_NM, width: w, height: h })} />`}
    </form>`}
  </section>`;
}
