"""
The direction learned from presses of known direction: a correction of the shift, and its gate.

The default shift method (``taxel_fit``) errs on a skin by an amount that is, in good part, a
function of cheap figures of each contact: where its imprints sit on the taxel grid (the
sub-taxel phase of the top imprint and of the bottom one, which is the top one moved by the
shift: each is placed with a bias that follows its phase, and the shift errs by the difference)
and how hard the press is. The bottom imprint is where the raw shift puts it, the layers'
misalignment included, so the correction also takes out the part of the zero that changes from
spot to spot; an offset taken where the skin is used after it (the paper's protocol) is taken
with the correction in force. A robot or an instrumented probe that
presses at known azimuths gives that function's samples: for each press the calibrated shift
the estimator measured and the press's true azimuth.

:func:`learn_direction` fits a linear map (ridge regression) from the features
(:func:`features`, in skin_kernel.h's order of ``sk_direction``) to a correction of the shift
that turns it onto the true azimuth (only the part across the azimuth is known), and keeps
it only when it lowers the mean azimuth error on presses it did not learn from: k-fold
cross-validation over the presses, the ridge chosen on the same folds, and a margin and a
standard error of the per-press gains asked of the gain for that choice. The result says
what it gained (the held-out folds' mean error before and after, degrees) and, whether kept or
not, is what the calibration file stores. The kernel applies a kept correction per contact
(skin_kernel/src/direction.c); fitting it is not a per-scan step, so it is here.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Sequence

import numpy as np

from ..scan.kernel import DIRECTION_FEATURES, direction_features

__all__ = ['KnownPress', 'DirectionCorrection', 'features', 'learn_direction',
           'MIN_DIRECTION_PRESSES', 'FOLDS', 'RIDGES', 'MARGIN']

MIN_DIRECTION_PRESSES = 10
FOLDS = 5
# Ridges tried (on features of order 1 and a sum of squares over the presses): the best on the
# held-out folds is taken.
RIDGES = (0.3, 1.0, 3.0, 10.0, 30.0)
# The share of the held-out error a correction must take off to be kept: the ridge is chosen on
# the same folds, which flatters the chosen one a little.
MARGIN = 0.03
# Standard errors of the per-press gain that the held-out gain must reach.
SIGNIFICANCE = 1.0
# A press whose measured azimuth is this far from its known one slipped, or its azimuth was not
# the one given: it is left out rather than bend the map for the others.
OUTLIER_DEG = 30.0
# The fit's reweightings by the corrected shifts' lengths, and the least length taken (taxels).
REWEIGHTS = 4
_SHORTEST = 0.05


@dataclass(frozen=True)
class KnownPress:
    """
    One press of known azimuth as the estimator saw it, the correction not applied.

    ``col``, ``row``: the contact's place (taxels); ``shift``: its calibrated shift (taxels);
    ``force_n``: its normal force as read; ``azimuth_rad``: the press's true azimuth; ``raw``:
    its raw shift (taxels, the offset not taken off; None: ``shift``).
    """

    col: float
    row: float
    shift: tuple
    force_n: float
    azimuth_rad: float
    raw: tuple = None


def features(col, row, dx, dy, force_n, force_ref_n: float) -> np.ndarray:
    """
    Return the correction's features of contacts (N x DIRECTION_FEATURES), the kernel's own.

    Arguments are arrays (or numbers) of the contacts' places and raw shifts (taxels: where the
    bottom imprint is from the top one) and normal forces; the kernel computes them
    (``sk_direction_features``, skin_kernel.h's order of ``sk_direction``), so that the map is
    fitted on the very features a scan applies it to.
    """
    return direction_features(col, row, dx, dy, force_n, force_ref_n)


@dataclass(frozen=True)
class DirectionCorrection:
    """
    A learned correction and what it gained on held-out presses.

    ``kept`` is whether it is applied: only when ``after_deg`` (the held-out folds' mean azimuth
    error with it) is below ``before_deg`` (without it) by the margin. ``weight_x``,
    ``weight_y`` are the map's weights per feature (taxels), ``force_ref_n`` the force the
    force feature is taken relative to, ``presses`` and ``folds`` what it learned from and how
    it was checked, ``ridge`` the ridge chosen, ``left_out`` the presses left out as outliers
    (their measured azimuth more than OUTLIER_DEG from the known one). ``rendered`` is how
    many presses rendered from the skin's taxel model the map was fitted to (0: it was fitted
    to the presses themselves); such a map's held-out error is its error on every press.
    """

    kept: bool
    force_ref_n: float
    weight_x: tuple
    weight_y: tuple
    presses: int
    folds: int
    before_deg: float
    after_deg: float
    ridge: float = 0.0
    left_out: int = 0
    rendered: int = 0

    def __post_init__(self):
        """Reject weights of the wrong length, non-finite numbers and a force that is not > 0."""
        for name in ('weight_x', 'weight_y'):
            values = tuple(float(v) for v in getattr(self, name))
            if len(values) != DIRECTION_FEATURES or not all(map(math.isfinite, values)):
                raise ValueError(f'{name} must be {DIRECTION_FEATURES} finite numbers')
            object.__setattr__(self, name, values)
        if not (math.isfinite(self.force_ref_n) and self.force_ref_n > 0):
            raise ValueError(f'force_ref_n must be a positive force, got {self.force_ref_n!r}')
        for name in ('before_deg', 'after_deg', 'ridge'):
            if not math.isfinite(float(getattr(self, name))):
                raise ValueError(f'{name} must be a finite number')
        object.__setattr__(self, 'kept', bool(self.kept))

    def describe(self) -> str:
        """Return one line: kept or not, and the held-out error before and after (degrees)."""
        verdict = 'applied' if self.kept else 'not applied (no gain on held-out presses)'
        left = (f'; {self.left_out} press{"es" if self.left_out > 1 else ""} left out (measured '
                f'more than {OUTLIER_DEG:.0f} deg from the known azimuth)' if self.left_out
                else '')
        source = (f'direction correction from {self.rendered} presses rendered from the '
                  f"skin's taxel model, judged on {self.presses} presses {verdict}: azimuth "
                  f'error {self.before_deg:.2f} -> {self.after_deg:.2f} deg' if self.rendered
                  else f'direction correction from {self.presses} presses {verdict}: held-out '
                  f'azimuth error {self.before_deg:.2f} -> {self.after_deg:.2f} deg '
                  f'({self.folds}-fold)')
        return source + left

    def predict(self, shift: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Return the corrected shifts (N x 2, taxels) of shifts and their features ``x``."""
        return shift + x @ np.stack((self.weight_x, self.weight_y), axis=1)

    def to_dict(self) -> dict:
        """Return the fields as plain Python values."""
        return {'kept': self.kept, 'force_ref_n': float(self.force_ref_n),
                'weight_x': list(self.weight_x), 'weight_y': list(self.weight_y),
                'presses': int(self.presses), 'folds': int(self.folds),
                'before_deg': float(self.before_deg), 'after_deg': float(self.after_deg),
                'ridge': float(self.ridge), 'left_out': int(self.left_out),
                'rendered': int(self.rendered)}

    @classmethod
    def from_dict(cls, doc) -> 'DirectionCorrection':
        """Return the correction of a :meth:`to_dict` mapping (ValueError when malformed)."""
        if not isinstance(doc, dict):
            raise ValueError('direction must be a mapping')
        return cls(kept=bool(doc['kept']), force_ref_n=float(doc['force_ref_n']),
                   weight_x=tuple(doc['weight_x']), weight_y=tuple(doc['weight_y']),
                   presses=int(doc['presses']), folds=int(doc['folds']),
                   before_deg=float(doc['before_deg']), after_deg=float(doc['after_deg']),
                   ridge=float(doc.get('ridge', 0.0)), left_out=int(doc.get('left_out', 0)),
                   rendered=int(doc.get('rendered', 0)))


def _angle_errors_deg(shift: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    turned = np.arctan2(shift[:, 1], shift[:, 0]) - azimuth
    return np.degrees(np.abs((turned + math.pi) % (2.0 * math.pi) - math.pi))


def _ridge(x: np.ndarray, shift: np.ndarray, azimuth: np.ndarray, ridge: float) -> np.ndarray:
    """
    Return the weights (features x 2) that turn the shifts closest to their true azimuths.

    Each press's residual is the corrected shift's part across its true azimuth over the
    corrected shift's length: the sine of its azimuth error. What is along the azimuth is left
    free, since a press of known direction does not say how long its shift should be; over the
    length of the correction before (reweighted, REWEIGHTS times) it is linear in the weights,
    and a correction gains nothing by shortening the shifts (no feature is the shift itself, so
    none can shorten them all). Ridge on every weight.
    """
    across = np.stack((-np.sin(azimuth), np.cos(azimuth)), axis=1)
    m = x.shape[1]
    weights = np.zeros((m, 2))
    for _ in range(REWEIGHTS):
        corrected = shift + x @ weights
        scale = 1.0 / np.maximum(np.hypot(corrected[:, 0], corrected[:, 1]), _SHORTEST)
        design = np.concatenate((x * across[:, :1], x * across[:, 1:]), axis=1) * scale[:, None]
        wanted = -np.sum(across * shift, axis=1) * scale
        a = design.T @ design + float(ridge) * np.eye(2 * m)
        flat = np.linalg.lstsq(a, design.T @ wanted, rcond=None)[0]
        weights = np.stack((flat[:m], flat[m:]), axis=1)
    return weights


def _usable(presses: Sequence[KnownPress]) -> tuple:
    """Return (presses with a measured shift within OUTLIER_DEG of their azimuth, measured)."""
    measured = [p for p in presses
                if all(map(math.isfinite, (p.col, p.row, *p.shift, p.force_n, p.azimuth_rad)))
                and math.hypot(*p.shift) > 0]
    kept = [p for p in measured if _angle_errors_deg(np.array([p.shift]),
                                                     np.array([p.azimuth_rad]))[0]
            <= OUTLIER_DEG]
    return kept, len(measured)


def _arrays(presses: Sequence[KnownPress], force_ref: float) -> tuple:
    """Return (features, calibrated shifts, azimuths) of presses."""
    shift = np.array([p.shift for p in presses], dtype=float)
    azimuth = np.array([p.azimuth_rad for p in presses], dtype=float)
    force = np.array([p.force_n for p in presses], dtype=float)
    raw = np.array([p.shift if p.raw is None else p.raw for p in presses], dtype=float)
    x = features([p.col for p in presses], [p.row for p in presses], raw[:, 0], raw[:, 1],
                 force, force_ref)
    return x, shift, azimuth


def _cross_validated(x: np.ndarray, shift: np.ndarray, azimuth: np.ndarray, folds: int,
                     ridges: Sequence[float], seed: int) -> tuple:
    """
    Return (held-out mean error, its ridge, the per-press held-out errors) of the best ridge.

    The presses are dealt at random (``seed``) into ``folds`` folds; for each ridge each fold is
    predicted by the map fitted to the others.
    """
    n = len(shift)
    fold = np.random.default_rng(seed).permutation(n) % folds
    best = (math.inf, ridges[0], None)
    for ridge in ridges:
        predicted = np.empty_like(shift)
        for k in range(folds):
            learn, held = fold != k, fold == k
            weights = _ridge(x[learn], shift[learn], azimuth[learn], ridge)
            predicted[held] = shift[held] + x[held] @ weights
        held_out = _angle_errors_deg(predicted, azimuth)
        best = min(best, (float(held_out.mean()), ridge, held_out), key=lambda b: b[0])
    return best


def learn_direction(presses: Sequence[KnownPress], folds: int = FOLDS,
                    ridges: Sequence[float] = RIDGES, margin: float = MARGIN,
                    seed: int = 0, rendered: Sequence[KnownPress] = ()) -> DirectionCorrection:
    """
    Return the correction learned from ``presses``, kept only when it gains on held-out ones.

    The presses are dealt at random (``seed``) into ``folds`` folds; for each ridge each fold is
    predicted by the map fitted to the others, and the ridge whose held-out mean azimuth error
    is least is taken, and the map is kept when its held-out gain reaches the margin and
    SIGNIFICANCE standard errors of the per-press gains. The final map is fitted to every
    press. Presses without a measured shift are dropped and those measured more than
    OUTLIER_DEG off their azimuth left out (counted). Raises ValueError with fewer than
    MIN_DIRECTION_PRESSES presses left.

    ``rendered`` (:mod:`.rendered`: presses rendered from the skin's taxel model) gives one more
    candidate: the map fitted to them alone, its ridge chosen by the same cross-validation over
    the renders, judged on every press (none of which it learned from or chose by). The
    candidate with the least held-out error is the one the margin and the significance then
    judge.
    """
    presses, measured = _usable(presses)
    n = len(presses)
    if n < MIN_DIRECTION_PRESSES:
        raise ValueError(f'{n} presses with a measured shift; learning the direction needs at '
                         f'least {MIN_DIRECTION_PRESSES}')
    folds = int(min(max(folds, 2), n))
    force = np.median([p.force_n for p in presses])
    force_ref = float(force) if force > 0 else 1.0
    x, shift, azimuth = _arrays(presses, force_ref)
    errors = _angle_errors_deg(shift, azimuth)
    before = float(errors.mean())
    after, ridge, held_out = _cross_validated(x, shift, azimuth, folds, ridges, seed)
    weights = None
    renders, _ = _usable(rendered)
    if len(renders) >= MIN_DIRECTION_PRESSES:
        # The renders' ridge is chosen on the renders: the presses judge one map, and a choice
        # among several on the presses that judge it would flatter the one chosen.
        xr, shift_r, azimuth_r = _arrays(renders, force_ref)
        _, r, _ = _cross_validated(xr, shift_r, azimuth_r, folds, ridges, seed)
        fitted = _ridge(xr, shift_r, azimuth_r, r)
        judged = _angle_errors_deg(shift + x @ fitted, azimuth)
        if judged.mean() < after:
            after, ridge, held_out, weights = float(judged.mean()), r, judged, fitted
    # The gain must stand out of the presses' own scatter (SIGNIFICANCE standard errors of the
    # per-press gain) as well as reach the margin: a few dozen presses gain by chance.
    gains = errors - held_out
    spread = float(gains.std(ddof=1)) / math.sqrt(n)
    kept = after < before * (1.0 - margin) and before - after > SIGNIFICANCE * spread
    from_renders = weights is not None
    if not from_renders:
        weights = _ridge(x, shift, azimuth, ridge)
    return DirectionCorrection(kept=kept, force_ref_n=force_ref,
                               weight_x=tuple(weights[:, 0]), weight_y=tuple(weights[:, 1]),
                               presses=n, folds=folds, before_deg=before, after_deg=after,
                               ridge=float(ridge), left_out=measured - n,
                               rendered=len(renders) if from_renders else 0)
