// Alerts, newest first, coloured by severity, grouped per scan (a scan's repeated alerts
// under one heading that opens the scan); technicians acknowledge them.
import { html } from './ui.js';
import { can, groupAlerts, shortTime } from './logic.js';

function AlertItem({ a, role, ack }) {
  return html`<li class=${`alert sev-${a.severity}${a.acknowledged ? ' acked' : ''}`} data-testid=${`alert-${a.id}`} data-kind=${a.kind} data-acknowledged=${String(a.acknowledged)}>
    <span class="badge">${a.severity}</span>
    <span class="kind">${a.kind}${a.count > 1 ? ` ×${a.count}` : ''}</span>
    <span class="msg">${a.message}</span>
    <span class="muted">${shortTime(a.last_at)}</span>
    ${a.acknowledged ? html`<span class="muted">acknowledged by ${a.acknowledged_by}</span>`
      : can(role, 'ack') && html`<button data-testid="alert-ack" onClick=${() => ack(a.id)}>Acknowledge</button>`}
  </li>`;
}

export function AlertsPanel({ alerts, role, call, notify, onShowScan }) {
  const ack = async (id) => {
    try { await call('alert.ack', { alert: id }); } catch (e) { notify(`alert.ack: ${e.message}`); }
  };
  const groups = groupAlerts(alerts);
  return html`<section class="panel" aria-labelledby="h-alerts">
    <h2 id="h-alerts">Alerts</h2>
    <ul class="alerts" data-testid="alerts">
      ${alerts.length === 0 && html`<li class="muted">no alerts</li>`}
      ${groups.map((g) => (g.scan === null
        ? html`<${AlertItem} key=${`a${g.alerts[0].id}`} a=${g.alerts[0]} role=${role} ack=${ack} />`
        : html`<li key=${`s${g.scan}`} class="alert-group" data-testid="alert-group" data-scan=${g.scan}>
          <div class="group-head"><button class="link" onClick=${() => onShowScan(g.scan)}>scan ${g.scan}</button>
            <span class="muted">${g.alerts.length} alert${g.alerts.length > 1 ? 's' : ''}${g.alerts.some((a) => !a.acknowledged) ? `, ${g.alerts.filter((a) => !a.acknowledged).length} unacknowledged` : ''}</span></div>
          <ul>${g.alerts.map((a) => html`<${AlertItem} key=${a.id} a=${a} role=${role} ack=${ack} />`)}</ul>
        </li>`))}
    </ul>
  </section>`;
}
