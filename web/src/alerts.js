// Alerts, newest first, coloured by severity, grouped per scan (a scan's repeated alerts
// under one heading that opens the scan); technicians acknowledge them. The ones goniod
// resolved (the scan's final verdict no longer supports them) are listed apart, below.
import { html } from './ui.js';
import { groupAlerts, splitAlerts } from './logic/alerts.js';
import { shortTime } from './logic/format.js';
import { can } from './logic/roles.js';

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

// A resolved alert: what was seen, and why it no longer stands.
function ResolvedItem({ a, onShowScan }) {
  return html`<li class=${`alert resolved sev-${a.severity}`} data-testid=${`alert-${a.id}`} data-kind=${a.kind} data-resolved="true">
    <span class="badge">${a.severity}</span>
    <span class="kind">${a.kind}</span>
    ${a.scan_id && html`<button class="link" onClick=${() => onShowScan(a.scan_id)}>scan ${a.scan_id}</button>`}
    <span class="msg">${a.message}</span>
    <span class="resolution" data-testid="alert-resolution">${a.resolution}</span>
    <span class="muted">resolved ${shortTime(a.resolved_at)}</span>
  </li>`;
}

export function AlertsPanel({ alerts: all, role, call, notify, onShowScan }) {
  const ack = async (id) => {
    try { await call('alert.ack', { alert: id }); } catch (e) { notify(`alert.ack: ${e.message}`); }
  };
  const { standing: alerts, resolved } = splitAlerts(all);
  const groups = groupAlerts(alerts);
  return html`<section class="panel" aria-labelledby="h-alerts">
    <h2 id="h-alerts">Alerts</h2>
    <ul class="alerts" data-testid="alerts">
      ${alerts.length === 0 && html`<li class="muted">no standing alerts</li>`}
      ${groups.map((g) => (g.scan === null
        ? html`<${AlertItem} key=${`a${g.alerts[0].id}`} a=${g.alerts[0]} role=${role} ack=${ack} />`
        : html`<li key=${`s${g.scan}`} class="alert-group" data-testid="alert-group" data-scan=${g.scan}>
          <div class="group-head"><button class="link" onClick=${() => onShowScan(g.scan)}>scan ${g.scan}</button>
            <span class="muted">${g.alerts.length} alert${g.alerts.length > 1 ? 's' : ''}${g.alerts.some((a) => !a.acknowledged) ? `, ${g.alerts.filter((a) => !a.acknowledged).length} unacknowledged` : ''}</span></div>
          <ul>${g.alerts.map((a) => html`<${AlertItem} key=${a.id} a=${a} role=${role} ack=${ack} />`)}</ul>
        </li>`))}
    </ul>
    ${resolved.length > 0 && html`<h3 id="h-alerts-resolved">Resolved by the final verdict</h3>
    <ul class="alerts resolved" data-testid="alerts-resolved" aria-labelledby="h-alerts-resolved">
      ${resolved.map((a) => html`<${ResolvedItem} key=${a.id} a=${a} onShowScan=${onShowScan} />`)}
    </ul>`}
  </section>`;
}
