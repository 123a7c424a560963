"""
The bring-up kit end to end against the rehosted Nucleo board (skin_driver/tools/rehost).

The test is the person at the bench: it answers each prompt by pressing in the simulated scene
the chip samples (a scene of the same length swapped in, so that the scan index stays valid), and
"flashes" the next settle build by starting a new board on the same port path. The skin has one
dead taxel and is mounted mirrored (its x axis runs from column 15 to column 0), which the report
must find. Windows are a few seconds of device time; the board waits for its reader (``realtime``
off), so a busy host loses no frame and nothing depends on how fast the emulation runs.
"""

import json
import os

import numpy as np
import pytest

from skin_driver.core.estimation.data.dataset import load_dataset
from skin_driver.core.sim import physics
from skin_driver.core.sim.scene import load_scene
from skin_driver.tools.bringup.cli import main
from skin_driver.tools.rehost.board import RehostBoard
from skin_lab.evaluate import cli as evaluate

SCANS = 40           # each scene loops over this many scans (half a second at 80 scans/s)
DEAD = (4, 7)        # in the image the board sends


def _scene(presses=(), seed=0):
    """Return (top, bottom) of SCANS scans of the presses, as the mirrored, faulty skin shows."""
    model = load_scene('seed').model
    rng = np.random.default_rng(seed)
    top, bottom = (np.stack(layer) for layer in zip(
        *(physics.render(model, presses, rng) for _ in range(SCANS))))
    top, bottom = np.flip(top, axis=2).copy(), np.flip(bottom, axis=2).copy()
    top[:, DEAD[0], DEAD[1]] = 0
    return top, bottom


def _press(x_taxels, y_taxels):
    pitch = load_scene('seed').model.pitch_m
    return _scene((physics.Press(x_taxels * pitch, y_taxels * pitch, 10.0, radius_m=0.004),),
                  seed=1)


@pytest.mark.timeout(400)
def test_bringup_finds_the_boards_identity_faults_and_orientation(nucleo_image, tmp_path):
    link = str(tmp_path / 'skin0')
    scenes = {'origin': _press(0, 0), 'x_end': _press(15, 0), 'middle': _press(7, 7)}
    boards = [RehostBoard(nucleo_image, *_scene(), link, realtime=False)]
    asked = []

    def ask(step, text):
        asked.append(step)
        if step == 'flash':                  # the next build on the same port
            boards[-1].stop()
            boards.append(RehostBoard(nucleo_image, *_scene(), link, realtime=False))
            boards[-1].start()
        else:
            boards[-1].chip.scans = scenes[step]

    boards[0].start()
    out = tmp_path / 'report'
    try:
        status = main(['--port', link, '--out', str(out), '--seconds', '2',
                       '--press-seconds', '1', '--settle', '10', '5'], ask=ask)
    finally:
        boards[-1].stop()
    assert status == 0
    assert asked == ['origin', 'x_end', 'middle', 'flash', 'middle']
    assert all(b.failure is None and b.chip.errors == [] for b in boards)

    s = json.loads((out / 'summary.json').read_text())
    assert s['board'].startswith('board=nucleo-f446re;') and ';fw=0.1.0;' in s['board']
    assert s['shape'] == [16, 16]
    link_found = s['link']
    assert link_found['frames'] > 0 and link_found['device_s'] >= 2
    assert (link_found['crc_errors'], link_found['seq_gaps'], link_found['size_errors']) == (
        0, 0, 0)
    assert s['clock']['points'] >= 3
    assert s['faults']['top']['dead_taxels'] == [list(DEAD)]
    assert sum(len(v) for v in s['faults']['top'].values()) == 1
    assert sum(len(v) for v in s['faults']['bottom'].values()) == 0
    o = s['orientation']
    assert (o['transpose'], o['flip_rows'], o['flip_cols']) == (False, False, True)
    assert o['layers_agree'] is True
    # The models have no ghosting against settle time: both builds show the same spread.
    sweep = s['ghosting']
    assert [g['settle_us'] for g in sweep] == [10, 5]
    assert all((g['row'], g['col']) == (7, 8) for g in sweep)
    assert abs(sweep[0]['ghost'] - sweep[1]['ghost']) < 0.02
    assert all(abs(g['carry']) < 0.02 for g in sweep)

    report = (out / 'report.md').read_text()
    for image in ('noise.png', 'presses.png', 'ghosting.png'):
        assert f']({image})' in report and os.path.getsize(out / image) > 0
    data = load_dataset(out / 'dataset.npz')
    assert data.tare_top.shape[1:] == (16, 16) and len(data.tare_top) >= 2 * 80 * 0.9
    assert data.frames > 0 and data.board_info == s['board']
    assert evaluate.main([str(out / 'dataset.npz')]) == 0     # the evaluator scores it
