"""Tests of segmentation into contacts."""

import numpy as np
import pytest

from skin_driver.core.estimation.contacts import (contact_windows, find_contacts,
                                                  segment_stacked, window_stack)


def _blob(shape, r, c, value=1.0):
    m = np.zeros(shape)
    m[r - 1:r + 2, c - 1:c + 2] = value * 0.25
    m[r, c] = value
    return m


def test_single_contact_location_force_area():
    top = _blob((16, 16), 6, 9)
    segs, labels = find_contacts(top, top, 0.005)
    assert len(segs) == 1
    s = segs[0]
    assert (s.row, s.col) == pytest.approx((6.0, 9.0))
    assert (s.x_m, s.y_m) == pytest.approx((0.045, 0.030))
    assert s.force_n == pytest.approx(3.0)
    assert s.area_m2 == pytest.approx(9 * 0.005 ** 2)
    assert s.window == (4, 9, 7, 12)


def test_sub_taxel_centroid():
    top = np.zeros((8, 8))
    top[3, 3], top[3, 4] = 3.0, 1.0
    s = find_contacts(top, top, 0.01)[0][0]
    assert s.col == pytest.approx(3.25)
    assert s.x_m == pytest.approx(0.0325)


def test_two_contacts_sorted_and_isolated():
    top = _blob((16, 16), 3, 3, 1.0) + _blob((16, 16), 11, 12, 2.0)
    segs, labels = find_contacts(top, top, 0.005)
    assert [round(s.force_n, 6) for s in segs] == [6.0, 3.0]
    tw, bw = contact_windows(top, top, labels, segs[0])
    assert tw.sum() == pytest.approx(6.0)


def test_bottom_imprint_joins_its_contact_and_weak_noise_is_dropped():
    top = _blob((16, 16), 8, 8)
    bottom = _blob((16, 16), 8, 9)
    top[0, 15] = 0.01
    segs, _ = find_contacts(top, bottom, 0.005, min_force_n=0.05)
    assert len(segs) == 1
    assert segs[0].window[2] <= 6 and segs[0].window[3] >= 11


def test_bad_input():
    with pytest.raises(ValueError, match='pitch_m must be positive'):
        find_contacts(np.zeros((4, 4)), np.zeros((4, 4)), 0.0)
    with pytest.raises(ValueError, match='inf'):
        find_contacts(np.full((4, 4), np.inf), np.zeros((4, 4)), 0.005)
    with pytest.raises(ValueError, match='connectivity'):
        find_contacts(np.zeros((4, 4)), np.zeros((4, 4)), 0.005, connectivity=6)


def test_bottom_layer_moments_and_border_flag():
    top = _blob((16, 16), 6, 9)
    bottom = np.zeros((16, 16))
    bottom[6, 10], bottom[6, 11] = 1.0, 1.0
    s = find_contacts(top, bottom, 0.005)[0][0]
    assert s.bottom_force_n == pytest.approx(2.0)
    assert (s.bottom_row, s.bottom_col) == pytest.approx((6.0, 10.5))
    assert s.bottom_spread == pytest.approx(0.25)
    assert not s.at_border
    edge = np.zeros((16, 16))
    edge[0, 3] = 1.0
    assert find_contacts(edge, edge, 0.005)[0][0].at_border


def test_many_contacts_use_the_same_moments():
    # More labels than the one-hot path handles: the bincount path must give the same figures.
    top = np.zeros((40, 40))
    top[::3, ::3] = np.arange(1, 197).reshape(14, 14)
    segs, _ = find_contacts(top, top * 0.5, 0.005, min_force_n=0.0)
    assert len(segs) == 196
    s = segs[0]
    assert s.force_n == pytest.approx(196.0) and s.bottom_force_n == pytest.approx(98.0)
    assert (s.row, s.col, s.bottom_row, s.bottom_col) == pytest.approx((39, 39, 39, 39))
    assert s.taxels == 1 and s.bottom_spread == pytest.approx(0.0, abs=1e-6)


def _fields(seg):
    return (seg.row, seg.col, seg.force_n, seg.taxels, seg.bottom_force_n, seg.bottom_row,
            seg.bottom_col, seg.bottom_spread)


def test_a_lone_contact_gives_the_same_figures_as_one_among_others():
    # A lone contact takes the whole-map shortcut; with a second contact the per-label sums run.
    rng = np.random.default_rng(4)
    top = _blob((16, 16), 6, 9) * rng.uniform(0.5, 1.5, (16, 16))
    bottom = np.roll(top, 1, axis=1) * 0.7
    alone, _ = find_contacts(top, bottom, 0.005)
    other = _blob((16, 16), 13, 2, 0.5)
    together, _ = find_contacts(top + other, bottom + other, 0.005)
    assert len(alone) == 1 and len(together) == 2
    assert _fields(alone[0]) == pytest.approx(_fields(together[0]), rel=1e-12, abs=1e-12)
    assert alone[0].window == together[0].window


def test_window_stack_equals_contact_windows():
    top = _blob((16, 16), 3, 3, 1.0) + _blob((16, 16), 5, 6, 2.0)
    top[4, 4] = 0.0  # two contacts whose windows overlap
    top[4, 5] = 0.0
    top[5, 4] = 0.0
    bottom = top * 0.5
    maps = np.stack((top, bottom))
    segs, labels, components = segment_stacked(maps, 0.005, 0.05, 1)
    assert components == 3 and len(segs) == 2
    for seg in segs:
        expected = contact_windows(top, bottom, labels, seg)
        window = window_stack(maps, labels, seg)
        np.testing.assert_array_equal(window[0], expected[0])
        np.testing.assert_array_equal(window[1], expected[1])
    lone = np.stack((_blob((16, 16), 8, 8), _blob((16, 16), 8, 9)))
    segs, labels, components = segment_stacked(lone, 0.005, 0.05, 1)
    assert components == 2
    copied = window_stack(lone, labels, segs[0], alone=True)
    np.testing.assert_array_equal(copied, np.stack(contact_windows(*lone, labels, segs[0])))
    copied[:] = 0.0
    assert lone.any()  # the window is a copy
