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
    one after another with nothing between, contacts included, in ``repeats`` passes that go
    round the scenes in turn. A frame's cost is the least of its passes: the machine's other
    jobs only ever add to a call, and a burst of them then spoils one pass of every scene
    rather than every pass of one. Over all the frames and per scene: the median and 90th
    percentile cost, and per scene the mean number of contacts reported and the median cost
    per contact (frames with one or more). Interleaved with the other estimators the compiled
    call finds its caches cold (the family's ``median_us``).
    """
    least = [np.full(len(frames), np.inf) for _, _, frames in scenes]
    found = [np.zeros(len(frames), dtype=int) for _, _, frames in scenes]
    for _ in range(repeats):
        for (kind, est, frames), times, counts in zip(scenes, least, found):
            est.process(*frames[0])
            for i, (top, bottom) in enumerate(frames):
                elapsed, contacts = timed(est, top, bottom)
                times[i] = min(times[i], elapsed)
                counts[i] = len(contacts)
    per_scene = {}
    for (kind, _, _), times, counts in zip(scenes, least, found):
        loaded = counts > 0
        per_contact = times[loaded] / counts[loaded]
        per_scene[kind] = {'median_us': 1e6 * float(np.median(times)),
                           'contacts': float(np.mean(counts)),
                           'per_contact_us': (1e6 * float(np.median(per_contact))
                                              if loaded.any() else None)}
    every = np.concatenate(least)
    return {'median_us': 1e6 * float(np.median(every)),
            'p90_us': 1e6 * float(np.percentile(every, 90)), 'frames': int(every.size),
            'repeats': repeats, 'scenes': per_scene}
