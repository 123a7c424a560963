"""Tests of the simulated skin on a real pseudo-terminal, read with pyserial and the decoder."""

import os
import signal
import subprocess
import sys

import numpy as np
from port_reader import DEADLINE_S, Reader

from skin_driver.core.estimation.data.dataset import load_dataset
from skin_driver.core.sim.paper import paper_presses
from skin_driver.core.sim.scene import load_scene
from skin_driver.core.sim.skins import get_skin
from skin_driver.tools.export import render_scene, TARE_FRAMES
from skin_driver.tools.sim import main


def test_render_scene_samples_every_press_of_the_seed_scene_at_full_force():
    data = render_scene(load_scene('seed'), noise_seed=1)
    n = 9 * 5
    assert data.top.shape == data.bottom.shape == (n, 16, 16)
    assert data.top.dtype == np.uint16 and data.pitch_m == 0.005
    normal = data.alpha_deg == 0
    assert normal.sum() == 5 and np.isnan(data.azimuth_deg[normal]).all()
    assert sorted(set(data.azimuth_deg[~normal])) == list(range(0, 360, 45))
    spot = paper_presses(get_skin('default'))[0]
    assert (data.force_n == 10.0).all() and (data.x_m == spot.x_m).all()
    assert data.tare_top.shape == (TARE_FRAMES, 16, 16)
    # Every sample is taken at full force: the press is plainly visible on the top layer.
    assert (data.top.reshape(n, -1).max(axis=1) > 1000).all()
    assert data.tare_top.max() < 200


def test_cli_export_writes_a_dataset_the_evaluator_loads(tmp_path, capsys):
    out = tmp_path / 'border.npz'
    assert main(['--scene', 'border', '--export', str(out), '--samples-per-press', '2']) == 0
    data = load_dataset(out)
    assert data.frames == 16 and data.shape == (16, 16)
    assert data.alpha_deg[0] == 0 and np.isnan(data.azimuth_deg[0])
    assert main(['--scene', 'nope']) == 2
    assert 'no scene file' in capsys.readouterr().err


def test_cli_streams_on_a_pty_and_stops_cleanly_on_sigterm(tmp_path):
    link = str(tmp_path / 'skin')
    proc = subprocess.Popen([sys.executable, '-m', 'skin_driver.tools.sim', '--rate', '200',
                             '--link', link, '--scene', 'seed', '--loop'],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = proc.stdout.readline().split()
        assert first == ['SKIN_PORT', link]
        reader = Reader(link)
        reader.read_frames(5)
        reader.close()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=DEADLINE_S) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert 'stopped after' in proc.stderr.read()
    assert not os.path.lexists(link)
