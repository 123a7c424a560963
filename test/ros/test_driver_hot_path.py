"""The driver's hot path: watched topics only, a refused real-time request, a slow estimator."""

import os

import numpy as np
from pipeline import pipeline, scene
import pytest
from rclpy.qos import qos_profile_sensor_data
from rosutil import spin_until
from sensor_msgs.msg import Image
from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.model.taxelmodel import TaxelModel
from skin_driver.core.protocol.realtime import NORMAL
from skin_driver.ros.conversions import status_values
from visualization_msgs.msg import MarkerArray

pytestmark = pytest.mark.ros

# Generous: only bounds a hung test on a loaded machine.
WAIT_S = 15.0
PRESS = [{'time_s': 0.0, 'duration_s': 1000.0}]
# A forward model of the taxels near the simulated skin's (any will do: it makes model_fit fit).
MODEL = TaxelModel(pitch_m=0.005, fill_factor=0.9, cover_spread_m=0.001, layer_spread_m=0.002,
                   film_scale=0.67, film_exponent=0.53, film_ceiling=3.3, film_activation_n=0.01)


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


def test_a_slow_estimator_takes_the_newest_scan_and_holds_up_no_read(tmp_path, owner_checked):
    # model_fit with a taxel model fits each contact in milliseconds: fused, at 500 scans a
    # second, the reader decodes on and the contacts come from the newest scans.
    path = tmp_path / 'calibration.yaml'
    Calibration(taxel_model=MODEL).save_yaml(path)
    with pipeline(tmp_path, scene(PRESS), rate_hz=500.0, fused=True,
                  direction={'method': 'model_fit', 'calibration_file': str(path)}) as (
            _, _, _, probe, executor):
        assert spin_until(executor, lambda: len(probe.record.received_s) > 20, WAIT_S)
        probe.statuses.clear()

        def estimation():
            status = probe.latest('contact estimation')
            return None if status is None else status_values(status)
        assert spin_until(executor, lambda: estimation() is not None, WAIT_S)
        values = estimation()
        assert int(values['frames left for newer ones (estimator slower than the scans)']) > 0
        assert int(values['bad frames']) == 0
        # The reader decodes on (this harness's board shares the process and its GIL, so a few
        # scans go missing whatever the estimator).
        link = _link_values(executor, probe)
        assert int(link['sequence gaps']) < int(link['frames']) / 4
        # Each message is a scan the estimation took up when it was the newest: no queue of
        # scans grows behind the fits (one would age them by seconds within this test).
        record = probe.record
        ages = np.subtract(record.received_s[-10:], record.stamp_s[-10:])
        assert ages.max() < 0.5
        assert record.contacts[-10:] == [1] * 10
