// One sample (#/sample/ID): its catalog entry and its scans, newest first.
import { html } from './ui.js';
import { fmt, shortTime } from './logic/format.js';
import { ScansPanel } from './scans.js';

export function SampleView({ sampleId, samples, call, navigate, reloads }) {
  const s = samples.find((x) => x.id === sampleId);
  return html`<div class="sample-view" data-testid="sample-view" data-sample=${sampleId}>
    <section class="panel">
      <h2>Sample ${s ? s.name : sampleId}</h2>
      ${s ? html`<dl class="facts">
        <dt>BSDF</dt><dd><code>${s.bsdf || '–'}</code></dd>
        <dt>tolerance</dt><dd>${fmt(s.tolerance, 3)}</dd>
        <dt>notes</dt><dd>${s.notes || '–'}</dd>
        <dt>created</dt><dd>${shortTime(s.created_at)}</dd>
      </dl>` : html`<p class="muted">${samples.length ? `No sample ${sampleId} in the catalog.` : 'loading…'}</p>`}
    </section>
    <${ScansPanel} params=${{ sample: String(sampleId) }} samples=${samples} call=${call} navigate=${navigate} reloads=${reloads} />
  </div>`;
}
