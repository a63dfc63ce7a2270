// Shared bits of the views: htm bound to Preact, a field with its API error, a uPlot host.
import { h } from 'preact';
import { useEffect, useRef } from 'preact/hooks';
import htm from 'htm';
import { describeError } from './logic/format.js';

export const html = htm.bind(h);

// onInput handlers for a form held in one state object: `setter(setForm)(key)`. A functional
// update, so that inputs arriving before the next render (fast typing, a form filled by a
// script) each build on the latest state, not on the render's copy.
export const setter = (setForm) => (k) => (e) => {
  const v = e.currentTarget.value;
  setForm((f) => ({ ...f, [k]: v }));
};

// A labelled input whose API error (error.data.field) is shown beneath it.
export function Field({ name, label, error, children, hint }) {
  const id = `f-${name}`;
  return html`<div class=${'field' + (error ? ' invalid' : '')}>
    <label for=${id}>${label}</label>
    ${children(id, error ? `${id}-err` : undefined)}
    ${hint && html`<small class="hint">${hint}</small>`}
    ${error && html`<div class="field-error" id=${`${id}-err`} role="alert" data-testid=${`field-error-${name}`}>${error}</div>`}
  </div>`;
}

// Errors of a failed call split into the one of a form field and the rest.
export function fieldErrors(e, fields) {
  const d = describeError(e);
  if (d.field && fields.includes(d.field)) return { [d.field]: d.message };
  return { _form: d.message };
}

// Mounts make(el, width) → uPlot when deps change and destroys it after; resizes to the host.
export function PlotHost({ make, deps, testid, height = 260, attrs = {} }) {
  const ref = useRef(null);
  useEffect(() => {
    const el = ref.current;
    const width = Math.max(280, el.clientWidth || 600);
    const plot = make(el, width, height);
    const ro = typeof ResizeObserver !== 'undefined' && plot
      ? new ResizeObserver(() => plot.setSize({ width: Math.max(280, el.clientWidth), height })) : null;
    if (ro) ro.observe(el);
    return () => { if (ro) ro.disconnect(); if (plot) plot.destroy(); };
  }, deps);
  return html`<div class="plot" ref=${ref} data-testid=${testid} ...${attrs}></div>`;
}

export function download(filename, mediaType, content) {
  const url = URL.createObjectURL(new Blob([content], { type: mediaType || 'application/octet-stream' }));
  const a = document.createElement('a');
  a.href = url;
  a.download = filename;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 1000);
}
