"""
What a skin's baselines have done since its tare, for the diagnostics: offsets, drift, a warning.

With no tare yet, the drift is the one followed since the start from the assumed baseline, and
is named so ("drift since the start (no tare yet)"), never "since the tare".

The creep correction in force, the tare's offsets (each layer's mean and range of unloaded
counts) and the drift the scans' baseline tracking followed since (:mod:`kernel`'s ``drift``,
each layer's mean and largest). A touched taxel's baseline follows only its layer's mean
drift; where one taxel has drifted from that mean by more than the touch threshold, a press
there reads wrong by as much, and no correction covers it: then the warning says to tare the
unloaded skin again.
"""

from __future__ import annotations

import numpy as np

__all__ = ['drift_status']


def drift_status(estimator) -> tuple:
    """Return (diagnostic values, warning or '') of ``estimator``'s tare and tracked drift."""
    creep = estimator.calibration.creep
    config = estimator.config
    values = {'creep correction': (
        f'calibrated: {creep.describe()}' if creep is not None else
        f'default: {100 * config.creep_per_decade:.2f} % per decade, settles in '
        f'{config.creep_settle_s:g} s')}
    conditioning = estimator.conditioning
    if not conditioning.tared:
        values['tare'] = 'no tare yet (the assumed baseline)'
    if conditioning.shape is None:
        return values, ''
    # Without a tare the baselines were followed from the assumed one since the start.
    since = 'the tare' if conditioning.tared else 'the start (no tare yet)'
    baseline = conditioning.state(conditioning.shape).baseline
    (mean, largest) = estimator.drift()
    for i, layer in enumerate(('top', 'bottom')):
        if conditioning.tared:
            b = baseline[i]
            values[f'tare offset, {layer} [counts]'] = (
                f'{float(np.mean(b)):.1f} (min {float(np.min(b)):.0f}, '
                f'max {float(np.max(b)):.0f})')
        values[f'drift since {since}, {layer} [counts]'] = (
            f'{mean[i]:+.1f} mean, {largest[i]:.1f} largest')
    threshold = estimator.config.threshold_counts
    apart = max(largest[i] - abs(mean[i]) for i in range(2))
    warning = ''
    if apart > threshold:
        warning = (f'a taxel drifted {apart:.0f} counts from its layer since {since}, more '
                   f'than the touch threshold ({threshold:.0f}): a press there reads it; tare '
                   'the unloaded skin')
    return values, warning
