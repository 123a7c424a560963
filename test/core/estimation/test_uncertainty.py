"""Tests of a contact's shift uncertainty: what each share of its data adds to sigma."""

import numpy as np
import pytest

from skin_driver.core.estimation.scan.contacts import LayerPair
from skin_driver.core.estimation.scan.uncertainty import shift_sigma


def _pair(top, share):
    maps = np.array([[top], [share]], dtype=np.float64)
    return LayerPair(maps, (0, 0), 0.0, 1.0, float(maps[0].sum()), float(maps[1].sum()),
                     int((maps[0] > 0).sum()), False)


def test_a_bottom_share_the_mixture_is_unsure_of_adds_its_assignment_spread():
    # A contact beside another: the bottom taxel at column 0 (100 counts) is half its own, the
    # one at column 1 wholly its own. Were column 0's load its own with probability 1/2, the
    # share's centroid (2/3 of a column) would spread by 100**2 * 1/4 * (2/3)**2 / 150**2 on
    # that axis; sigma stands for one axis, so half of that. Expected: sigma**2 grows by 0.0247.
    counts = np.array([[[0.0, 100.0, 0.0]], [[100.0, 100.0, 0.0]]])
    noise = np.zeros_like(counts)
    pair = _pair([0.0, 100.0, 0.0], [50.0, 100.0, 0.0])
    shared = shift_sigma(pair, counts, noise, False, 0.0)
    alone = shift_sigma(pair, counts, noise, True, 0.0)
    assert shared ** 2 - alone ** 2 == pytest.approx(0.5 * 2500.0 * (2 / 3) ** 2 / 150.0 ** 2)


def test_a_bottom_share_wholly_its_own_adds_nothing():
    # The same contact whose neighbour takes none of its bottom: no assignment spread, and its
    # shares carry all of their noise. Expected: the same sigma as alone.
    counts = np.array([[[0.0, 100.0, 0.0]], [[100.0, 100.0, 0.0]]])
    noise = np.full_like(counts, 3.0)
    pair = _pair([0.0, 100.0, 0.0], [100.0, 100.0, 0.0])
    assert shift_sigma(pair, counts, noise, False, 0.0) == pytest.approx(
        shift_sigma(pair, counts, noise, True, 0.0))
