// Alerts, newest first, coloured by severity; technicians acknowledge them.
import { html } from './ui.js';
import { can } from './logic.js';

export function AlertsPanel({ alerts, role, call, notify, onShowScan }) {
  const ack = async (id) => {
    try { await call('alert.ack', { alert: id }); } catch (e) { notify(`alert.ack: ${e.message}`); }
  };
  return html`<section class="panel" aria-labelledby="h-alerts">
    <h2 id="h-alerts">Alerts</h2>
    <ul class="alerts" data-testid="alerts">
      ${alerts.length === 0 && html`<li class="muted">no alerts</li>`}
      ${alerts.map((a) => html`<li key=${a.id} class=${`alert sev-${a.severity}${a.acknowledged ? ' acked' : ''}`} data-testid=${`alert-${a.id}`} data-kind=${a.kind} data-acknowledged=${String(a.acknowledged)}>
        <span class="badge">${a.severity}</span>
        <span class="kind">${a.kind}${a.count > 1 ? ` ×${a.count}` : ''}</span>
        <span class="msg">${a.message}</span>
        <span class="muted">${(a.last_at || '').replace('T', ' ').replace(/\.\d+Z$/, 'Z')}</span>
        ${a.scan_id && html`<button class="link" onClick=${() => onShowScan(a.scan_id)}>scan ${a.scan_id}</button>`}
        ${a.acknowledged ? html`<span class="muted">acknowledged by ${a.acknowledged_by}</span>`
          : can(role, 'ack') && html`<button data-testid="alert-ack" onClick=${() => ack(a.id)}>Acknowledge</button>`}
      </li>`)}
    </ul>
  </section>`;
}
