"""The driver's hot path: viewers' topics only while watched, a refused real-time request."""

import os

from pipeline import pipeline, scene
import pytest
from rclpy.qos import qos_profile_sensor_data
from rosutil import spin_until
from sensor_msgs.msg import Image
from skin_driver.core.protocol.realtime import NORMAL
from skin_driver.ros.conversions import status_values
from visualization_msgs.msg import MarkerArray

pytestmark = pytest.mark.ros

# Generous: only bounds a hung test on a loaded machine.
WAIT_S = 15.0
PRESS = [{'time_s': 0.0, 'duration_s': 1000.0}]


def _link_values(executor, probe):
    probe.statuses.clear()
    assert spin_until(executor, lambda: probe.link_status() is not None, WAIT_S)
    return status_values(probe.link_status())


def test_raw_images_and_heatmaps_are_built_only_for_a_subscriber(tmp_path):
    with pipeline(tmp_path, scene(PRESS), direction={'viz_rate': 20.0}) as (
            _, _, _, probe, executor):
        assert spin_until(executor, lambda: len(probe.record.received_s) > 20, WAIT_S)
        # Nobody watches: the reader never hands an image over.
        assert float(_link_values(executor, probe)['reader CPU per scan, images [us]']) == 0.0
        images = {'top/image_raw': [], 'top/heatmap': [], 'markers': []}
        for topic, got in images.items():
            probe.node.create_subscription(MarkerArray if topic == 'markers' else Image, topic,
                                           got.append, qos_profile_sensor_data)
        assert spin_until(executor, lambda: all(len(got) >= 3 for got in images.values()),
                          WAIT_S)
        raw, heat = images['top/image_raw'][-1], images['top/heatmap'][-1]
        # The grid (one message, clearing the old markers first), then the press's arrow.
        kinds = [[m.ns for m in array.markers] for array in images['markers'][-2:]]
        assert ['skin', 'taxels'] in kinds and ['force', 'label'] in kinds
        assert (raw.encoding, raw.height, raw.width) == ('mono16', 16, 16)
        assert (heat.encoding, heat.height, heat.width) == ('rgb8', 16, 16)
        # No namespace: the skin's frame is skin_link.
        assert raw.header.frame_id == heat.header.frame_id == 'skin_link'


def test_a_refused_realtime_priority_reads_at_normal_priority_with_a_warning(
        tmp_path, monkeypatch, capfd):
    def refuse(pid, policy, param):
        raise PermissionError(1, 'Operation not permitted')
    monkeypatch.setattr(os, 'sched_setscheduler', refuse)
    with pipeline(tmp_path, scene([]), driver={'realtime_priority': 60}) as (
            _, driver, _, probe, executor):
        assert 'SCHED_FIFO 60 not permitted' in driver.link.scheduling.warning
        assert _link_values(executor, probe)['reader scheduling'] == NORMAL
        # Reading goes on at normal priority.
        assert spin_until(executor, lambda: probe.frame_count > 10, WAIT_S)
    assert 'serial reader: SCHED_FIFO 60 not permitted' in capfd.readouterr().err
