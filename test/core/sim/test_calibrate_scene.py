"""The bundled `calibrate` scene calibrates the simulated skin end to end, as the recipe says."""

import math
import re

import numpy as np
import pytest
from skin_driver.core.estimation.calibration.session import CalibrationSession
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.sim.physics import Press, render
from skin_driver.core.sim.scene import find_scene, load_scene

SCAN_S = 0.02


def listed(text: str, name: str) -> list:
    """Return each list of numbers the scene's header gives after ``name`` (the recipe's)."""
    return [[float(v) for v in found.split(',')]
            for found in re.findall(rf'{name} \[([^\]]*)\]', text)]


def test_the_scene_header_lists_the_loads_of_its_labelled_presses():
    # What the recipe tells a person to send is what the scene presses.
    scene = load_scene('calibrate')
    header = find_scene('calibrate').read_text()
    force, tilted = scene.labelled('force'), scene.labelled('compliance')
    assert listed(header, 'forces') == [[p.force_n for p in force], [p.force_n for p in tilted]]
    assert listed(header, 'alphas')[0] == pytest.approx(
        [math.radians(p.alpha_deg) for p in tilted], abs=1e-4)
    assert len(scene.labelled('offset')) == 8 and len(scene.labelled('gains')) == 1


def play(scene, est, session, start_s, end_s, rng):
    """Feed the session every scan from start_s to end_s, as the node does."""
    for t in np.arange(start_s, end_s, SCAN_S):
        top, bottom = render(scene.model, scene.presses_at(float(t)), rng)
        session.add_scan(top, bottom, est.process(top, bottom))
        if session.done:
            return


def test_the_calibrate_scene_calibrates_offset_force_compliance_and_gains_in_turn():
    scene = load_scene('calibrate')
    header = find_scene('calibrate').read_text()
    rng = np.random.default_rng(0)
    quiet = [render(scene.model, [], rng) for _ in range(20)]
    est = ContactEstimator(EstimatorConfig()).with_tare(np.stack([t for t, _ in quiet]),
                                                        np.stack([b for _, b in quiet]))
    steps = (('offset', 4.0, 20.0, {'presses': 8}),
             ('force', 22.0, 52.0, {'forces_n': listed(header, 'forces')[0]}),
             ('compliance', 57.0, 87.0, {'forces_n': listed(header, 'forces')[1],
                                         'alphas_rad': listed(header, 'alphas')[0]}),
             ('gains', 92.0, 99.0, {'presses': 1}))
    outcomes = {}
    for kind, start, end, args in steps:
        session = CalibrationSession(est, kind, **args)
        play(scene, est, session, start, end, rng)
        assert session.done, f'{kind}: {len(session.accepted)} of {session.wanted} presses'
        outcomes[kind] = session.finish()
        est = est.with_calibration(outcomes[kind].calibration)
    cal = est.calibration
    assert (cal.x_p_m, cal.y_p_m) == pytest.approx(scene.model.misalignment_m, abs=1e-4)
    assert abs(cal.compliance_m_per_n / scene.model.compliance_m_per_n - 1.0) < 0.1
    # The plate covers the skin: no gain at its limits.
    assert outcomes['gains'].warnings == ()
    # What the calibrated estimator reads of presses the calibration never saw.
    for force, alpha in ((18.0, 0.0), (30.0, 30.0)):
        press = Press(0.041, 0.033, force, math.radians(alpha), 1.0, 0.004)
        contact = est.process(*render(scene.model, [press], rng))[0]
        assert abs(contact.force_n / press.normal_force_n - 1.0) < 0.05
        if alpha:
            assert abs(math.degrees(contact.alpha_rad) - alpha) < 2.0
