"""
The benchmark's timings of an estimator: one call, side by side with others, back to back.

Every timing is ``ContactEstimator.process`` in this process (contacts included), on the core
the caller pinned it to (the benchmark pins one).
"""

from __future__ import annotations

import time

import numpy as np

__all__ = ['timed', 'interleaved_cost', 'back_to_back_us', 'alone_costs', 'ALONE_REPEATS']


def timed(est, top, bottom) -> tuple:
    """Return (seconds, contacts) of one ``est.process`` call, contacts included."""
    start = time.perf_counter()
    contacts = est.process(top, bottom)
    return time.perf_counter() - start, contacts


def interleaved_cost(ests, frames, rng, repeats) -> dict:
    """Return each estimator's cost on ``frames``, the estimators in a fresh order per frame."""
    costs = {m: [] for m in ests}
    for est in ests.values():
        est.process(*frames[0])
    for _ in range(repeats):
        for top, bottom in frames:
            for m in rng.permutation(list(ests)):
                costs[m].append(timed(ests[m], top, bottom)[0])
    return {m: {'median_us': 1e6 * float(np.median(c)), 'mean_us': 1e6 * float(np.mean(c)),
                'p90_us': 1e6 * float(np.percentile(c, 90))} for m, c in costs.items()}


def back_to_back_us(est, frames, repeats) -> float:
    """Return the median cost of ``est`` on ``frames`` run one after another, nothing between."""
    costs = [timed(est, top, bottom)[0] for _ in range(repeats) for top, bottom in frames]
    return 1e6 * float(np.median(costs))


# How many times the default goes over a skin's scored frames back to back (issue #16.5's cost).
ALONE_REPEATS = 3


def alone_costs(scenes, repeats: int = ALONE_REPEATS) -> dict:
    """
    Return the default's cost on one skin's scored frames run back to back, as a driver runs it.

    ``scenes`` holds (scene, estimator, frames as (top, bottom) pairs); each scene's frames go
    one after another with nothing between, ``repeats`` times, contacts included. Over all the
    frames and per scene: the median and 90th percentile cost, and per scene the mean number of
    contacts reported and the median cost per contact (frames with one or more). Interleaved
    with the other estimators the compiled call finds its caches cold (the family's
    ``median_us``).
    """
    every, per_scene = [], {}
    for kind, est, frames in scenes:
        est.process(*frames[0])
        times, found = [], []
        for _ in range(repeats):
            for top, bottom in frames:
                elapsed, contacts = timed(est, top, bottom)
                times.append(elapsed)
                found.append(len(contacts))
        every += times
        per_contact = [t / k for t, k in zip(times, found) if k]
        per_scene[kind] = {'median_us': 1e6 * float(np.median(times)),
                           'contacts': float(np.mean(found)),
                           'per_contact_us': (1e6 * float(np.median(per_contact))
                                              if per_contact else None)}
    return {'median_us': 1e6 * float(np.median(every)),
            'p90_us': 1e6 * float(np.percentile(every, 90)), 'frames': len(every) // repeats,
            'repeats': repeats, 'scenes': per_scene}
