"""The simulated patches of one scene: one board per patch, each where its driver looks."""

import os

from skin_driver.core.sim.board import SIM_UID, sim_uid
from skin_driver.tools import patches_sim


def test_each_patch_gets_a_board_linked_under_its_name(tmp_path, capsys):
    assert patches_sim.main(['--scene', 'crossing', '--link-dir', str(tmp_path), '--duration',
                             '0.3', '--rate', '50']) == 0
    out, err = capsys.readouterr()
    ports = dict(line.split()[1:] for line in out.splitlines() if line.startswith('SKIN_PORT'))
    assert sorted(ports) == ['forearm_a', 'forearm_b', 'upper_arm']
    for patch, port in ports.items():
        assert port == str(tmp_path / patch / 'skin0')
    # Each board its own uid, the same at every run (issue #47: all shared one).
    uids = dict(line.split(': board sim uid ') for line in err.splitlines()
                if ': board sim uid ' in line)
    uids = {name.split(': ')[1]: uid for name, uid in uids.items()}
    assert sorted(uids) == sorted(ports)
    assert len(set(uids.values())) == 3 and SIM_UID not in uids.values()
    assert all(uid == sim_uid(patch) and len(uid) == 24 for patch, uid in uids.items())
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


def test_a_named_boards_uid_is_deterministic_and_its_own():
    assert sim_uid() == SIM_UID
    assert sim_uid('forearm_a') == sim_uid('forearm_a') != sim_uid('forearm_b')
    assert sim_uid('forearm_a').startswith('53494d')
