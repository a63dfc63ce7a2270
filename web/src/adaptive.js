// An adaptive scan's loop beside its plot: the state (running, target reached, stopped at
// max_points) and the warnings, a misfit first; each parameter's value ± u, or the curve's
// estimated error; the uncertainty against the points used with the target as a line; and the
// points in the order the twin chose them, the latest marked.
import { useEffect, useRef } from 'preact/hooks';
import { html } from './ui.js';
import { adaptiveState, adaptiveWarnings, chosenOrder, parameterLines } from './logic/adaptive.js';
import { fmt } from './logic/format.js';
import { adaptivePlot, adaptiveData } from './plot.js';

const SHOWN_PICKS = 300; // the most recent choices listed; the plot marks them all

// track: logic.js AdaptiveTrack (mutated as progress comes; its version changes with it).
function UncertaintyPlot({ track, mode, target }) {
  const ref = useRef(null);
  const plot = useRef(null);
  const cols = track.columns();
  const shape = `${mode}|${target}|${cols.labels.join(',')}`;
  useEffect(() => {
    const el = ref.current;
    const width = Math.max(280, el.clientWidth || 420);
    const p = adaptivePlot(el, track.columns(), {
      target, width, height: 200,
      ylabel: mode === 'curve' ? 'estimated error' : 'u / |value|',
    });
    plot.current = p;
    const ro = typeof ResizeObserver !== 'undefined' ? new ResizeObserver(() => p.setSize({ width: Math.max(280, el.clientWidth), height: 200 })) : null;
    if (ro) ro.observe(el);
    return () => { if (ro) ro.disconnect(); p.destroy(); plot.current = null; };
  }, [shape]);
  useEffect(() => { if (plot.current) plot.current.setData(adaptiveData(track.columns())); }, [track.version]);
  return html`<div class="plot adaptive-plot" ref=${ref} data-testid="adaptive-plot" data-rows=${String(cols.x.length)}
    data-series=${String(cols.labels.length)} aria-label=${mode === 'curve' ? 'estimated error against points used' : 'relative uncertainty against points used'}></div>`;
}

function Picks({ points }) {
  const all = chosenOrder(points);
  const shown = all.slice(-SHOWN_PICKS);
  return html`<div class="adaptive-picks">
    <h3>Chosen points, in order</h3>
    ${all.length === 0 && html`<p class="muted">none yet: the seeds come first</p>`}
    ${all.length > shown.length && html`<p class="muted">… ${all.length - shown.length} earlier</p>`}
    <ol class="picks" data-testid="adaptive-chosen" data-count=${String(all.length)}>
      ${shown.map((c) => html`<li key=${c.index} value=${c.order} class=${`pick${c.latest ? ' latest' : ''}${c.reading > 1 ? ' again' : ''}`}
        data-testid="adaptive-pick" data-candidate=${String(c.candidate)} data-reading=${String(c.reading)} data-latest=${String(c.latest)}
        title=${`point ${c.index}: candidate ${c.candidate}, θi ${fmt(c.thetaI, 4)}°, θr ${fmt(c.thetaR, 4)}°${c.reading > 1 ? `, reading ${c.reading}` : ''}`}>
        <span class="n">${c.order}</span> ${fmt(c.thetaR, 4)}°${c.reading > 1 ? html` <span class="again">×${c.reading}</span>` : ''}${c.latest ? html` <span class="latest-tag">latest</span>` : ''}</li>`)}
    </ol>
  </div>`;
}

// scan: scan.get (its plan.adaptive, state); status: the loop's latest status; track:
// AdaptiveTrack; points: the scan's point records; candidates: the plan's geometries (null
// until read).
export function AdaptivePanel({ scan, status, track, points, candidates }) {
  const plan = scan.plan.adaptive || {};
  const mode = (status && status.mode) || plan.mode;
  const target = mode === 'curve' ? plan.tolerance : plan.target_rel_u;
  const st = adaptiveState(status, scan.state);
  const warnings = adaptiveWarnings(status);
  const params = parameterLines(status, target);
  const measured = new Set(points.map((p) => p.geometry_index)).size;
  return html`<div class="adaptive" data-testid="adaptive" data-mode=${mode} data-scan-state=${scan.state}>
    <h3>Adaptive scan · ${mode === 'curve' ? 'curve mode' : 'parameters mode'}</h3>
    <p class="muted">${mode === 'curve'
      ? `Points until the interpolated curve is within ${fmt(100 * target, 3)} % everywhere`
      : html`Fitting <code>${plan.model}</code> until every u/|value| ≤ ${fmt(100 * target, 3)} %`}, at most ${plan.max_points} points;
      ${candidates ? ` ${candidates.length} candidates,` : ''} ${measured} measured.</p>
    <p><span class=${`verdict tone-${st.tone}`} data-testid="adaptive-state" data-state=${st.state}>${st.text}</span>
      ${mode !== 'curve' && status && status.chi2_per_dof != null && html` <span class="muted" data-testid="adaptive-chi2">χ²/dof ${fmt(status.chi2_per_dof, 3)}</span>`}</p>
    ${warnings.length > 0 && html`<ul class="warnings" data-testid="adaptive-warnings">${warnings.map((w) => html`<li class=${w.misfit ? 'warn misfit' : 'warn'} data-testid=${w.misfit ? 'adaptive-misfit' : 'adaptive-warning'} role=${w.misfit ? 'alert' : undefined}>${w.text}</li>`)}</ul>`}
    ${mode === 'curve'
      ? html`<p data-testid="adaptive-error" data-value=${status && status.estimated_error != null ? String(status.estimated_error) : ''}>estimated error ${status && status.estimated_error != null ? `${fmt(100 * status.estimated_error, 3)} %` : '–'} (tolerance ${fmt(100 * target, 3)} %)</p>`
      : html`<ul class="adaptive-params">${params.length === 0 && html`<li class="muted">no fit yet</li>`}${params.map((p) => html`<li data-testid="adaptive-param" data-name=${p.name}
          data-rel=${p.rel === null ? '' : String(p.rel)} class=${p.reached ? 'reached' : ''}>${p.text}${p.reached ? ' ✓' : ''}</li>`)}</ul>`}
    <${UncertaintyPlot} track=${track} mode=${mode} target=${target} />
    <p class="muted">${mode === 'curve' ? 'Estimated error' : 'u/|value| of each parameter'} against the points used, as the scan went while this page was open (log scale; the dashed line is the target).
      On the β plot: a tick per candidate θr, a dot per reading of each measured one, the order it was first chosen in, the latest ringed.</p>
    <${Picks} points=${points} />
  </div>`;
}
