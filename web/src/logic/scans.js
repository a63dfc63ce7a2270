// The scans' history: scan.list's params from the page's filters, and the states a scan is over in.

import { formFieldOf } from './format.js';

export const HISTORY_PAGE = 25;
export const SCAN_STATES = ['queued', 'running', 'paused', 'interrupted', 'completed', 'failed', 'cancelled'];

// scan.list params from the history's filters (the route's params: sample, state, from, to
// (days, YYYY-MM-DD, both included), text, page (1-based)). One row more than a page is asked
// for: its presence says there is a next page.
export function historyQuery(f = {}) {
  const p = { limit: HISTORY_PAGE + 1, offset: HISTORY_PAGE * Math.max(0, (Number(f.page) || 1) - 1) };
  if (f.sample) p.sample = /^\d+$/.test(f.sample) ? Number(f.sample) : f.sample;
  if (f.state) p.state = f.state;
  if (f.from) p.since = `${f.from}T00:00:00Z`;
  if (f.to) p.until = `${nextDay(f.to)}T00:00:00Z`;
  if (f.text && f.text.trim()) p.text = f.text.trim();
  return p;
}

// The day after an ISO date (YYYY-MM-DD), in UTC; the text itself when it is not a date (goniod
// then names the field).
export function nextDay(day) {
  if (!/^\d{4}-\d{2}-\d{2}$/.test(day)) return day;
  const t = new Date(`${day}T00:00:00Z`);
  if (Number.isNaN(t.getTime())) return day;
  t.setUTCDate(t.getUTCDate() + 1);
  return t.toISOString().slice(0, 10);
}

// The history's filter a scan.list error names (since → from, until → to).
export function historyField(path) {
  const f = formFieldOf(path);
  return { since: 'from', until: 'to' }[f] || f;
}

// States a scan is over in: they can be fitted, compared and are not live.
export function finished(state) {
  return state === 'completed' || state === 'failed' || state === 'cancelled';
}
