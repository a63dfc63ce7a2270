// When to act: the WebSocket's reconnect back-off, and re-rendering at a readable rate.

// Reconnect delay for the attempt-th retry (0-based): doubling from `base` to `max`, with
// jitter in [½, 1] of that so that many tabs do not come back in step after a restart.
export function backoffDelay(attempt, { base = 250, max = 8000, random = Math.random } = {}) {
  const d = Math.min(max, base * 2 ** Math.min(attempt, 30));
  return Math.round(d * (0.5 + 0.5 * random()));
}

// fn(latest value) at most once per `ms`: notifications that arrive with every point
// (progress, instrument state) re-render the page at a readable rate, not at the point rate.
export function coalesce(fn, ms, timers = globalThis) {
  let latest, timer = null;
  return (v) => {
    latest = v;
    if (timer !== null) return;
    timer = timers.setTimeout(() => { timer = null; fn(latest); }, ms);
  };
}
