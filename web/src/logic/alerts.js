// The alert list: upserted as notifications arrive, counted, split into standing and resolved,
// grouped per scan.

// Upsert by id, newest (highest id) first: the alert list.
export function mergeAlerts(list, incoming) {
  const byId = new Map(list.map((a) => [a.id, a]));
  for (const a of incoming) byId.set(a.id, a);
  return [...byId.values()].sort((a, b) => b.id - a.id);
}

// The alerts that still ask for someone: unacknowledged and standing (a resolved alert's
// scan ended with a verdict that no longer supports it).
export function unacknowledged(alerts) {
  return alerts.reduce((n, a) => n + (a.acknowledged || a.resolved_at ? 0 : 1), 0);
}

// Standing alerts and the ones goniod resolved, apart, each newest first.
export function splitAlerts(alerts) {
  const standing = [], resolved = [];
  for (const a of alerts) (a.resolved_at ? resolved : standing).push(a);
  return { standing, resolved };
}

// Alerts (newest first) in groups: one per scan (its alerts newest first), and one per alert
// that names no scan, in the order of each group's newest alert.
export function groupAlerts(alerts) {
  const groups = [];
  const byScan = new Map();
  for (const a of alerts) {
    if (a.scan_id) {
      let g = byScan.get(a.scan_id);
      if (!g) { g = { scan: a.scan_id, alerts: [] }; byScan.set(a.scan_id, g); groups.push(g); }
      g.alerts.push(a);
    } else groups.push({ scan: null, alerts: [a] });
  }
  return groups;
}
