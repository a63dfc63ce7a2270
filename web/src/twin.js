// The twin playground: a BSDF spec, a geometry grid and wavelengths → β with its s.e.
import { useState } from 'preact/hooks';
import { html, Field, setter, fieldErrors, PlotHost } from './ui.js';
import { fmt } from './logic/format.js';
import { channelOf } from './logic/points.js';
import { predictionColumns, predictionPlot } from './plot.js';

export function TwinPanel({ call }) {
  const [form, setForm] = useState({ bsdf: 'conductor:alpha=0.05,eta=0.2,k=3.9', grids: 'in=45;out=-80:80:2', wavelengths: '400:700:50', rel_se: '0.01' });
  const [errors, setErrors] = useState({});
  const [result, setResult] = useState(null);
  const [nm, setNm] = useState(550);
  const [busy, setBusy] = useState(false);
  const set = setter(setForm);
  const run = async (e) => {
    e.preventDefault();
    setBusy(true);
    try {
      const r = await call('twin.predict', { bsdf: form.bsdf, grids: form.grids.split('\n').map((s) => s.trim()).filter(Boolean), wavelengths: form.wavelengths, rel_se: Number(form.rel_se) });
      setResult(r);
      const wl = r.predictions[0] ? r.predictions[0].wavelengths_nm : [];
      setNm((cur) => (wl.length ? wl[channelOf(wl, cur)] : cur));
      setErrors({});
    } catch (err) { setErrors(fieldErrors(err, ['bsdf', 'grids', 'geometries', 'wavelengths', 'rel_se'])); }
    setBusy(false);
  };
  const input = (k, extra = {}) => (id, d) => html`<input id=${id} value=${form[k]} onInput=${set(k)} aria-invalid=${errors[k] ? 'true' : 'false'} aria-describedby=${d} ...${extra} />`;
  const wl = result && result.predictions[0] ? result.predictions[0].wavelengths_nm : [];
  const cols = result ? predictionColumns(result.predictions, nm) : null;
  return html`<section class="panel" aria-labelledby="h-twin">
    <h2 id="h-twin">Twin playground</h2>
    <form onSubmit=${run} data-testid="twin-form" novalidate>
      <${Field} name="bsdf" label="BSDF spec" error=${errors.bsdf}>${input('bsdf')}<//>
      <${Field} name="grids" label="Geometry grid" error=${errors.grids || errors.geometries}>${input('grids')}<//>
      <div class="row">
        <${Field} name="wavelengths" label="Wavelengths (nm)" error=${errors.wavelengths}>${input('wavelengths')}<//>
        <${Field} name="rel_se" label="Relative s.e." error=${errors.rel_se}>${input('rel_se', { type: 'number', step: '0.001', min: '0.0001', max: '0.5' })}<//>
      </div>
      ${errors._form && html`<div class="form-error" role="alert">${errors._form}</div>`}
      <button type="submit" disabled=${busy}>${busy ? 'Predicting…' : 'Predict'}</button>
    </form>
    ${result && html`<div>
      <label>λ <select value=${nm} onChange=${(e) => setNm(Number(e.currentTarget.value))}>${wl.map((w) => html`<option value=${w}>${w} nm</option>`)}</select></label>
      <span class="muted"> ${result.twin_version}</span>
      <${PlotHost} testid="twin-plot" deps=${[result, nm]} make=${(el, w, h) => predictionPlot(el, cols, { nm, width: w, height: h })} />
      <table class="numbers"><thead><tr><th>θr (°)</th><th>β</th><th>s.e.</th></tr></thead>
        <tbody>${cols[0].map((t, i) => html`<tr><td>${fmt(t, 3)}</td><td>${fmt(cols[1][i])}</td><td>${fmt(cols[2][i], 2)}</td></tr>`)}</tbody></table>
    </div>`}
  </section>`;
}
