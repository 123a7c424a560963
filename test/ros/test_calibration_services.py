"""The calibration services on the direction node: force and compliance, per-node files."""

import math

import numpy as np
from pipeline import call, overrides, pipeline, scene
import pytest
from rosutil import ros_context, spin_until
from skin_driver.core.estimation.calibration import Calibration
from skin_driver.core.estimation.forcecurve import ForceCurve
from skin_driver.ros.calibration_services import default_calibration_file
from skin_driver.ros.conversions import status_values
from skin_driver.ros.direction_node import DirectionNode
from skin_msgs.srv import CalibrateCompliance, CalibrateForce, CalibrateGains

pytestmark = pytest.mark.ros

# Another FSR curve and twice the default compliance: the assumed values are far off here.
MODEL = {'fsr': {'r_series_ohm': 2000.0, 'r_min_ohm': 150.0, 'r_max_ohm': 6000.0,
                 'force_at_r_min_n': 40.0}, 'compliance_m_per_n': 1.4e-3}
FORCES = [5.0, 30.0, 10.0, 40.0, 15.0, 25.0, 8.0, 20.0]
TILTED = [(6.0, 30.0, 0.0), (8.0, 20.0, 90.0), (5.0, 40.0, 200.0), (7.0, 25.0, 300.0)]
CURVE = ForceCurve((0.0, 1000.0, 3000.0), (0.0, 1.0, 9.0))


def test_force_then_compliance_through_the_services(tmp_path):
    presses = [{'time_s': 2.0 + 1.2 * i, 'force_n': f} for i, f in enumerate(FORCES)]
    start = 2.0 + 1.2 * len(FORCES) + 1.0
    presses += [{'time_s': start + 1.2 * i, 'force_n': f, 'alpha_deg': a, 'beta_deg': b}
                for i, (f, a, b) in enumerate(TILTED)]
    with pipeline(tmp_path, scene(presses, **MODEL)) as (sim, _, direction, probe, executor):
        force = call(executor, direction, CalibrateForce, '/skin_direction/calibrate_force',
                     CalibrateForce.Request(forces=FORCES, timeout=20.0), timeout_s=30.0)
        assert force.success, force.message
        assert force.presses_used == len(FORCES) and len(force.residuals) == len(FORCES)
        assert max(abs(r) / f for r, f in zip(force.residuals, FORCES)) < 0.15
        assert len(force.curve_counts) == len(force.curve_forces) >= 2
        assert 'written to' in force.message
        compliance = call(executor, direction, CalibrateCompliance,
                          '/skin_direction/calibrate_compliance',
                          CalibrateCompliance.Request(
                              forces=[t[0] for t in TILTED],
                              alphas=[math.radians(t[1]) for t in TILTED], timeout=20.0),
                          timeout_s=30.0)
        assert compliance.success, compliance.message
        assert compliance.compliance == pytest.approx(1.4e-3, rel=0.2)
        assert len(compliance.fitted) == len(TILTED)
        in_force = direction.host.estimator.calibration
        assert in_force.force_curves is not None and in_force.compliance_presses == 4
        # What the diagnostics say is what was made, and when.
        assert spin_until(executor, lambda: any(
            s.name.endswith('contact estimation') and
            status_values(s).get('calibration made') == in_force.made_utc
            for _, s in probe.statuses))
    saved = Calibration.load_yaml(str(tmp_path / 'calibration.yaml'))
    assert saved == in_force


def test_bad_requests_answer_the_calibration_in_force_and_change_nothing(tmp_path):
    path = tmp_path / 'calibration.yaml'
    previous = Calibration(x_p_m=2e-4, compliance_m_per_n=1e-3, force_curves=(CURVE, CURVE),
                           force_presses=7, made_utc='2026-01-01T00:00:00Z')
    previous.save_yaml(path)
    text = path.read_text()
    with ros_context() as (context, executor):
        node = DirectionNode(context=context, parameter_overrides=overrides(
            {'calibration_file': str(path)}))
        executor.add_node(node)
        try:
            force = call(executor, node, CalibrateForce, '/skin_direction/calibrate_force',
                         CalibrateForce.Request(forces=[5.0, -1.0], timeout=1.0))
            assert not force.success and 'positive number of newtons' in force.message
            assert 'previous calibration stays in force' in force.message
            assert list(force.curve_counts) == list(CURVE.counts)
            compliance = call(executor, node, CalibrateCompliance,
                              '/skin_direction/calibrate_compliance',
                              CalibrateCompliance.Request(forces=[], timeout=1.0))
            assert not compliance.success and 'calibration.wrench_topic' in compliance.message
            assert compliance.compliance == 1e-3
            compliance = call(executor, node, CalibrateCompliance,
                              '/skin_direction/calibrate_compliance',
                              CalibrateCompliance.Request(forces=[5.0], alphas=[2.0]))
            assert not compliance.success and 'pi/2) radians' in compliance.message
            force = call(executor, node, CalibrateForce, '/skin_direction/calibrate_force',
                         CalibrateForce.Request(forces=[5.0] * 6, timeout=0.3))
            assert not force.success and 'timed out' in force.message
            gains = call(executor, node, CalibrateGains, '/skin_direction/calibrate_gains',
                         CalibrateGains.Request(presses=1, timeout=0.3))
            assert not gains.success and 'timed out' in gains.message
            assert (gains.gain_min, gains.gain_max) == (1.0, 1.0)  # no gains in force
            assert node.host.estimator.calibration == previous
        finally:
            node.destroy_node()
    assert path.read_text() == text


def test_two_skins_in_two_namespaces_never_share_a_calibration_file(tmp_path, monkeypatch):
    monkeypatch.setenv('ROS_HOME', str(tmp_path))
    left = default_calibration_file('/left/skin_direction')
    assert left == str(tmp_path / 'skin_driver' / 'calibration' / 'left' / 'skin_direction.yaml')
    Calibration(x_p_m=5e-4, presses=3).save_yaml(left)
    with ros_context() as (context, _):
        nodes = {ns: DirectionNode(context=context, namespace=ns) for ns in ('/left', '/skin')}
        try:
            assert nodes['/left'].host.estimator.calibration.x_p_m == 5e-4
            assert nodes['/skin'].host.estimator.calibration == Calibration()
            assert 'skin/skin_direction.yaml' in nodes['/skin'].host.calibration.note
        finally:
            for node in nodes.values():
                node.destroy_node()
    assert np.isclose(Calibration.load_yaml(left).x_p_m, 5e-4)
