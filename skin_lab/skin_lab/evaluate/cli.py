"""
Evaluate direction estimators on an offline dataset and print the seed's Table 1.

Usage::

    python -m skin_lab.evaluate DATA.npz [--method NAME] [--params FILE] [--contacts OUT.csv]
                                         [--json]
    python -m skin_lab.evaluate --skin NAME [--scene KIND] [--size N] [--noise-seed N] [...]
    python -m skin_lab.evaluate --generate KIND OUT.npz [--skin NAME] [--size N] [--noise-seed N]
    python -m skin_lab.evaluate --skin NAME --scene hold|idle [--noise-seed N] [--json]
    python -m skin_lab.evaluate --list-skins | --list-methods

The single normal presses calibrate (x_p, y_p); every single tilted press's strongest contact is
compared with the ground-truth azimuth; frames with several presses are matched press by press
(docs/dataset.md). With a ``split`` array (dataset format 2) only the calibration frames
(split = 1, after the plate frames of split = 3, which give the taxel gains) calibrate, and more
fully: alpha = 0 frames with ``force_n`` give (x_p, y_p) and the force curves, tilted ones
with ``force_n`` the compliance; split = 2 frames (normal presses at the place of use) then
re-take (x_p, y_p); only split = 0 frames are scored.
``--calibration-frames`` adds such frames to a generated dataset (or to the --skin data). With
``--skin`` the oracle (:mod:`skin_lab.oracle`, the simulator's forward model fitted to each
frame, started at the truth) is scored beside the methods, and each method's error is given in
units of the oracle's (``--no-oracle`` skips it). ``--direction-presses N`` (with
``--calibration-frames``) adds N tilted presses of known direction (split = 4, a robot's
calibration run) that learn the direction's correction. ``--scene hold`` and ``--scene idle``
take the skin through simulated hours instead (:mod:`.drift`): |F| of a press held an hour, a
re-press, phantom contacts over 8 h unloaded, with and without following drift and correcting
creep. ROS-free.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from skin_driver.core.common.atomic import check_writable
from skin_driver.core.estimation.calibration.creep import CreepFit
from skin_driver.core.estimation.data.dataset import load_dataset, save_dataset
from skin_driver.core.estimation.scan.kernel import KernelMissing
from skin_driver.core.estimation.scan.pipeline import EstimatorConfig
from skin_driver.core.estimation.shift.methods import DEFAULT_METHOD, method_names, REFERENCES
from skin_driver.core.sim.skins import family_skin, GRID, HELD_OUT, skin_names
from skin_driver.ros.estimator_params import estimator_config, load_direction_parameters
from skin_lab.evaluate.drift import (calibrate_creep, format_drift, hold_report, idle_report,
                                     user_calibration)
from skin_lab.evaluate.scoring import evaluate
from skin_lab.evaluate.tables import format_table, json_safe, write_contacts
from skin_lab.experiments import calibrated_scene, make_scene, SCENE_KINDS

__all__ = ['main', 'DRIFT_SCENES']

DRIFT_SCENES = ('hold', 'idle')


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='python -m skin_lab.evaluate',
                                     description=__doc__.strip().split('\n')[0])
    parser.add_argument('data', nargs='?', help='dataset .npz to evaluate')
    parser.add_argument('--method', default=None, choices=method_names() + list(REFERENCES),
                        help=f"estimator (default: the --params file's, else {DEFAULT_METHOD})")
    parser.add_argument('--params', metavar='FILE',
                        help="the direction node's parameter file (config/skin.yaml format): "
                             'the estimator is configured as the node would be')
    parser.add_argument('--contacts', metavar='OUT.csv',
                        help="write every reported contact of every frame (the --method's)")
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('--skin', metavar='NAME',
                        help='generate the data from this skin of the family (see --list-skins; '
                             'held_out:N for random draw number N; NAME@N on an N x N '
                             'grid over the same patch)')
    parser.add_argument('--scene', default='paper', choices=SCENE_KINDS + DRIFT_SCENES,
                        help='scene kind rendered with --skin (default paper); hold and idle: '
                        'simulated hours of a held press and of an unloaded skin')
    parser.add_argument('--size', type=_count, default=None,
                        help='repeats (paper) or frames (other scenes) to render')
    parser.add_argument('--generate', nargs=2, metavar=('KIND', 'OUT'),
                        help=f'write a simulated dataset (KIND one of {", ".join(SCENE_KINDS)}) '
                             'of --skin (default: default) and exit')
    parser.add_argument('--noise-seed', type=_non_negative, default=0,
                        help='random seed for generated data (0 or more)')
    parser.add_argument('--calibration-frames', action='store_true',
                        help='with --generate or --skin: put 16 frames of a plate over the '
                        'skin (split = 3: the taxel gains), 16 normal presses over 5-60 N and '
                        '16 tilted presses of known load in front, as calibration frames '
                        '(split = 1); in the paper scene its normal presses at its spot '
                        're-take the offset (split = 2)')
    parser.add_argument('--direction-presses', type=_count, default=0, metavar='N',
                        help='with --calibration-frames: N tilted presses of known direction '
                        '(split = 4; 240 are a ten-minute robot run) learn the direction')
    parser.add_argument('--no-oracle', action='store_true',
                        help='with --skin: do not fit the oracle (the forward model, a few ms '
                        'to tens of ms per frame)')
    parser.add_argument('--list-skins', action='store_true', help='list the family and exit')
    parser.add_argument('--list-methods', action='store_true', help='list estimators and exit')
    return parser


def _count(text: str) -> int:
    """Return a whole number of at least 1 (argparse type)."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f'must be 1 or more, got {value}')
    return value


def _non_negative(text: str) -> int:
    """Return a whole number of at least 0 (argparse type)."""
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f'must be 0 or more, got {value}')
    return value


def _config(args) -> EstimatorConfig:
    """Return the estimator settings of --params (pitch set per dataset later) or None."""
    if not args.params:
        return None
    values = load_direction_parameters(args.params)
    config = estimator_config(values, EstimatorConfig().pitch_m)
    if args.method is None:
        args.method = config.method
    return config


def _scene(args, kind: str, skin: str, rng, truth_out: list = None):
    """Return the scene the arguments ask for, with its calibration frames when asked."""
    if not args.calibration_frames:
        if args.direction_presses:
            raise ValueError('--direction-presses needs --calibration-frames')
        return make_scene(kind, skin, rng, args.size, truth_out)
    return calibrated_scene(kind, skin, rng, args.size, truth_out,
                            direction_presses=args.direction_presses)


def main(argv=None) -> int:
    """Run the command line; return the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.list_skins:
        for name in skin_names():
            print(f'{name:12s} {family_skin(name).description}')
        print(f'{HELD_OUT + "N":12s} random draw number N of a skin within these ranges')
        print(f'{"NAME" + GRID + "N":12s} skin NAME with N x N taxels over the same patch')
        return 0
    if args.list_methods:
        print('\n'.join(method_names()))
        for name, reference in REFERENCES.items():
            print(f'{name} (reference: {reference.description})')
        return 0
    if args.skin:
        try:
            family_skin(args.skin)
        except ValueError as err:
            parser.error(str(err))
    rng = np.random.default_rng(args.noise_seed)
    if args.generate:
        kind, out = args.generate
        if kind not in SCENE_KINDS:
            parser.error(f'--generate KIND must be one of {", ".join(SCENE_KINDS)}, got {kind!r}')
        try:
            check_writable(out)
            data = _scene(args, kind, args.skin or 'default', rng)
            save_dataset(out, data)
        except (OSError, ValueError) as exc:
            print(f'error: {exc}', file=sys.stderr)
            return 2
        print(f'wrote {data.frames} frames to {out}')
        return 0
    if bool(args.data) == bool(args.skin):
        parser.error('give a dataset .npz or --skin NAME (not both)')
    if args.scene in DRIFT_SCENES:
        return _over_hours(args)
    try:
        if args.contacts:
            check_writable(args.contacts)
        config = _config(args)
        truth = None
        if args.skin:
            presses = []
            data = _scene(args, args.scene, args.skin, rng, presses)
            model = family_skin(args.skin).model
            scored = [presses[i] for i in data.scored_frames()]
            truth = None if args.no_oracle else (model, scored)
            source = f'skin {args.skin}, scene {args.scene}, noise seed {args.noise_seed}'
        else:
            data = load_dataset(args.data)
            source = args.data
    except (OSError, ValueError) as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    method = args.method or DEFAULT_METHOD
    runs = {}
    try:
        report = evaluate(data, method, config, runs, truth)
    except KernelMissing as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    if args.contacts:
        rows = write_contacts(args.contacts, runs[method], data.scored_frames())
        print(f'wrote {rows} contacts of {method} to {args.contacts}', file=sys.stderr)
    if args.json:
        print(json.dumps(json_safe({'dataset': source, **report})))
    else:
        print(source)
        print(format_table(report))
    return 0


def _over_hours(args) -> int:
    """Report the --skin's hold or idle scene (simulated hours); return the exit status."""
    try:
        config = _config(args)
        calibration = user_calibration(args.skin, args.noise_seed, config)
        if args.scene == 'hold':
            creep, error = calibrate_creep(args.skin, args.noise_seed, config, calibration)
            hold = hold_report(args.skin, args.noise_seed, config, creep, calibration)
            hold['calibration_error'] = error
            report = {'holds': [hold], 'idles': []}
        else:
            idle = idle_report(args.skin, args.noise_seed, config=config, calibration=calibration)
            report = {'holds': [], 'idles': [idle]}
    except KernelMissing as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    report['hours'] = 8.0
    if args.json:
        print(json.dumps(json_safe({'skin': args.skin, 'scene': args.scene, **report})))
        return 0
    print(f'skin {args.skin}, scene {args.scene}, noise seed {args.noise_seed}')
    table = format_drift(report).split('\n\n')
    print(table[0] if args.scene == 'hold' else table[1])
    if args.scene == 'hold':
        fit = report['holds'][0]['creep_fit']
        print(f'creep calibration: {CreepFit.from_dict(fit).describe()}' if fit else
              f"creep calibration refused: {report['holds'][0]['calibration_error']}")
    return 0


if __name__ == '__main__':
    sys.exit(main())
