"""
The thread that runs the scans owns the live kernels; changes reach it between two scans.

With the owner check on, a kernel refuses every thread but the first to enter it; other threads
read what the owner publishes. A change is built off the scans' thread and handed over
(:class:`Handover`); the owner carries the per-scan state (drift state, dead marks) into it as it
puts it in force, so the drift state sees every scan and a mark revived after the build stays
revived.
"""

from dataclasses import replace
import threading

import numpy as np
import pytest

from skin_driver.core.estimation.scan import kernel
from skin_driver.core.estimation.scan.handover import Handover
from skin_driver.core.estimation.scan.pipeline import ContactEstimator
from skin_driver.core.sim.physics import Press, render, SkinModel

PRESS = Press(0.0375, 0.0375, 8.0, 0.5, 1.0)


def _tared(model, rng):
    frames = [render(model, [], rng) for _ in range(8)]
    return ContactEstimator().with_tare(np.stack([t for t, _ in frames]),
                                        np.stack([b for _, b in frames]))


def _on_a_thread(work) -> dict:
    """Return {'value': work()} or {'error': what it raised}, run on a thread of its own."""
    box = {}

    def run():
        try:
            box['value'] = work()
        except Exception as err:  # noqa: B902 - handed to the test as it is
            box['error'] = err
    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    return box


def test_only_the_owner_enters_a_live_kernel_and_other_threads_read_its_snapshots(monkeypatch):
    monkeypatch.setenv(kernel.CHECK_VARIABLE, '1')
    model = SkinModel()
    rng = np.random.default_rng(7)
    est = _tared(model, rng)
    top, bottom = render(model, [PRESS], rng)
    before = len(kernel.breaches())
    assert est.process(top, bottom, 0.0)  # this thread enters first: it owns the kernel

    # Another thread's scan is refused, and the refusal is kept.
    scanned = _on_a_thread(lambda: est.process(top, bottom, 0.01))
    assert isinstance(scanned.get('error'), kernel.NotTheOwner)
    assert len(kernel.breaches()) == before + 1
    # Carrying the per-scan state from another thread than the owner's (a swap built off the
    # scans' thread, as before the hand-over) enters the live kernel: refused too.
    changed = est.with_config(est.config)
    carried = _on_a_thread(lambda: changed.carry_from(est))
    assert isinstance(carried.get('error'), kernel.NotTheOwner)

    # What the owner publishes is any thread's to read; so are heatmaps and a new estimator.
    read = _on_a_thread(lambda: (est.drift(), est.dead_masks(), est.timed_scans,
                                 est.conditioning, est.maps_of(top, bottom),
                                 est.with_config(est.config)))
    assert 'error' not in read
    assert read['value'][2] == 1  # one timed scan: the refused one never ran

    # A claim hands the kernel over: the new owner scans, the old one is refused.
    handed = _on_a_thread(lambda: est.claim().process(top, bottom, 0.02))
    assert handed.get('value')
    with pytest.raises(kernel.NotTheOwner):
        est.process(top, bottom, 0.03)
    assert len(kernel.breaches()) == before + 3


def test_changes_handed_over_mid_stream_lose_no_scan_from_the_drift_state(owner_checked):
    model = SkinModel()
    rng = np.random.default_rng(8)
    est = _tared(model, rng)
    scans = [render(model, [PRESS] if i % 3 else [], rng) for i in range(6)]
    applied, handed = [], []

    def carry(new, old):
        applied.append(new)
        new.carry_from(old)
    handover = Handover(est, carry)
    changes, between = 12, 20
    scanned = [0]
    progress = threading.Condition()

    def change_now_and_then():
        # Each change built here, off the scans' thread, after `between` more scans.
        for i in range(changes):
            with progress:
                progress.wait_for(lambda: scanned[0] >= (i + 1) * between)
            confidence = 0.3 + 0.01 * (i + 1)
            handed.append(handover.put(lambda old: old.with_config(
                replace(old.config, min_confidence=confidence)).ready_for(16, 16)))

    changer = threading.Thread(target=change_now_and_then)
    changer.start()
    met = []  # the estimators in force, in order
    n = 0
    while n < (changes + 1) * between or changer.is_alive() or handover.pending:
        live = handover.take()
        if not met or met[-1] is not live:
            met.append(live)
        top, bottom = scans[n % len(scans)]
        live.process(top, bottom, time_s=0.001 * n)
        n += 1
        with progress:
            scanned[0] = n
            progress.notify_all()
    changer.join()

    final = handover.take()
    # Changes were put in force between scans, in the order handed over (one handed over before
    # the owner took the one before it replaced it, and holds it): the last one is in force.
    order = [next(i for i, made in enumerate(handed) if made is live) for live in applied]
    assert len(handed) == changes and applied[-1] is handed[-1]
    assert order == sorted(set(order))
    assert len(met) > 1 and all(live in applied for live in met[1:])
    assert final is handover.newest
    assert final.config.min_confidence == pytest.approx(0.3 + 0.01 * changes)
    # The drift state saw every scan, across all the swaps.
    assert final.timed_scans == n


def test_a_taxel_revived_between_a_change_s_build_and_its_swap_stays_revived(owner_checked):
    model = SkinModel()
    rng = np.random.default_rng(9)
    frames = [render(model, [], rng) for _ in range(8)]
    tops = np.stack([t for t, _ in frames])
    tops[:, 8, 8] = 0  # dead at the tare
    est = ContactEstimator().with_tare(tops, np.stack([b for _, b in frames]))
    handover = Handover(est, lambda new, old: new.carry_from(old))
    # A change built off the scans' thread while (8, 8) is still dead.
    built = _on_a_thread(lambda: handover.put(lambda old: old.with_config(old.config)))['value']
    assert built.dead_masks()[0][8, 8]
    # The live estimator's next scan touches (8, 8) and revives it, before the swap.
    assert handover.in_force is est
    assert est.process(*render(model, [Press(0.0425, 0.0425, 10.0, 0.5, 2.0)], rng))
    assert not est.dead_masks()[0][8, 8]

    live = handover.take()
    assert live is built
    # Expected: revived in the new kernel too, not again at its next touch.
    assert not live.dead_masks()[0][8, 8]
    assert not live.conditioning.dead_masks()[0][8, 8]
    # And the new kernel scans as the old one: a press around (8, 8) that it reads at 0 (a
    # dead taxel would be filled from its neighbours, a live one reads its own 0).
    top, bottom = render(model, [Press(0.0425, 0.0425, 10.0, 0.5, 2.0)], rng)
    top[8, 8] = 0
    assert live.process(top, bottom) == est.process(top, bottom)
    # Its heatmaps too: (8, 8) reads its own 0, not its neighbours' mean.
    assert live.maps_of(top, bottom)[0][8, 8] == 0.0


def test_changes_while_no_scan_comes_replace_each_other_and_the_newest_holds_them_all(
        owner_checked):
    model = SkinModel()
    rng = np.random.default_rng(10)
    est = _tared(model, rng)
    for i in range(3):
        est.process(*render(model, [PRESS], rng), time_s=0.01 * i)
    carried = []

    def carry(new, old):
        carried.append((new, old))
        new.carry_from(old)
    handover = Handover(est, carry)

    def change_threshold(old):
        return old.with_config(replace(old.config, threshold_counts=old.config.threshold_counts
                                       + 1)).ready_for(16, 16)
    # A board unplugged while a script changes a parameter 50 times, on a thread of its own.
    handed = _on_a_thread(lambda: [handover.put(change_threshold) for _ in range(50)])['value']
    # Expected: one change waits (the newest), not fifty; the older ones are not kept.
    assert handover.pending and handover.newest is handed[-1]
    live = handover.take()
    # Expected: the newest in force after one carry from the one the scans met, with every
    # change in it and the drift state of the scans before.
    assert carried == [(handed[-1], est)]
    assert live is handed[-1] and not handover.pending
    assert live.config.threshold_counts == est.config.threshold_counts + 50
    assert live.timed_scans == est.timed_scans == 3
    assert handover.take() is live and len(carried) == 1
