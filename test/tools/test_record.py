"""ros2 run skin_driver record: live frames of a running driver into a dataset."""

import numpy as np
from pipeline import overrides, scene
import pytest
from rosutil import ros_context, spin_until
from skin_driver.core.estimation.data.dataset import load_dataset
from skin_driver.core.sim.board import SimulatedSkin
from skin_driver.ros.driver_node import SkinDriverNode
from skin_driver.tools.harness import spawn, stop


@pytest.mark.ros
def test_record_writes_the_live_frames_and_their_tare_as_a_dataset(tmp_path):
    link = str(tmp_path / 'skin0')
    out = tmp_path / 'live.npz'
    # Pressed from 0.3 s on, for as long as the recorder may take to start.
    the_scene = scene([{'time_s': 0.3, 'alpha_deg': 45.0, 'beta_deg': 90.0,
                        'duration_s': 120.0}])
    sim = SimulatedSkin(the_scene, rate_hz=100.0, link_path=link, noise_seed=1)
    with ros_context() as (context, executor):
        driver = SkinDriverNode(context=context, parameter_overrides=overrides({'port': link}))
        executor.add_node(driver)
        sim.start()
        with open(tmp_path / 'record.log', 'w') as log:
            recorder = spawn(['-m', 'skin_driver.tools.record', str(out), '--topic', '/frame',
                              '--scans', '60', '--tare-frames', '10'], log)
        try:
            driver.trigger_configure()
            driver.trigger_activate()
            assert spin_until(executor, lambda: recorder.poll() is not None, 60.0), \
                (tmp_path / 'record.log').read_text()
        finally:
            stop([recorder])
            driver.close()
            driver.destroy_node()
            sim.stop()
    assert recorder.returncode == 0, (tmp_path / 'record.log').read_text()
    data = load_dataset(out)
    assert data.frames == 50 and data.tare_top.shape == (10, 16, 16)
    # Unlabelled: a recording has no ground truth of its own.
    assert np.isnan(data.azimuth_deg).all() and (data.alpha_deg == 0).all()
    # The press is in the recording: the scans are the skin's, not empty maps.
    assert data.top.max() > 1000
    # Stamped with the board that said who it is (the simulated board's fake identity).
    assert data.board() == sim.identity
