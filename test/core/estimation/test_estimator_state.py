"""
An estimator does not change once made: its kernel holds the one per-scan state (dead marks).

Snapshots (``conditioning``, ``dead_masks``) and heatmaps (``maps_of``) are read from other
threads while one thread scans; a ``with_*`` change makes a new estimator from a snapshot.
"""

import threading

import numpy as np
import pytest

from skin_driver.core.estimation.scan.pipeline import ContactEstimator
from skin_driver.core.sim.physics import Press, render, SkinModel


def tared_with_dead_taxel(model, rng, spot):
    frames = [render(model, [], rng) for _ in range(8)]
    tops = np.stack([t for t, _ in frames])
    tops[:, spot[0], spot[1]] = 0
    return ContactEstimator().with_tare(tops, np.stack([b for _, b in frames]))


def test_a_scan_revives_in_the_kernel_and_a_change_carries_the_marks_over():
    model = SkinModel()
    rng = np.random.default_rng(4)
    est = tared_with_dead_taxel(model, rng, (8, 8))
    snapshot = est.conditioning
    assert est.dead_masks()[0][8, 8] and snapshot.dead_masks()[0][8, 8]
    top, bottom = render(model, [Press(0.0425, 0.0425, 10.0, 0.5, 2.0)], rng)
    assert est.process(top, bottom)
    # Revived in the kernel; the snapshot taken before is a copy and keeps its marks.
    assert not est.dead_masks()[0][8, 8] and not est.conditioning.dead_masks()[0][8, 8]
    assert snapshot.dead_masks()[0][8, 8]
    # A new estimator starts from the marks in force when it is made.
    changed = est.with_config(est.config)
    assert not changed.dead_masks()[0][8, 8]


def test_a_tared_estimator_has_its_kernel_before_the_first_scan():
    model = SkinModel()
    est = tared_with_dead_taxel(model, np.random.default_rng(1), (3, 3))
    assert set(est._kernels) == {(16, 16)}


def test_heatmaps_are_the_scans_conditioning():
    model = SkinModel()
    rng = np.random.default_rng(2)
    est = tared_with_dead_taxel(model, rng, (5, 5))
    top, bottom = render(model, [Press(0.03, 0.04, 8.0, 0.4, 1.0)], rng)
    maps = est.maps_of(top, bottom)
    # Drawn on a kernel of their own: the scanning kernel's marks are not touched.
    assert est.dead_masks()[0][5, 5]
    # The scan's normal force is its bottom layer's sum over the sensed share of the area.
    contact, = est.process(top, bottom)
    fill = est.config.fill_factor
    assert maps[1].sum() / fill ** 2 == pytest.approx(contact.force_n, rel=1e-9)


def test_a_calibrations_kernel_revives_its_own_marks_only():
    model = SkinModel()
    rng = np.random.default_rng(5)
    est = tared_with_dead_taxel(model, rng, (8, 8))
    kernel = est.conditioning_kernel(16, 16)
    scan = kernel.condition(*render(model, [Press(0.0425, 0.0425, 10.0, 0.5, 2.0)], rng))
    assert scan.counts[0, 8, 8] > 0
    assert not kernel.dead_masks()[0][8, 8]
    assert est.dead_masks()[0][8, 8]
    # Made later, another one starts from the marks in force then.
    assert est.conditioning_kernel(16, 16).dead_masks()[0][8, 8]


def test_readers_and_changes_beside_a_scanning_thread_see_whole_states(owner_checked):
    model = SkinModel()
    rng = np.random.default_rng(3)
    # Its dead taxel far from the presses: every scan's contacts are the same in every round.
    est = tared_with_dead_taxel(model, rng, (0, 15))
    scans = [render(model, [Press(0.02 + 0.004 * i, 0.04, 6.0 + i, 0.5, 0.3 * i)], rng)
             for i in range(6)]
    want = [est.with_config(est.config).process(t, b) for t, b in scans]
    stop = threading.Event()
    errors = []

    def read():
        try:
            while not stop.is_set():
                est.maps_of(*scans[0])
                snapshot = est.conditioning
                assert snapshot.dead_masks()[0].shape == (16, 16)
                est.with_config(est.config)
        except Exception as err:  # noqa: B902 - reported below, from the main thread
            errors.append(err)

    reader = threading.Thread(target=read)
    reader.start()
    try:
        for _ in range(30):
            got = [est.process(t, b) for t, b in scans]
            assert got == want
    finally:
        stop.set()
        reader.join()
    assert not errors
