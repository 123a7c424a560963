"""Tests of the Levenberg-Marquardt solver the taxel model, its learning and the oracle share."""

import numpy as np
import pytest
from skin_driver.core.common.least_squares import (forward_jacobian, levenberg_marquardt,
                                                   scaled_into)

T = np.linspace(0.0, 3.0, 40)
TRUTH = np.array((2.5, -1.3, 0.4))


def decay(x):
    """Return the residuals of a * exp(b t) + c against the truth's curve."""
    a, b, c = x
    return a * np.exp(b * T) + c - (TRUTH[0] * np.exp(TRUTH[1] * T) + TRUTH[2])


def decay_jacobian(x, r):
    a, b, _ = x
    e = np.exp(b * T)
    return np.column_stack((e, a * T * e, np.ones_like(T)))


def test_a_nonlinear_curve_is_recovered_from_a_far_start_with_either_curvature():
    start = np.array((1.0, -0.2, 0.0))
    by_differences = levenberg_marquardt(decay, start, iterations=100,
                                         jacobian=forward_jacobian(decay, np.full(3, 1e-7)))
    exact = levenberg_marquardt(decay, start, iterations=100, jacobian=decay_jacobian)
    assert by_differences.x == pytest.approx(TRUTH, abs=1e-6)
    assert exact.x == pytest.approx(TRUTH, abs=1e-9)
    assert exact.cost < 1e-20
    # The curvature at the end is the normal matrix there (the covariance's inverse).
    jac = decay_jacobian(exact.x, decay(exact.x))
    np.testing.assert_allclose(exact.normal, jac.T @ jac, rtol=1e-6)


def test_normal_equations_given_by_the_caller_fit_as_the_jacobian_does():
    def normal_equations(x, r):
        jac = decay_jacobian(x, r)
        return jac.T @ jac, jac.T @ r
    start = np.array((1.0, -0.2, 0.0))
    one = levenberg_marquardt(decay, start, iterations=30, jacobian=decay_jacobian)
    other = levenberg_marquardt(decay, start, iterations=30, normal_equations=normal_equations)
    np.testing.assert_array_equal(one.x, other.x)
    with pytest.raises(ValueError, match='exactly one'):
        levenberg_marquardt(decay, start, iterations=3)


def test_no_move_goes_beyond_its_bound():
    start = np.array((1.0, -0.2, 0.0))
    bound = np.array((0.01, 0.02, 0.03))
    fit = levenberg_marquardt(decay, start, iterations=1, jacobian=decay_jacobian,
                              limit=scaled_into(bound))
    assert fit.steps == 1
    assert np.all(np.abs(fit.x - start) <= bound * (1 + 1e-12))
    # Scaled as a whole: the direction of the move is kept.
    assert np.abs((fit.x - start) / bound).max() == pytest.approx(1.0)


def test_the_fit_stops_after_its_steps_its_patience_or_a_short_move():
    calls = []

    def counted(x):
        calls.append(1)
        return decay(x)
    start = np.array((1.0, -0.2, 0.0))
    assert levenberg_marquardt(counted, start, iterations=50, jacobian=decay_jacobian,
                               most_steps=2).steps == 2
    # At the minimum no trial lowers the misfit: three rejected in a row end it.
    calls.clear()
    fit = levenberg_marquardt(counted, TRUTH, iterations=50, jacobian=decay_jacobian,
                              patience=3)
    assert (fit.steps, len(calls)) == (0, 1 + 3)
    np.testing.assert_array_equal(fit.x, TRUTH)
    short = levenberg_marquardt(decay, start, iterations=200, jacobian=decay_jacobian,
                                stop_move=1e-3)
    assert short.steps < levenberg_marquardt(decay, start, iterations=200,
                                             jacobian=decay_jacobian).steps


def test_a_parameter_the_residuals_do_not_see_ends_the_fit_instead_of_raising():
    def blind(x):
        return np.array((x[0] - 1.0, 0.0))

    def jacobian(x, r):
        return np.array(((1.0, 0.0), (0.0, 0.0)))
    # Without a floor under the damping the system is singular: the start comes back.
    fit = levenberg_marquardt(blind, np.array((3.0, 7.0)), iterations=10, jacobian=jacobian,
                              floor=0.0)
    np.testing.assert_array_equal(fit.x, (3.0, 7.0))
    # With one, the seen parameter is fitted and the blind one stays where it was.
    fit = levenberg_marquardt(blind, np.array((3.0, 7.0)), iterations=50, jacobian=jacobian)
    assert fit.x == pytest.approx((1.0, 7.0), abs=1e-6)
