"""A calibration of another grid, refused or replaced, leaves the estimator serving this grid."""

import numpy as np
from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.scan import kernel
from skin_driver.core.estimation.scan.pipeline import ContactEstimator
from skin_driver.core.sim.physics import Press, render, SkinModel


def test_the_defaults_after_a_calibration_of_another_grid_estimate_this_grid():
    """Issue #37: a 16 x 16 file refused on a 12 x 12 skin left every frame dropped."""
    gains = (np.full((16, 16), 1.1), np.full((16, 16), 0.9))
    est = ContactEstimator(calibration=Calibration(gains=gains)).with_calibration(Calibration())
    est = est.for_grid(12, 12)
    model = SkinModel(rows=12, cols=12)
    top, bottom = render(model, [Press(0.03, 0.025, 10.0)], np.random.default_rng(0))
    contacts = est.process(top, bottom)
    assert len(contacts) == 1
    assert abs(contacts[0].x_m - 0.03) < 0.002 and abs(contacts[0].y_m - 0.025) < 0.002


def test_a_tare_of_another_grid_is_dropped_for_this_grid():
    model = SkinModel(rows=12, cols=12)
    rng = np.random.default_rng(1)
    idle = [render(SkinModel(), [], rng) for _ in range(8)]
    est = ContactEstimator().with_tare(np.stack([t for t, _ in idle]),
                                       np.stack([b for _, b in idle]))
    assert est.for_grid(16, 16) is est
    est = est.for_grid(12, 12)
    top, bottom = render(model, [Press(0.03, 0.025, 10.0)], rng)
    assert len(est.process(top, bottom)) == 1


def test_an_estimator_made_ready_for_a_grid_builds_nothing_on_its_first_scan(monkeypatch):
    est = ContactEstimator().ready_for(12, 12)
    built = []
    real = kernel.Kernel.__init__

    def counting(self, *args, **kwargs):
        built.append(args)
        real(self, *args, **kwargs)
    monkeypatch.setattr(kernel.Kernel, '__init__', counting)
    top, bottom = render(SkinModel(rows=12, cols=12), [Press(0.03, 0.025, 10.0)],
                         np.random.default_rng(2))
    assert len(est.process(top, bottom)) == 1 and built == []
    # A grid it was not made ready for is built by its first scan, as before.
    top, bottom = render(SkinModel(rows=10, cols=10), [Press(0.02, 0.02, 10.0)],
                         np.random.default_rng(3))
    assert len(est.process(top, bottom)) == 1 and len(built) == 1
