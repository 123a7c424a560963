"""
Protocol version 2 end to end at 1 kHz: simulated board -> pty -> driver -> estimator.

Fused and split on version 2, and fused on version 1: every scan the board wrote into the pty
is decoded (a missing sequence number is one the board itself could not write, counted by it),
every decoded scan reaches the estimator, and the driver says which version it reads.
No timing is asserted here: latency is the benchmark's (docs/benchmarks.md).
"""

from pipeline import pipeline, scene
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosutil import spin_until
from skin_driver.ros.conversions import status_values
from skin_msgs.msg import SkinInfo

pytestmark = pytest.mark.ros

RATE_HZ = 1000.0
SCANS = 2000
# Generous: only bounds a hung test on a loaded machine.
WAIT_S = 60.0
PRESS = [{'time_s': 0.2, 'duration_s': 1000.0}]
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)


@pytest.mark.parametrize('fused, protocol', [(True, 2), (False, 2), (True, 1)],
                         ids=['fused-v2', 'split-v2', 'fused-v1'])
def test_1_khz_loses_no_scan_between_the_pty_and_the_estimator(tmp_path, fused, protocol):
    with pipeline(tmp_path, scene(PRESS), rate_hz=RATE_HZ, fused=fused, protocol=protocol) as (
            sim, driver, direction, probe, executor):
        infos = []
        probe.node.create_subscription(SkinInfo, '/skin_info', infos.append, LATCHED)
        link = driver.link
        dec = link.decoder.stats
        assert spin_until(executor, lambda: dec.frames >= SCANS, WAIT_S), dec
        missed = dec.frames_missed
        # Read after the gaps: the board's count only grows.
        assert missed <= sim.frames_dropped, 'a scan written into the pty was never decoded'
        assert (dec.crc_errors, dec.version_errors, dec.size_errors) == (0, 0, 0)
        assert link.decoder.last_version == protocol
        sim.stop()
        host = direction.host
        if fused:
            # Every scan the reader handed over was estimated, or counted as not.
            assert spin_until(executor, lambda: link.stats.frames == sum(host.tally()[:4]),
                              WAIT_S), (link.stats.frames, host.tally())
        tally = host.tally()
        assert tally.refused == 0 and tally.contacts > 0
        assert spin_until(executor, lambda: probe.link_status() is not None
                          and status_values(probe.link_status())['protocol version']
                          == str(protocol), WAIT_S)
        # A separate estimator is not told the version (the driver's diagnostics say it).
        want = protocol if fused else 0
        assert spin_until(executor, lambda: infos and infos[-1].protocol_version == want,
                          WAIT_S), [i.protocol_version for i in infos]
    print(f'\n{"fused" if fused else "split"} v{protocol}: {dec.frames} scans decoded, '
          f'{missed} not sent by the board (it never blocks: queue full or lagging), '
          f'{tally.left_for_newer} left for newer')
