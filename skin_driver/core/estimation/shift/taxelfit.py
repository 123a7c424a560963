"""
Shift by a forward model of the taxels: a continuous profile integrated over each taxel cell.

Where the information is lost: a taxel reports the load integrated over its cell, so the
centroid of a sampled imprint 2-3 taxels wide is pulled towards the nearest taxel centre by an
amount that depends on where the imprint sits within the taxel (sampling bias, "pixel
locking"), and the FSR's compressive curve, applied after the integration, distorts the cell
sums further. The sharp top imprint is hit hardest, so the shift inherits its bias as an offset
that follows the press's sub-taxel position, not noise.

What this estimator does instead, on maps already linearised by the layer's force curve (the
pipeline passes force maps to methods marked ``linear``; a layer flat at its peak, where the
force curve ends, is fitted on its counts instead):

* each layer's marginal profile along each axis (the window summed over the other axis) is
  modelled as a Gaussian of free centre, width and mass *integrated over unit taxel cells*,
  ``m_i = M * (Phi((i + 1/2 - mu) / s) - Phi((i - 1/2 - mu) / s))``, and fitted by
  Gauss-Newton from the centroid and the second moment;
* the shift is the difference of the fitted bottom and top centres.

A profile cut by the map's edge keeps the width of the same layer's whole profile along the
other axis, and its centre may lie past the edge (:func:`_cut_by_edge`).

A layer with saturated taxels (at its force curve's ceiling or cut by the ADC: ``censored``)
loses its shape in the marginal sums: a saturated taxel reads the ceiling's force whatever it
carries, and the sums mix it with the rim. Such a layer is fitted in 2-D instead
(:func:`fit_censored_layer`): a Gaussian integrated over the cells along both axes whose
saturated taxels are lower bounds, so the rim places the imprint. The bottom imprint, blurred,
has rim enough (``_MIN_FREE`` taxels) to fit its mass too. The sharp top imprint has not: a fit
of its mass trades it against width and centre (a thousandfold mass in one saturated taxel), so
it takes the bottom layer's mass, the same load seen through the layer (docs/estimation.md).
An imprint cut by the map's edge is fitted on the cells the map has, its centre free to lie
past the edge.

A profile cut by the map's edge places its centre by the shape of the part the map holds, so
the centre follows the width it was fitted with: the further past the edge, the more. Its
uncertainty (:func:`_cut_variance`) is that dependence, the centre's derivative by the width
along the fit's valley (the mass refitted), times the width's own uncertainty
(``_CUT_WIDTH_SHARE`` of it): nil for a profile cut at its tail, large for one whose centre
lies past the edge.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ['fit_cell_profiles', 'fit_censored_layer', 'cell_fit_shift']

_ITERATIONS = 8
# Centre steps below this (taxels) end the fit: a hundredth of the noise floor's shift error.
_TOLERANCE = 1e-4
_MIN_WIDTH = 0.25
_MIN_EXPLAINED = 0.5
# Profiles at least this wide (taxels, from the second moment) keep their centroid.
_WIDE = 1.5
# How far past the map's edge a cut profile's centre may lie, in its widths: two leave 2 % of
# the imprint on the map, and less is too little to place it (a fit would trade centre for mass).
_PAST_EDGE = 2.0
# Taxels within this share of a layer's peak force sit on one plateau: the curve's cap.
_PLATEAU = 1e-9
_INV_SQRT2PI = 1.0 / math.sqrt(2.0 * math.pi)
# A censored layer is fitted in 2-D with at least this many loaded taxels below its ceiling: five
# parameters, and the noise, need that many (with fewer the width trades against the centre).
_MIN_FREE = 8
_ITERATIONS_2D = 30
# Halvings of a 2-D step that raises the misfit before the fit stops where it is; steps that
# move the centre less than _SEARCHED (taxels) are taken whole.
_HALVINGS = 12
_SEARCHED = 1e-5
_DECREASE = 1e-12
# A censored taxel this close to its reading (share of it) holds a kinked optimum's bound.
_PINNED = 1e-3
# The 2-D fit runs until its centre steps fall below this (taxels): a ten-thousandth of the noise
# floor's shift error. Its last steps shrink about tenfold each, so every tenfold further costs
# one more step (1e-10 cost the saturating skin's frames a sixth more time, for nothing).
_TOLERANCE_2D = 1e-6
# A film that turns on at a pressure steps to a few kOhm: a rim taxel conducting over any part
# of its cell reads at least the step's counts, whatever its load (docs/estimation.md). Such
# taxels sit on one floor: at least _STEP_TAXELS loaded taxels within _STEP_SPREAD (share of it)
# of the layer's lowest reading, no more than half its loaded taxels (an imprint's rim, not a
# narrow imprint's every taxel), the floor above _STEP_HEIGHT of the peak (a rim fading into
# the noise sits near the touch threshold, far below it).
_STEP_TAXELS = 3
_STEP_SPREAD = 0.05
_STEP_HEIGHT = 0.2
# How far a cut profile's width may be off, a share of it: the width taken from the other axis
# is that of the imprint's part on the map, and an imprint is no Gaussian (docs/estimation.md).
_CUT_WIDTH_SHARE = 0.4
# Abramowitz and Stegun 7.1.26: erf to 1.5e-7, far below the counts' noise.
_AS_P = 0.3275911
_AS = (0.254829592, -0.284496736, 1.421413741, -1.453152027, 1.061405429)


def _normal_cdf(u: np.ndarray, gauss: np.ndarray = None) -> np.ndarray:
    """
    Return the standard normal CDF of ``u`` (numpy has no erf).

    ``gauss``: exp(-u^2 / 2), when the caller has it for the density already.
    """
    x = np.abs(u) * (1.0 / math.sqrt(2.0))
    t = 1.0 / (1.0 + _AS_P * x)
    poly = t * (_AS[0] + t * (_AS[1] + t * (_AS[2] + t * (_AS[3] + t * _AS[4]))))
    half = 0.5 * poly * (np.exp(-x * x) if gauss is None else gauss)
    return np.where(u >= 0, 1.0 - half, half)


def fit_cell_profiles(profiles: np.ndarray, mask: np.ndarray, cut: tuple = None) -> tuple:
    """
    Fit cell-integrated Gaussians to K marginal profiles (K x n; ``mask`` marks real cells).

    Returns (centres, widths, explained share of each profile's energy), cell units, centre 0 at
    the first cell's middle. A profile with no load gives NaN. ``cut``: (widths, centres, low,
    high), K each, for profiles cut by the map's edge: a finite width is held fixed (the centre
    and mass are fitted, from the given centre, within ``low``..``high``).
    """
    idx = np.arange(profiles.shape[1], dtype=np.float64)[None, :]
    # Cell i spans edges i and i + 1: one CDF per edge gives every cell's share.
    edges = np.arange(profiles.shape[1] + 1, dtype=np.float64)[None, :] - 0.5
    mass = profiles.sum(axis=1)
    safe = np.where(mass > 0, mass, 1.0)
    mu = (profiles @ idx[0]) / safe
    var = (profiles @ (idx[0] ** 2)) / safe - mu * mu
    s = np.sqrt(np.maximum(var - 1.0 / 12.0, _MIN_WIDTH ** 2))
    amp = mass.copy()
    start, start_width = mu.copy(), s.copy()
    # The centre stays within the cells the profile has (its loaded span and half a cell).
    low, high = np.full(mu.shape, -0.5), mask.sum(axis=1) - 0.5
    free = np.ones(mu.shape)
    if cut is not None:
        fixed = np.isfinite(cut[0])
        s = np.where(fixed, cut[0], s)
        # A cut profile starts, and falls back, at the given centre, not at its centroid.
        start = np.where(fixed, cut[1], start)
        mu = start.copy()
        low, high = np.where(fixed, cut[2], low), np.where(fixed, cut[3], high)
        free = np.where(fixed, 0.0, 1.0)
    for _ in range(_ITERATIONS):
        u = (edges - mu[:, None]) / s[:, None]
        gauss = np.exp(-0.5 * u * u)
        pdf = gauss * _INV_SQRT2PI
        cells = np.diff(_normal_cdf(u, gauss), axis=1) * mask
        d_mu = -np.diff(pdf, axis=1) * mask / s[:, None]
        # A fixed width has no column: its normal equation is the regulariser's, its step 0.
        d_s = -np.diff(u * pdf, axis=1) * mask / s[:, None] * free[:, None]
        residual = profiles - amp[:, None] * cells
        jac = np.stack((cells, amp[:, None] * d_mu, amp[:, None] * d_s), axis=2)
        normal = np.einsum('kni,knj->kij', jac, jac) + 1e-12 * np.eye(3)
        rhs = np.einsum('kni,kn->ki', jac, residual)
        try:
            step = np.linalg.solve(normal, rhs[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            break
        # Damped: a step never moves the centre by more than a taxel nor the width by half.
        amp = amp + step[:, 0]
        mu = np.clip(mu + np.clip(step[:, 1], -1.0, 1.0), low, high)
        s = np.maximum(s + np.clip(step[:, 2], -0.5 * s, 0.5 * s), _MIN_WIDTH)
        if np.abs(step[:, 1]).max() < _TOLERANCE:
            break
    cells = np.diff(_normal_cdf((edges - mu[:, None]) / s[:, None]), axis=1) * mask
    residual = profiles - amp[:, None] * cells
    energy = (profiles * profiles).sum(axis=1)
    explained = 1.0 - (residual * residual).sum(axis=1) / np.where(energy > 0, energy, 1.0)
    # A fit that explains little of its profile (a shape far from any Gaussian, or a run-away
    # step) keeps the centroid it started from. So does a profile a taxel and a half wide: its
    # centroid's sampling bias, exp(-2 pi^2 s^2) / pi taxel, is nil, and the centroid takes
    # every cell as it is, where a Gaussian would misfit a flat or skewed imprint.
    keep = np.isfinite(mu) & (explained >= _MIN_EXPLAINED) & ((start_width < _WIDE) | (free == 0))
    mu = np.where(keep, mu, start)
    explained = np.where(np.isfinite(explained), explained, 0.0)
    bad = ~(mass > 0)
    mu = np.where(bad, np.nan, mu)
    return mu, s, np.where(bad, 0.0, np.maximum(explained, 0.0))


def _axis_cells(mu: float, s: float, n: int) -> tuple:
    """Return a unit Gaussian's share of each of ``n`` cells and its derivatives by mu and s."""
    u = (np.arange(n + 1, dtype=np.float64) - 0.5 - mu) / s
    gauss = np.exp(-0.5 * u * u)
    pdf = gauss * _INV_SQRT2PI
    return np.diff(_normal_cdf(u, gauss)), -np.diff(pdf) / s, -np.diff(u * pdf) / s


def _censored_cost(force: np.ndarray, free: np.ndarray, params: tuple) -> float:
    """Return the squared misfit of (mass, x, y, sx, sy): a censored taxel's only below it."""
    mass, mx, my, sx, sy = params
    h, w = force.shape
    residual = force - mass * np.outer(_axis_cells(my, sy, h)[0], _axis_cells(mx, sx, w)[0])
    residual = np.where(free, residual, np.maximum(residual, 0.0))
    return float((residual * residual).sum())


def _damped(params: tuple, step: np.ndarray, shape: tuple) -> tuple:
    """
    Return params moved by step: a taxel at most for a centre, half a width for a width.

    A centre may lie past the window's edge by ``_PAST_EDGE`` widths: where the window is the
    map's edge, the imprint's rim on the map still places it (:func:`_cut_by_edge`).
    """
    mass, mx, my, sx, sy = params
    h, w = shape
    reach_x, reach_y = _PAST_EDGE * sx, _PAST_EDGE * sy
    return (mass + float(step[0]),
            min(max(mx + min(max(float(step[1]), -1.0), 1.0), -0.5 - reach_x), w - 0.5 + reach_x),
            min(max(my + min(max(float(step[2]), -1.0), 1.0), -0.5 - reach_y), h - 0.5 + reach_y),
            max(sx + min(max(float(step[3]), -0.5 * sx), 0.5 * sx), _MIN_WIDTH),
            max(sy + min(max(float(step[4]), -0.5 * sy), 0.5 * sy), _MIN_WIDTH))


def _gauss_newton(force: np.ndarray, free: np.ndarray, params: tuple, fitted: float,
                  searched: bool) -> tuple:
    """
    Return (params, converged) of Gauss-Newton on :func:`_censored_cost` from ``params``.

    ``searched``: a step that moves a centre by ``_SEARCHED`` or more is halved until the misfit
    falls (the saturated taxels that count come and go, and a full step can overshoot), and the
    fit stops where none does. ``fitted`` 0 holds the mass.
    """
    h, w = force.shape
    cost = _censored_cost(force, free, params)
    for _ in range(_ITERATIONS_2D):
        mass, mx, my, sx, sy = params
        gx, dgx_mu, dgx_s = _axis_cells(mx, sx, w)
        gy, dgy_mu, dgy_s = _axis_cells(my, sy, h)
        model = mass * np.outer(gy, gx)
        active = free | (model < force)
        # A fixed mass has no column: its normal equation is the regulariser's, its step 0. So
        # has a width at its floor: else the centre's step counts on a width it cannot take.
        jac = np.stack((np.outer(gy, gx) * fitted, mass * np.outer(gy, dgx_mu),
                        mass * np.outer(dgy_mu, gx),
                        mass * np.outer(gy, dgx_s) * float(sx > _MIN_WIDTH),
                        mass * np.outer(dgy_s, gx) * float(sy > _MIN_WIDTH)), axis=2)[active]
        residual = (force - model)[active]
        try:
            step = np.linalg.solve(jac.T @ jac + 1e-12 * np.eye(5), jac.T @ residual)
        except np.linalg.LinAlgError:
            return params, False
        # The centre's move as taken: a bound (past the edge, a width's floor) may hold it.
        whole = _damped(params, step, (h, w))
        moves = max(abs(whole[1] - params[1]), abs(whole[2] - params[2]))
        if moves < _SEARCHED or not searched:
            # Near the optimum the misfit is flat to its rounding: Gauss-Newton steps as they are.
            params = whole
            if moves < _TOLERANCE_2D:
                return params, True
            cost = _censored_cost(force, free, params)
            continue
        for _ in range(_HALVINGS):
            trial = _damped(params, step, (h, w))
            trial_cost = _censored_cost(force, free, trial)
            # Lower by more than its rounding, so that no tie decides where the fit goes.
            if trial_cost < cost * (1.0 - _DECREASE):
                break
            step = 0.5 * step
        else:
            return params, False
        params, cost = trial, trial_cost
    return params, False


def fit_censored_layer(force: np.ndarray, censored: np.ndarray, centre: tuple, width: tuple,
                       mass: float = None):
    """
    Return (x, y, mass) of one layer's imprint, its saturated taxels lower bounds, or None.

    ``force``: the layer's (h, w) linearised window; ``censored``: its taxels whose reading is
    only a lower bound. The model is ``mass * gy[r] * gx[c]``, a Gaussian integrated over the
    cells along each axis, fitted by Gauss-Newton from ``centre`` and ``width`` (x, y: the
    marginal fits'); a censored taxel counts only while the model falls below its reading.
    A given ``mass`` is held fixed. Where the optimum sits on saturated taxels' bounds (kinks
    of the misfit, along which the steps only creep), the taxels within ``_PINNED`` of their
    reading are taken as readings and the fit polished from there. None when it does not
    settle: the taxels it leans on still come and go.
    """
    h, w = force.shape
    free = ~censored
    fitted = 1.0 if mass is None else 0.0
    if mass is None:
        base = np.outer(_axis_cells(centre[1], width[1], h)[0],
                        _axis_cells(centre[0], width[0], w)[0])
        weight = float(base[free] @ base[free])
        if not weight > 0:
            return None
        mass = float(force[free] @ base[free]) / weight
    start = (mass, centre[0], centre[1], width[0], width[1])
    params, converged = _gauss_newton(force, free, start, fitted, True)
    if not converged:
        model = params[0] * np.outer(_axis_cells(params[2], params[4], h)[0],
                                     _axis_cells(params[1], params[3], w)[0])
        pinned = censored & (np.abs(force - model) <= _PINNED * force)
        params, converged = _gauss_newton(force, free | pinned, params, fitted, False)
    mx, my = params[1], params[2]
    return (mx, my, params[0]) if converged and math.isfinite(mx) and math.isfinite(my) else None


def _fits_censored(force: np.ndarray, censored: np.ndarray, min_free: int) -> bool:
    """Return whether a layer's window calls for :func:`fit_censored_layer` (module docstring)."""
    return bool(censored.any()) and int(((force > 0) & ~censored).sum()) >= min_free


def _censored_centres(force: np.ndarray, censored: np.ndarray, mu: np.ndarray,
                      width: np.ndarray) -> None:
    """Refit the saturated layers of a (2, h, w) window in 2-D, in place on ``mu`` (docstring)."""
    # The bottom first: its mass, fitted or (unsaturated) summed, is the top's.
    mass = None if censored[1].any() else float(force[1].sum())
    for layer in (1, 0):
        given = mass if layer == 0 and mass is not None and mass > 0 else None
        if not _fits_censored(force[layer], censored[layer], _MIN_FREE if given is None else 0):
            continue
        found = fit_censored_layer(force[layer], censored[layer], (mu[layer], mu[2 + layer]),
                                   (width[layer], width[2 + layer]), given)
        if found is not None:
            mu[layer], mu[2 + layer], fitted = found
            mass = fitted if layer == 1 else mass


def _cut_by_edge(profiles: np.ndarray, mask: np.ndarray, mu: np.ndarray, width: np.ndarray):
    """
    Return the ``cut`` of :func:`fit_cell_profiles` for profiles cut by the map's edge, or None.

    A contact's window has an empty cell around its load except where the map ends, so a profile
    loaded in its first or last cell lost the rest of its imprint there: its width and centre
    trade against each other on the cells that are left (at the border the bottom imprint was
    0.3-0.7 taxel off, 1 sigma). The same layer's profile along the other axis is whole and
    gives the width (an imprint about as wide both ways); the centre is then fitted, and may lie
    past the edge (a press just off the map, a bottom imprint shifted out). Rows 0, 1 are the
    top and bottom along x, rows 2, 3 along y; a corner (both axes cut) is left as fitted.
    """
    length = mask.sum(axis=1).astype(int)
    first = profiles[:, 0] > 0
    last = profiles[np.arange(4), length - 1] > 0
    cut = first | last
    other = np.array([2, 3, 0, 1])
    fixed = cut & ~cut[other]
    if not fixed.any():
        return None
    reach = _PAST_EDGE * width[other]
    low = np.where(first, -0.5 - reach, -0.5)
    high = np.where(last, (length - 0.5) + reach, length - 0.5)
    return (np.where(fixed, width[other], np.nan), np.clip(mu, low, high), low, high)


def _cut_variance(profiles: np.ndarray, mask: np.ndarray, mu: np.ndarray,
                  width: np.ndarray) -> float:
    """
    Return the variance (taxels**2, one axis of the shift) of the centres cut by the map's edge.

    For each profile loaded in its first or last cell (cut, :func:`_cut_by_edge`), the centre's
    derivative by the width with the mass refitted, ``-(d_mu' d_s) / (d_mu' d_mu)`` in the
    metric that leaves out the mass's column (cells, d_mu, d_s: the profile's unit cells and
    their derivatives at the fitted centre and width), times ``_CUT_WIDTH_SHARE`` of the width.
    Half the sum of their squares: ``sigma`` stands for one axis of the shift (uncertainty.py).
    """
    length = mask.sum(axis=1).astype(int)
    cut = (profiles[:, 0] > 0) | (profiles[np.arange(4), length - 1] > 0)
    total = 0.0
    for j in np.flatnonzero(cut):
        cells, d_mu, d_s = _axis_cells(mu[j], width[j], length[j])
        n00 = float(cells @ cells) + 1e-12
        n01 = float(cells @ d_mu)
        n11 = float(d_mu @ d_mu) + 1e-12
        b0, b1 = float(cells @ d_s), float(d_mu @ d_s)
        sens = -(n00 * b1 - n01 * b0) / (n00 * n11 - n01 * n01)
        total += (_CUT_WIDTH_SHARE * width[j] * sens) ** 2
    return 0.5 * total


def _on_step(force: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """
    Return the force window with the taxels on a film's turn-on step at half their force.

    Such a taxel's load lies anywhere between nothing and the step's force (the constants'
    comment): the middle of that interval is its least biased value, where the step's force
    pulled the fitted centre towards the rim's side with most taxels on the step.
    """
    out = force
    for layer in range(2):
        c = counts[layer]
        loaded = c > 0
        n = int(loaded.sum())
        if n == 0:
            continue
        low = float(c[loaded].min())
        step = loaded & (c <= low * (1.0 + _STEP_SPREAD))
        k = int(step.sum())
        if k >= _STEP_TAXELS and 2 * k <= n and low > _STEP_HEIGHT * float(c.max()):
            out = out.copy() if out is force else out
            out[layer][step] *= 0.5
    return out


def _plateau(layer: np.ndarray) -> bool:
    """Return whether the layer's highest value is shared by several taxels (a clipped top)."""
    peak = layer.max()
    # Counts carry noise, so equal peak forces are the curve's cap (or, rarely, a tie: then the
    # layer is fitted on its counts, which costs a little accuracy and nothing else).
    return peak > 0 and int((layer >= peak * (1.0 - _PLATEAU)).sum()) >= 2


def cell_fit_shift(maps: np.ndarray, counts: np.ndarray = None, censored: np.ndarray = None):
    """
    Return (dx, dy, explained share, cut variance) of a (2, h, w) linearised window, or None.

    None without load. dx, dy: the bottom's fitted centres less the top's, taxels; the
    explained share (the worst of the four fits) serves as the confidence; the cut variance
    (taxels**2, :func:`_cut_variance`) is the uncertainty of the profiles cut by the map's edge,
    0 when none is. A layer whose linearised map is flat at
    its peak hit the end of the force curve: its force says nothing there, so that layer is
    fitted on its ``counts`` (same shape) when given. Each layer's centre is absolute, so the
    two layers need not be fitted on the same scale. ``censored`` (same shape, boolean) marks
    saturated taxels: a layer with enough rim below them is fitted in 2-D (module docstring).
    Taxels on a film's turn-on step count at half their force (:func:`_on_step`).
    """
    if counts is not None:
        maps = _on_step(maps, counts)
    force = maps
    if counts is not None:
        maps = np.stack([c if _plateau(m) else m for m, c in zip(maps, counts)])
    h, w = maps.shape[1:]
    n = max(h, w)
    profiles = np.zeros((4, n))
    mask = np.zeros((4, n))
    # Rows 0, 1: top and bottom along x (columns); rows 2, 3: along y (rows).
    profiles[:2, :w] = maps.sum(axis=1)
    profiles[2:, :h] = maps.sum(axis=2)
    mask[:2, :w] = 1.0
    mask[2:, :h] = 1.0
    mu, width, explained = fit_cell_profiles(profiles, mask)
    if not np.isfinite(mu).all():
        return None
    cut = _cut_by_edge(profiles, mask, mu, width)
    fitted_width = width
    if cut is not None:
        again, held, share = fit_cell_profiles(profiles, mask, cut)
        fixed = np.isfinite(cut[0])
        mu = np.where(fixed, again, mu)
        explained = np.where(fixed, share, explained)
        fitted_width = np.where(fixed, held, width)
    variance = _cut_variance(profiles, mask, mu, fitted_width)
    if censored is not None:
        _censored_centres(force, censored, mu, width)
    return (float(mu[1] - mu[0]), float(mu[3] - mu[2]),
            float(min(max(explained.min(), 0.0), 1.0)), variance)
