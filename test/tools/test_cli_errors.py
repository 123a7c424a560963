"""Every bad input of the evaluator and the simulator is one clear line, and creates nothing."""

import os
import subprocess
import sys

import pytest
from skin_driver.core.sim.scene import bundled_scene_names
from skin_driver.tools import sim
from skin_lab.evaluate import cli as evaluate


def _run(main, argv):
    """Return the exit status of a command line run in this process."""
    try:
        status = main(argv)
    except SystemExit as exit_:
        status = exit_.code
    return status


@pytest.mark.parametrize('argv, expected', [
    (['EMPTY'], 'the file is empty'),
    (['JUNK'], 'not a NumPy zip archive'),
    (['MISSING'], 'No such file or directory'),
    (['TMP'], 'Is a directory'),
    (['--generate', 'paper', 'TMP/nodir/x.npz'], 'directory TMP/nodir does not exist'),
    (['--generate', 'paper', 'TMP'], 'is a directory'),
    (['--skin', 'default', '--size', '0'], '--size: must be 1 or more'),
    (['--skin', 'default', '--noise-seed', '-1'], '--noise-seed: must be 0 or more'),
    (['--skin', 'default', '--size', '1', '--contacts', 'TMP/nodir/c.csv'],
     'directory TMP/nodir does not exist'),
    (['--generate', 'bogus', 'TMP/x.npz'], 'KIND must be one of'),
    (['--skin', 'nosuch'], "unknown skin 'nosuch'"),
])
def test_the_evaluator_refuses_bad_input_in_one_line_and_creates_nothing(
        tmp_path, capsys, argv, expected):
    (tmp_path / 'empty.npz').write_bytes(b'')
    (tmp_path / 'junk.npz').write_text('not numpy\n')
    names = {'EMPTY': 'empty.npz', 'JUNK': 'junk.npz', 'MISSING': 'missing.npz'}
    argv = [str(tmp_path / names[a]) if a in names else a.replace('TMP', str(tmp_path))
            for a in argv]
    before = sorted(tmp_path.rglob('*'))
    assert _run(evaluate.main, argv) == 2
    err = capsys.readouterr().err
    # One line says it (argparse puts its usage above).
    assert expected.replace('TMP', str(tmp_path)) in err.strip().splitlines()[-1]
    assert 'Traceback' not in err
    assert sorted(tmp_path.rglob('*')) == before


@pytest.mark.parametrize('argv, expected', [
    (['--scene', 'nosuch'], 'bundled scenes are ' + ', '.join(bundled_scene_names())),
    (['--export', 'TMP/nodir/x.npz'], 'directory TMP/nodir does not exist'),
    (['--export', 'TMP'], 'is a directory'),
    (['--link', 'TMP/nodir/skin0'], 'directory TMP/nodir does not exist'),
    (['--noise-seed', '-1'], '--noise-seed must be 0 or more'),
    (['--rate', '0'], 'rate_hz must be positive'),
    (['--duration', '-1'], '--duration must be a non-negative number'),
    (['--board-info', 'board=x;uid=0'], '--board-info: info text lacks fw, grid, pitch_um'),
])
def test_the_simulator_refuses_bad_input_in_one_line_and_creates_nothing(
        tmp_path, capsys, argv, expected):
    argv = [a.replace('TMP', str(tmp_path)) for a in argv] + ['--duration', '0'] * (
        '--duration' not in argv)
    before = sorted(tmp_path.rglob('*'))
    assert _run(sim.main, argv) == 2
    err = capsys.readouterr().err
    assert expected.replace('TMP', str(tmp_path)) in err
    assert 'Traceback' not in err and err.strip().count('\n') == 0
    assert sorted(tmp_path.rglob('*')) == before


def test_the_simulators_help_lists_its_scenes(capsys):
    assert _run(sim.main, ['--help']) == 0
    out = ' '.join(capsys.readouterr().out.split())
    assert ', '.join(bundled_scene_names()) in out and 'two_finger' in out


def test_the_evaluator_without_its_compiled_kernel_says_so_in_one_line(tmp_path):
    data = str(tmp_path / 'seed.npz')
    assert _run(evaluate.main, ['--generate', 'paper', data]) == 0
    out = subprocess.run([sys.executable, '-m', 'skin_lab.evaluate', data],
                         capture_output=True, text=True, timeout=60,
                         env={**os.environ, 'SKIN_KERNEL_LIBRARY': '/nonexistent/lib.so'})
    assert out.returncode == 2
    assert out.stderr.startswith('error: skin_kernel') and len(out.stderr.splitlines()) == 1
