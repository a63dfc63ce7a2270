// The instrument panel: state, fault latch, the goniometer diagram, drivers and links, Stop.
import { useState } from 'preact/hooks';
import { html } from './ui.js';
import { armEnd, collisionWedge } from './logic/diagram.js';
import { fmt } from './logic/format.js';
import { can } from './logic/roles.js';

export function Goniometer({ thetaI, thetaR, sep }) {
  const cx = 130, cy = 120, r = 100;
  const src = armEnd(thetaI, r, cx, cy, -1);
  const rcv = armEnd(thetaR, r, cx, cy, 1);
  return html`<svg viewBox="0 0 260 140" class="gonio" role="img" data-testid="goniometer"
      aria-label=${`source arm at θi = ${fmt(thetaI)}°, receiver arm at θr = ${fmt(thetaR)}°`}>
    <path class="rail" d=${`M${cx - r},${cy} A${r},${r} 0 0 1 ${cx + r},${cy}`} />
    <path class="collision" d=${collisionWedge(thetaI, sep, r, cx, cy)}><title>${`collision zone: |θi + θr| < ${sep}°`}</title></path>
    <line class="normal" x1=${cx} y1=${cy} x2=${cx} y2=${cy - r - 8} />
    <line class="arm source" x1=${cx} y1=${cy} x2=${src.x} y2=${src.y} />
    <circle class="head source" cx=${src.x} cy=${src.y} r="6" />
    <line class="arm receiver" x1=${cx} y1=${cy} x2=${rcv.x} y2=${rcv.y} />
    <circle class="head receiver" cx=${rcv.x} cy=${rcv.y} r="6" />
    <rect class="sample" x=${cx - 22} y=${cy} width="44" height="6" />
    <text x="6" y="134">θi ${fmt(thetaI, 3)}°</text>
    <text x="254" y="134" text-anchor="end">θr ${fmt(thetaR, 3)}°</text>
  </svg>`;
}

export function InstrumentPanel({ status, role, call, notify }) {
  const [busy, setBusy] = useState(false);
  if (!status) return html`<section class="panel"><h2>Instrument</h2><p>…</p></section>`;
  const pos = status.positions || {};
  const act = async (method) => {
    setBusy(true);
    try { await call(method); } catch (e) { notify(`${method}: ${e.message}`); }
    setBusy(false);
  };
  const devices = Object.entries(status.devices || {});
  return html`<section class="panel instrument" aria-labelledby="h-instrument">
    <h2 id="h-instrument">Instrument</h2>
    <div class="row">
      <span class=${`state state-${status.state}`} data-testid="instrument-state">${status.state}</span>
      ${status.scan && html`<span>scan ${status.scan}</span>`}
    </div>
    ${status.fault_latched && html`<div class="fault" role="alert" data-testid="fault">
      Fault latched: ${status.fault_reason || status.error}
      ${can(role, 'control') && html` <button onClick=${() => act('instrument.reset')} disabled=${busy}>Reset</button>`}
    </div>`}
    <${Goniometer} thetaI=${pos.incidence ?? 0} thetaR=${pos.receive ?? 0} sep=${(status.limits && status.limits.min_separation) || 10} />
    <table class="devices" data-testid="devices">
      <thead><tr><th>device</th><th>driver</th><th>link</th><th>last error</th></tr></thead>
      <tbody>${devices.map(([name, d]) => html`<tr key=${name}>
        <td>${name}</td><td>${d.driver}</td>
        <td class=${`link-${d.link}`}>${d.link}${d.next_retry_s != null ? ` (retry in ${fmt(d.next_retry_s, 2)} s)` : ''}</td>
        <td>${d.last_error || '–'}</td></tr>`)}</tbody>
    </table>
    ${status.axes_to_home && status.axes_to_home.length > 0 && html`<p class="warn">to home: ${status.axes_to_home.join(', ')}</p>`}
    <p class="muted">profile ${status.profile ? `${status.profile.name}#${status.profile.version}` : '–'} · ${status.photometer ? status.photometer.identity : ''}</p>
  </section>`;
}
