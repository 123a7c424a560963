"""skin_info: a latched description of the skin, for a tool that finds the topic later."""

from diagnostic_msgs.msg import DiagnosticArray
from pipeline import pipeline, scene
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosutil import spin_until
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
    assert info.calibration_parts == [] and info.parent_frame == ''


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
