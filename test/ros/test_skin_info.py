"""skin_info: a latched description of the skin, for a tool that finds the topic later."""

from pipeline import pipeline, scene
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosutil import spin_until
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
