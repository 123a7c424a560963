"""
`make bench` section 9: a skin over hours (issue #36), drift and creep, and what they cost.

The figures come from :mod:`skin_lab.evaluate.drift` (the evaluator's ``--scene hold``
and ``--scene idle``) on every skin asked for; the cost is ``ContactEstimator.process`` of the
same 16 x 16 frames (a press held, the skin drifting) without a time and with one (baselines
followed, creep corrected), the two interleaved in a fresh order on every frame.
"""

from __future__ import annotations

import time

import numpy as np

from skin_driver.core.estimation.scan.pipeline import ContactEstimator
from skin_driver.core.sim.hold import hold_scene
from skin_driver.core.sim.skins import family_skin
from skin_lab.evaluate.drift import drift_report, format_drift

__all__ = ['drift_bench', 'drift_targets', 'drift_section', 'COST_LIMIT_US', 'FORCE_LIMIT',
           'REPRESS_LIMIT']

COST_LIMIT_US = 2.0
FORCE_LIMIT = 0.03
REPRESS_LIMIT = 0.03


def time_cost(repeats: int, seed: int = 0) -> dict:
    """Return the cost of a scan without and with its time, side by side (module doc)."""
    scene = hold_scene(family_skin('default'), seed=seed, hold_s=600.0, step_s=5.0)
    frames = [f for f in scene.frames if f.label or f.time_s > 0]
    plain, timed = (ContactEstimator().with_tare(scene.tare_top, scene.tare_bottom)
                    for _ in range(2))
    rng = np.random.default_rng(seed)
    costs = {'without': [], 'with': []}
    clock = 0.0
    for _ in range(repeats):
        for f in frames:
            clock += 0.001
            for which in rng.permutation(['without', 'with']):
                start = time.perf_counter()
                if which == 'with':
                    timed.process(f.top, f.bottom, clock)
                else:
                    plain.process(f.top, f.bottom)
                costs[which].append(time.perf_counter() - start)
    out = {k: 1e6 * float(np.median(v)) for k, v in costs.items()}
    out['added_us'] = out['with'] - out['without']
    out['scans'] = len(costs['with'])
    return out


def drift_bench(skins, hours: float, step_s: float, cost_repeats: int, seed: int = 0,
                log=None) -> dict:
    """Return the drift report of ``skins`` and the cost of a scan's time."""
    res = drift_report(skins, seed, hours, step_s, log=log)
    res['cost'] = time_cost(cost_repeats, seed)
    return res


def _worst(holds, mode, key):
    """Return (largest |value|, skin) of a mode's figure over the skins, None when absent."""
    values = [(abs(h[mode][key]), h['skin']) for h in holds
              if mode in h and np.isfinite(h[mode][key])]
    return max(values) if values else (None, '')


def drift_targets(res) -> list:
    """Return the issue's targets as (name, measured, limit, met, note, format) tuples."""
    holds, idles = res['holds'], res['idles']
    out = []
    phantoms = max(i['tracking']['phantoms'] for i in idles)
    off = max(i['off']['phantoms'] for i in idles)
    out.append((f'phantom contacts over {res["hours"]:g} h unloaded, baselines followed',
                phantoms, '0', phantoms == 0, f'{off} on the worst skin with the tare alone',
                'd'))
    for key, limit, what in (('force_60min', FORCE_LIMIT,
                              'force (magnitude) after 60 min against 1 s'),
                             ('force_repress', REPRESS_LIMIT,
                              're-press after an hour held, against the first')):
        worst, skin = _worst(holds, 'calibrated', key)
        raw, raw_skin = _worst(holds, 'tracking', key)
        default, default_skin = _worst(holds, 'default', key)
        note = (f'worst on {skin}; uncorrected {100 * (raw or 0):.1f} % ({raw_skin}), with the '
                f'default creep {100 * (default or 0):.1f} % ({default_skin})')
        if worst is not None and worst > limit:
            note += f'; {100 * (worst - limit):.1f} points over'
        out.append((f'{what}, creep calibrated (%)', None if worst is None else 100 * worst,
                    f'<= {100 * limit:g} %', worst is not None and worst <= limit, note, '.1f'))
    turn, skin = _worst(holds, 'calibrated', 'azimuth_deg')
    alone = next((h['off']['azimuth_deg'] for h in holds if h['skin'] == skin), None)
    note = f'worst on {skin}'
    if alone is not None:
        note += f'; {abs(alone):.2f} deg with the tare alone there'
    if turn is not None and turn >= 1.0:
        note += f'; {turn - 1.0:.2f} deg over'
    out.append(('azimuth change over an hour held, creep calibrated (deg)', turn, '< 1 deg',
                turn is not None and turn < 1.0, note, '.2f'))
    cost = res['cost']['added_us']
    out.append(("cost of a scan's time at 16x16 (followed baselines, creep), side by side",
                cost, f'<= {COST_LIMIT_US:g} us', cost <= COST_LIMIT_US,
                f'{res["cost"]["without"]:.1f} us without, {res["cost"]["with"]:.1f} us with',
                '.2f'))
    return out


def drift_section(res) -> list:
    """Return section 9 of the report as Markdown lines."""
    cost = res['cost']
    skins = ', '.join(h['skin'] for h in res['holds'])
    out = ['## 9. Hours: drift and creep (issue #36)', '',
           f"Skins: {skins}. A tilted press at each skin's paper force held an hour, released "
           'for two minutes and pressed again; |F| after 1, 10 and 60 minutes and at the '
           're-press as its change from 1 s into the first press (%), the change of azimuth and '
           'location over the hour, each skin calibrated first as its user would (gains, force '
           'curves, offset, compliance). Modes: `off` scans without a time (the tare believed '
           'forever), `tracking` baselines followed but no creep corrected, `default` the '
           "estimator's default creep (the family's middle), `calibrated` the creep a creep "
           'calibration fitted on a hold of its own (three minutes held, one off, two seconds '
           'back). Simulated hours are rendered at the frames scored (docs/drift.md).', '']
    out += format_drift(res).split('\n')
    out += ['', f'Cost of the time on the same 16 x 16 frames, interleaved ({cost["scans"]} '
            f'scans each): {cost["without"]:.1f} us a scan without it, {cost["with"]:.1f} us '
            f'with it: {cost["added_us"]:+.2f} us.', '']
    fits = [(h['skin'], h['creep_fit'], h['calibration_error']) for h in res['holds']]
    out += ['Creep calibration: ' + '; '.join(
        f'{skin} {100 * fit["per_decade"]:.2f} %/decade, settles {fit["settle_s"]:.1f} s, '
        f'recovers {fit["recovery_s"]:.0f} s'
        if fit else f'{skin}: {error}' for skin, fit, error in fits) + '.', '']
    return out
