"""A contact's censored taxels: lower bounds for the fit, sums filled in or given their rims."""

import numpy as np
import pytest
from skin_driver.core.estimation.model.forcecurve import ForceCurve
from skin_driver.core.estimation.scan.censoring import (censored_taxels, force_window,
                                                        marked_counts, with_censored_sums)
from skin_driver.core.estimation.scan.contacts import LayerPair

CEILING = 3000.0
# Linear to the ceiling, then flat: a film at its resistance floor.
SATURATING = ForceCurve((0.0, CEILING, 4000.0), (0.0, 3.0, 3.0), censor_counts=CEILING,
                        spread_taxels=1.0, rim_load_n=0.5)
PLAIN = ForceCurve((0.0, 4000.0), (0.0, 4.0), rim_load_n=0.5)


def _pair(top, bottom, origin=(1, 1)):
    maps = np.stack((top, bottom)).astype(np.float64)
    return LayerPair(maps, origin, 2.0, 2.0, float(top.sum()) / 1000, float(bottom.sum()) / 1000,
                     int((top > 0).sum()), False)


def test_taxels_read_at_the_adcs_full_scale_are_censored_whatever_their_counts():
    top = np.array([[0, 500, 0], [500, 1200, 500], [0, 500, 0]], float)
    bottom = np.full((3, 3), 300.0)
    pair = _pair(top, bottom)
    clipped = np.zeros((2, 6, 6), bool)
    clipped[0, 2, 2] = True  # the top's centre, tared down to 1200 counts
    marked = marked_counts(pair, clipped, full_scale=4095.0)
    assert marked[0, 1, 1] == 4095.0 and marked[0, 0, 1] == 500.0
    mask = censored_taxels(marked, (SATURATING, SATURATING))
    assert mask[0].sum() == 1.0 and mask[0, 1, 1] == 1.0 and mask[1].sum() == 0.0
    # Without a censoring curve nothing is a lower bound, marked or not.
    assert censored_taxels(marked, None).sum() == 0.0
    assert marked_counts(pair, None, 4095.0) is pair.maps


def test_an_unsaturated_layer_gets_its_rim_load_and_a_saturated_one_is_filled_in():
    top = np.array([[0, 800, 0], [800, CEILING, 800], [0, 800, 0]], float)
    bottom = np.array([[200, 400, 200], [400, 900, 400], [200, 400, 200]], float)
    pair = _pair(top, bottom, origin=(0, 0))
    force = np.stack((top, bottom)) / 1000.0  # 1 N per 1000 counts, the window's own share
    window = force_window(pair, pair.maps, force)
    np.testing.assert_allclose(window, force)
    out = with_censored_sums(pair, pair.maps, window, (SATURATING, PLAIN))
    # The bottom reads 3.3 N and no taxel of it is censored: its rim load is added, no more.
    assert out.bottom_force_n == pytest.approx(3.3 + 0.5)
    # The top's centre is at the ceiling: its load is at least the 3 N read there.
    assert out.top_force_n > 3.0 + 4 * 0.8 + 0.5
    assert out.origin == pair.origin and out.taxels == pair.taxels
