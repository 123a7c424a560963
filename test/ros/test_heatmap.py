"""
The published heatmaps as a person sees them: a light press fills the scale, seen from above.

The test draws the two heatmaps of one scan of a 2 N press into a PNG (in tmp_path) and reads
it back. With SKIN_UPDATE_FIGURES=1 it also writes docs/img/heatmap_press.png, the figure of
docs/robot.md: `SKIN_UPDATE_FIGURES=1 tools/with-env.sh python -m pytest test/ros/test_heatmap.py`.
"""

import os
from pathlib import Path
import shutil

import cv2
import numpy as np
from pipeline import pipeline, scene
import pytest
from rclpy.qos import qos_profile_sensor_data
from rosutil import spin_until
from sensor_msgs.msg import Image
from skin_driver.core.estimation.scan.heatmap import colour_map

pytestmark = pytest.mark.ros

WAIT_S = 15.0
FIGURE = Path(__file__).resolve().parents[2] / 'docs' / 'img' / 'heatmap_press.png'
# Pixels per taxel in the figure, and the gap between the layers.
ZOOM = 16
# A 2 N press straight down on taxel (row 11, column 11): x = y = 0.055 m, up and to the right
# of the skin's middle when the skin frame is seen from above.
PRESS = {'time_s': 0.0, 'x_m': 0.055, 'y_m': 0.055, 'force_n': 2.0, 'duration_s': 1000.0}
PALETTE = colour_map(np.arange(256, dtype=np.float64).reshape(1, -1), 255.0)[0].astype(int)


def levels(rgb: np.ndarray) -> np.ndarray:
    """Return each pixel's place on the colour scale (0..255): its nearest palette colour."""
    distance = ((rgb[..., None, :].astype(int) - PALETTE) ** 2).sum(axis=-1)
    return distance.argmin(axis=-1)


def as_rgb(image: Image) -> np.ndarray:
    return np.frombuffer(bytes(image.data), np.uint8).reshape(image.height, image.width, 3)


def write_figure(path: Path, top: np.ndarray, bottom: np.ndarray) -> None:
    """Write both layers side by side, each taxel ZOOM pixels wide, as a PNG."""
    zoomed = [np.kron(layer, np.ones((ZOOM, ZOOM, 1), np.uint8)) for layer in (top, bottom)]
    gap = np.full((zoomed[0].shape[0], ZOOM, 3), 255, np.uint8)
    rgb = np.concatenate([zoomed[0], gap, zoomed[1]], axis=1)
    assert cv2.imwrite(str(path), np.ascontiguousarray(rgb[..., ::-1]))


def test_a_2_n_press_fills_the_colour_scale_where_a_top_down_view_puts_it(tmp_path):
    got = {'top/heatmap': [], 'bottom/heatmap': []}
    with pipeline(tmp_path, scene([PRESS]), direction={'viz_rate': 20.0}) as (
            _, _, _, probe, executor):
        for topic, images in got.items():
            probe.node.create_subscription(Image, topic, images.append,
                                           qos_profile_sensor_data)

        def one_scan_of_each():
            tops = {m.header.stamp.sec * 10**9 + m.header.stamp.nanosec: m
                    for m in got['top/heatmap'][3:]}
            return [(tops[k], m) for m in got['bottom/heatmap']
                    if (k := m.header.stamp.sec * 10**9 + m.header.stamp.nanosec) in tops]
        assert spin_until(executor, lambda: one_scan_of_each(), WAIT_S)
    top, bottom = (as_rgb(m) for m in one_scan_of_each()[-1])
    path = tmp_path / 'heatmap_press.png'
    write_figure(path, top, bottom)
    seen = cv2.imread(str(path))[..., ::-1]
    assert seen.shape == (16 * ZOOM, 33 * ZOOM, 3)
    drawn = levels(seen[ZOOM // 2::ZOOM, ZOOM // 2:16 * ZOOM:ZOOM])
    np.testing.assert_array_equal(drawn, levels(top))
    # Row 0 is the largest y: taxel (row 11, column 11) is drawn in image row 4, column 11.
    assert np.unravel_index(drawn.argmax(), drawn.shape) == (4, 11)
    # A light press reaches the top of the scale (at 10 N a taxel it stayed at a tenth of it);
    # far from it the skin stays dark.
    assert drawn.max() >= 230
    assert (drawn[10:, :6] == 0).all()
    if os.environ.get('SKIN_UPDATE_FIGURES') == '1':
        shutil.copyfile(path, FIGURE)
