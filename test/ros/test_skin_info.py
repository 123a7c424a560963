"""skin_info: a latched description of the skin, for a tool that finds the topic later."""

import math

from diagnostic_msgs.msg import DiagnosticArray
from pipeline import pipeline, scene
import pytest
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosutil import spin_until
from skin_driver.core.estimation.calibration.calibration import Calibration, SkinMount
from skin_driver.core.estimation.calibration.creep import CreepFit
from skin_driver.core.estimation.calibration.direction import DirectionCorrection
from skin_driver.core.estimation.scan.kernel import DIRECTION_FEATURES
from skin_driver.core.protocol.wire import BoardInfo
from skin_msgs.msg import SkinInfo

pytestmark = pytest.mark.ros

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)


def test_the_skin_describes_itself_to_a_late_subscriber(tmp_path):
    with pipeline(tmp_path, scene([]), rate_hz=100.0,
                  direction={'layer_gap': 0.002}) as (_, _, _, probe, executor):
        early = []
        probe.node.create_subscription(SkinInfo, '/skin_info', early.append,
                                       LATCHED)
        assert spin_until(executor, lambda: any(m.board_uid for m in early), 15.0)
        late = []
        probe.node.create_subscription(SkinInfo, '/skin_info', late.append,
                                       LATCHED)
        assert spin_until(executor, lambda: late, 5.0), 'the description is not latched'
    info = late[-1]
    assert (info.rows, info.cols) == (16, 16) and info.pitch == pytest.approx(0.005)
    assert info.layer_gap == pytest.approx(0.002) and info.min_contact_force > 0
    assert info.board_name == 'sim' and len(info.board_uid) == 24 and info.firmware_version
    assert info.scan_rate > 0 and info.header.frame_id
    assert info.calibration_parts == [] and info.calibration_parts_made == []
    assert (info.parent_frame, info.mount_source) == ('', '')


def _described(executor, probe):
    heard = []
    probe.node.create_subscription(SkinInfo, '/skin_info', heard.append, LATCHED)
    assert spin_until(executor, lambda: any(m.board_uid for m in heard), 15.0)
    return heard[-1]


def test_after_a_restart_the_files_mount_wins_and_every_part_is_listed_with_its_date(
        tmp_path, capfd):
    """Issue #47: the mount lasted only in the log, and direction and creep were not listed."""
    mount = SkinMount('base_link', (0.2, -0.1, 0.05), (0.0, 0.0, 0.5), 0.001, 6)
    direction = DirectionCorrection(True, 10.0, (0.0,) * DIRECTION_FEATURES,
                                    (0.0,) * DIRECTION_FEATURES, 12, 4, 9.0, 5.0)
    made = Calibration(x_p_m=1e-4, presses=8, part_utc=('2026-11-20T01:00:00Z',)).updated(
        direction=direction).updated(creep=CreepFit(0.0, 0.5)).updated(mount=mount)
    made.save_yaml(tmp_path / 'calibration.yaml')
    # The launch gives another mount: the calibrated one wins, and the log names both.
    with pipeline(tmp_path, scene([]), rate_hz=100.0,
                  direction={'parent_frame': 'left_forearm_link', 'mount_z': 0.05}) as (
            _, _, _, probe, executor):
        info = _described(executor, probe)
    assert (info.parent_frame, info.mount_source) == ('base_link', 'calibration')
    p = info.mount_pose.position
    assert (p.x, p.y, p.z) == pytest.approx((0.2, -0.1, 0.05))
    assert info.mount_pose.orientation.z == pytest.approx(math.sin(0.25))
    assert info.calibration_parts == ['offset', 'direction', 'creep', 'mount']
    assert info.calibration_parts_made == [made.made(part) for part in info.calibration_parts]
    assert info.calibration_parts_made[0] == '2026-11-20T01:00:00Z'
    assert all(info.calibration_parts_made)
    logged = capfd.readouterr().err
    assert (f"two mounts for this skin: {tmp_path / 'calibration.yaml'} has base_link at xyz "
            '(0.200, -0.100, 0.050) m') in logged
    assert 'parameters parent_frame and mount_* give left_forearm_link' in logged
    assert 'The calibrated mount wins and goes on /tf_static' in logged


def test_a_mount_given_by_parameters_is_the_one_in_force_without_a_calibrated_one(tmp_path):
    with pipeline(tmp_path, scene([]), rate_hz=100.0,
                  direction={'parent_frame': 'left_forearm_link', 'mount_z': 0.05,
                             'mount_pitch': 1.5}) as (_, _, direction, probe, executor):
        info = _described(executor, probe)
        assert (info.parent_frame, info.mount_source) == ('left_forearm_link', 'parameters')
        assert info.mount_pose.position.z == pytest.approx(0.05)
        assert info.mount_pose.orientation.y == pytest.approx(math.sin(0.75))
        # Set at run time, the given mount is the one in force at once.
        assert direction.set_parameters([Parameter('mount_z', value=0.07)])[0].successful
        heard = []
        probe.node.create_subscription(SkinInfo, '/skin_info', heard.append, LATCHED)
        assert spin_until(executor, lambda: heard and heard[-1].mount_pose.position.z == 0.07)
        assert heard[-1].parent_frame == 'left_forearm_link'


def test_the_board_health_is_shown_by_name_in_skin_info_and_on_diagnostics(tmp_path):
    # A board that was reset by its watchdog and dropped three scans to ADC overruns.
    board = BoardInfo.parse(
        'board=nucleo-f446re;uid=0039001e3438510b34313939;fw=0.1.0;grid=16x16;pitch_um=5000;'
        'rate_hz=100;reset=iwdg;clock=hse;drop=3;adc_ovr=3;adc_to=0;link_to=0;hse_lost=0')
    with pipeline(tmp_path, scene([]), rate_hz=100.0, identity=board) as (
            _, _, _, probe, executor):
        infos, links = [], []
        probe.node.create_subscription(SkinInfo, '/skin_info', infos.append, LATCHED)

        def on_diagnostics(msg):
            links.extend(s for s in msg.status if s.name.endswith('skin link') and any(
                v.key == 'board reset cause' for v in s.values))
        probe.node.create_subscription(DiagnosticArray, '/diagnostics', on_diagnostics, 10)
        assert spin_until(executor, lambda: any(m.board_faults for m in infos) and links, 15.0)
    info = [m for m in infos if m.board_faults][-1]
    assert info.board_reset_cause == 'iwdg: independent watchdog (the firmware hung)'
    assert 'ADC overruns: 3' in info.board_faults
    assert 'frames dropped by the board (a row failed to sample): 3' in info.board_faults
    values = {v.key: v.value for v in links[-1].values}
    assert values['board reset cause'] == 'iwdg: independent watchdog (the firmware hung)'
    assert values['board ADC overruns'] == '3'
    assert links[-1].level == b'\x01'
    assert 'the board was reset by its independent watchdog' in links[-1].message
