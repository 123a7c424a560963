"""The evaluator's presses of known direction (split 4): they calibrate the direction."""

import json

from skin_lab.evaluate.cli import main


def test_direction_presses_learn_the_direction_and_are_never_scored(capsys):
    # 12 presses, a few over the 10 the calibration needs: what is asserted is where they go,
    # not how well they teach; each one more lengthens the taxel model's learning.
    assert main(['--skin', 'default', '--scene', 'random', '--size', '30', '--no-oracle',
                 '--calibration-frames', '--direction-presses', '12', '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    notes = report['methods']['taxel_fit']['calibration_notes']
    # from the 40 presses, or from renders of the taxel model learned from them, judged on them
    assert any(n.startswith('direction: direction correction from ')
               and ('from 12 presses' in n or 'judged on 12 presses' in n) for n in notes)
    assert report['tilted_frames'] == 24  # the scored frames' tilted ones, none of split 4
    assert report['calibration_frames'] == 48 + 12


def test_direction_presses_without_calibration_frames_are_refused(capsys):
    assert main(['--skin', 'default', '--scene', 'random', '--size', '10', '--no-oracle',
                 '--direction-presses', '12']) == 2
    assert 'needs --calibration-frames' in capsys.readouterr().err
