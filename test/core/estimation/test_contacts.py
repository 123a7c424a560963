"""Tests of contact finding: top imprints, their bottom imprints, neighbours kept apart."""

import numpy as np
import pytest

from skin_driver.core.estimation.scan.contacts import LayerPair, pair_layers
from skin_driver.core.estimation.shift.methods import centroid


def _blob(shape, r, c, value=1.0):
    m = np.zeros(shape)
    m[r - 1:r + 2, c - 1:c + 2] = value * 0.25
    m[r, c] = value
    return m


def _gauss(shape, r, c, sigma, value=1.0):
    rr, cc = np.indices(shape)
    return value * np.exp(-((rr - r) ** 2 + (cc - c) ** 2) / (2 * sigma * sigma))


def _shift(pair: LayerPair):
    est = centroid(pair.maps)
    return est.dy, est.dx


def test_single_contact_location_forces_and_window():
    top = _blob((16, 16), 6, 9)
    bottom = _blob((16, 16), 6, 10, 0.5)
    pairs = pair_layers(np.stack((top, bottom)))
    assert len(pairs) == 1
    p = pairs[0]
    assert (p.row, p.col) == pytest.approx((6.0, 9.0))
    assert p.top_force_n == pytest.approx(3.0) and p.bottom_force_n == pytest.approx(1.5)
    assert p.taxels == 9 and not p.at_border
    # The window holds both imprints plus a margin of one taxel.
    assert p.origin == (4, 7) and p.maps.shape == (2, 5, 6)
    assert _shift(p) == pytest.approx((0.0, 1.0))


def test_bottom_imprint_far_from_the_top_one_is_still_its_own():
    # A soft layer under a strong tilted press: the bottom imprint lies 5 taxels away and does not
    # touch the top one. Expected: one contact whose shift is the 5 taxels.
    top = _blob((16, 16), 7, 4)
    bottom = _gauss((16, 16), 7, 9, 1.0) * (top > 0).sum() / 4.0
    bottom[bottom < 0.01] = 0.0
    pairs = pair_layers(np.stack((top, bottom)))
    assert len(pairs) == 1
    assert _shift(pairs[0]) == pytest.approx((0.0, 5.0), abs=0.01)


def test_two_presses_joined_by_a_shallow_saddle_are_two_contacts():
    # Two fingers three taxels apart whose top imprints touch: the load between them drops to
    # well under the weaker peak. Expected: two contacts, each on its own peak.
    top = _gauss((16, 16), 8, 5, 0.8, 4.0) + _gauss((16, 16), 8, 8, 0.8, 3.0)
    top[top < 0.05] = 0.0
    bottom = _gauss((16, 16), 9, 5, 1.2, 4.0) + _gauss((16, 16), 7, 8, 1.2, 3.0)
    bottom[bottom < 0.05] = 0.0
    pairs = pair_layers(np.stack((top, bottom)))
    assert len(pairs) == 2
    first, second = pairs
    assert (round(first.row), round(first.col)) == (8, 5)
    assert (round(second.row), round(second.col)) == (8, 8)
    # Each keeps its own bottom imprint although the two overlap: +1 row and -1 row.
    assert _shift(first) == pytest.approx((1.0, 0.0), abs=0.25)
    assert _shift(second) == pytest.approx((-1.0, 0.0), abs=0.25)
    assert first.bottom_force_n + second.bottom_force_n == pytest.approx(bottom.sum(), rel=0.03)


def test_two_fingers_whose_counts_barely_dip_are_split_by_the_load_between_them():
    # Two presses 2 taxels apart on a film near the end of its curve: the counts between them
    # stay at 0.94 of the weaker peak, the load drops to 0.78 of it (the force maps' saddle).
    # Expected: two contacts, one on each peak; judged on the counts alone they were one.
    force = _gauss((16, 16), 6, 8, 0.7, 10.0) + _gauss((16, 16), 8, 8, 0.7, 12.0)
    force[force < 0.2] = 0.0
    counts = 4000.0 * force / (force + 3.0)
    assert counts[7, 8] / counts[6, 8] > 0.9 and force[7, 8] / force[6, 8] < 0.8
    maps = np.stack((counts, np.roll(counts, 1, axis=1)))
    assert len(pair_layers(maps)) == 1
    pairs = pair_layers(maps, force=np.stack((force, np.roll(force, 1, axis=1))))
    assert sorted((round(p.row), round(p.col)) for p in pairs) == [(6, 8), (8, 8)]


def test_a_second_press_whose_peak_reads_less_load_than_a_flank_is_still_its_own_contact():
    # Two presses 2 taxels apart (a `loaded` skin's frame): the weaker press's peak taxel reads
    # more counts than its neighbour on the stronger press's flank, but after that taxel's gain
    # less force (5.27 N against 5.34 N). Expected: two contacts; the force map alone has one
    # peak there.
    counts, force = np.zeros((16, 16)), np.zeros((16, 16))
    counts[3, 4:6], force[3, 4:6] = (787, 973), (0.16, 0.24)
    counts[4, 4:8], force[4, 4:8] = (2715, 2516, 1795, 1200), (7.47, 5.34, 1.39, 0.41)
    counts[5, 4:8], force[5, 4:8] = (373, 0, 2536, 1933), (0.03, 0.0, 5.27, 1.72)
    maps = np.stack((counts, np.roll(counts, 1, axis=0)))
    pairs = pair_layers(maps, force=np.stack((force, np.roll(force, 1, axis=0))))
    assert sorted((round(p.row), round(p.col)) for p in pairs) == [(4, 4), (5, 6)]
    assert len(pair_layers(np.stack((force, np.roll(force, 1, axis=0))))) == 1


def test_a_flat_topped_imprint_with_two_close_maxima_is_one_contact():
    # A large indenter loads a plateau whose noise makes two maxima one taxel apart.
    top = np.zeros((16, 16))
    top[6:9, 6:10] = 2.0
    top[7, 6], top[7, 9] = 2.1, 2.05
    pairs = pair_layers(np.stack((top, top)))
    assert len(pairs) == 1 and pairs[0].taxels == 12


def test_two_separate_contacts_and_the_border_flag():
    top = _blob((16, 16), 3, 3, 1.0) + _blob((16, 16), 11, 12, 2.0)
    top[0, 15] = 0.5
    pairs = pair_layers(np.stack((top, top)))
    assert len(pairs) == 3
    assert [p.at_border for p in pairs] == [False, False, True]
    assert pairs[0].top_force_n == pytest.approx(6.0)
    assert sum(p.bottom_force_n for p in pairs) == pytest.approx(top.sum(), rel=1e-6)


def test_a_bottom_imprint_is_cut_only_when_its_strongest_line_is_the_edge():
    # Top imprint at row 2; the wider bottom imprint reaches row 0 with its rim only: not cut.
    top = _blob((16, 16), 2, 8)
    rim_only = pair_layers(np.stack((top, _gauss((16, 16), 2, 8, 1.2))))[0]
    assert rim_only.at_border and not rim_only.bottom_cut
    # The bottom imprint pushed to the edge column (centre half a taxel past it): cut.
    past = pair_layers(np.stack((_blob((16, 16), 8, 14), _gauss((16, 16), 8, 15.5, 1.2))))[0]
    assert past.at_border and past.bottom_cut
    # Away from the edge nothing is cut.
    inside = pair_layers(np.stack((_blob((16, 16), 8, 8), _gauss((16, 16), 8, 8, 1.2))))[0]
    assert not inside.at_border and not inside.bottom_cut


def test_the_contact_limit_keeps_the_strongest_and_no_load_has_no_contact():
    top = _blob((16, 16), 3, 3, 1.0) + _blob((16, 16), 11, 12, 2.0)
    maps = np.stack((top, top))
    assert len(pair_layers(maps)) == 2
    (only,) = pair_layers(maps, max_contacts=1)
    assert only.top_force_n == pytest.approx(2.0 * 3.0)
    assert pair_layers(np.zeros((2, 8, 8))) == []
