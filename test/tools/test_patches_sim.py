"""The simulated patches of one scene: one board per patch, each where its driver looks."""

import os

from skin_driver.tools import patches_sim


def test_each_patch_gets_a_board_linked_under_its_name(tmp_path, capsys):
    assert patches_sim.main(['--scene', 'crossing', '--link-dir', str(tmp_path), '--duration',
                             '0.3', '--rate', '50']) == 0
    out, err = capsys.readouterr()
    ports = dict(line.split()[1:] for line in out.splitlines() if line.startswith('SKIN_PORT'))
    assert sorted(ports) == ['forearm_a', 'forearm_b', 'upper_arm']
    for patch, port in ports.items():
        assert port == str(tmp_path / patch / 'skin0')
    # Each board sent frames, and took its link away when it stopped.
    assert 'stopped after' in err and ' 0 frames' not in err
    assert not any(os.path.lexists(port) for port in ports.values())


def test_a_bad_scene_is_one_line_and_starts_no_board(tmp_path, capsys):
    assert patches_sim.main(['--scene', 'nosuch', '--link-dir', str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith('patches_sim: error: no patch scene file or bundled patch scene '
                              "named 'nosuch'")
    assert 'crossing' in err[-1]
    assert list(tmp_path.iterdir()) == []
