"""
``python -m skin_driver.tools.bringup --port /dev/ttyACM0 --out DIR``: check a new board once.

Reads the board's stream with the driver's link and decoder (no ROS), asks the person for a few
presses on stdin, and writes DIR/report.md with its heatmaps, DIR/summary.json and
DIR/dataset.npz (docs/dataset.md). docs/firmware.md, "Bringing up a new board", says what each
check means.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from . import analysis
from .reader import BoardReader, link_quality
from .report import write_report

PROMPTS = {
    'origin': 'Press and hold the corner at the skin origin (x = 0, y = 0: bottom left, seen '
              'from the cover with x right and y up), then press Enter.',
    'x_end': 'Release it. Press and hold the corner along +x (bottom right), then press Enter.',
    'flash': 'Release it. Flash the image built with SKIN_BOARD_SETTLE_US = {us} (skin_board_'
             'pins.h, make flash), plug it in again, then press Enter.',
    'middle': 'Release it. Press and hold one taxel near the middle of the skin (settle time '
              '{us}), then press Enter.',
}


def ask_stdin(step: str, text: str) -> None:
    """Print the prompt and wait for a line on stdin (a piped file answers as well)."""
    print(f'bringup [{step}]: {text}', flush=True)
    if not sys.stdin.readline():
        raise RuntimeError(f'stdin ended before the {step!r} prompt was answered')


def _layers(frames) -> tuple:
    return (np.stack([f.top for f in frames]), np.stack([f.bottom for f in frames]))


def _pressed(reader: BoardReader, seconds: float):
    """Return a press window's frames, the first quarter dropped (the hand still settling)."""
    frames = reader.window(seconds)
    return frames[len(frames) // 4:]


def bring_up(port: str, seconds: float = 60.0, press_seconds: float = 2.0, settle=(),
             presses: bool = True, ask=ask_stdin, baud: int = 921600) -> dict:
    """Run every check on the board at port; return the findings and the frames they used."""
    reader = BoardReader(port, baud)
    reader.start()
    try:
        reader.window(0)                     # the first frame: the board is there
        before = reader.counters()
        idle = reader.window(seconds)
        after = reader.counters()
        clock = [(d, h) for d, h in reader.clock if idle[0].device_time_us <= d]
        found = {
            'port': port, 'info': reader.decoder.board_info,
            'shape': idle[0].top.shape, 'idle': idle,
            'link': link_quality(before, after, idle),
            'clock': analysis.clock_ppm(*zip(*clock)) if len(clock) >= 3 else None,
            'noise': {}, 'faults': {}, 'presses': [], 'orientation': None, 'ghosting': [],
            'stopped': None,
        }
        for name, stack in zip(('top', 'bottom'), _layers(idle)):
            found['noise'][name] = analysis.noise(stack)
            found['faults'][name] = analysis.faults(stack)
        if presses:
            try:
                _orientation(reader, found, press_seconds, ask)
                reader = _sweep(reader, found, press_seconds, settle, ask)
            except RuntimeError as err:
                # What the idle window found is kept: the report says where it stopped.
                found['stopped'] = str(err)
    finally:
        reader.stop()
    return found


def _orientation(reader, found, press_seconds, ask) -> None:
    layers = {}
    for step in ('origin', 'x_end'):
        ask(step, PROMPTS[step])
        frames = _pressed(reader, press_seconds)
        found['presses'].append((step, frames))
        layers[step] = _layers(frames)
    result = {}
    for i, name in enumerate(('top', 'bottom')):
        try:
            peaks = [analysis.press_peak(found['noise'][name], layers[step][i])
                     for step in ('origin', 'x_end')]
            result[name] = analysis.orientation(*peaks, found['shape'])
        except ValueError as err:
            result[name] = {'ok': False, 'text': f'undetermined: {err}'}
    # The top layer's is the finding; a bottom layer wired otherwise is a finding too.
    found['orientation'] = {**result['top'], 'bottom': result['bottom']['text'],
                            'layers_agree': result['top'] == result['bottom']}


def _sweep(reader, found, press_seconds, settle, ask):
    idle_mean = found['noise']['top']['mean']
    for i, us in enumerate(settle or ['as built']):
        if i:
            reader.stop()
            ask('flash', PROMPTS['flash'].format(us=us))
            reader = BoardReader(reader.port, reader.baud)
            reader.start()
            reader.window(0)
        ask('middle', PROMPTS['middle'].format(us=us))
        frames = _pressed(reader, press_seconds)
        label = f'middle, {us}' if isinstance(us, str) else f'middle, {us:g} us'
        found['presses'].append((label, frames))
        try:
            analysis.press_peak(found['noise']['top'], _layers(frames)[0])
            ghost = analysis.ghost_fraction(idle_mean, _layers(frames)[0])
        except ValueError as err:
            ghost = {'error': str(err)}
        found['ghosting'].append({'settle_us': us, **ghost})
    return reader


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='bringup', description='Check a new board once: identity, clock, link, idle noise, '
        'dead/stuck/shorted lines, orientation, settle time (docs/firmware.md).')
    parser.add_argument('--port', required=True, help="the board's serial port")
    parser.add_argument('--out', required=True, help='directory for the report')
    parser.add_argument('--seconds', type=float, default=60.0,
                        help='idle window in device seconds: noise, faults, clock, link (60)')
    parser.add_argument('--press-seconds', type=float, default=2.0,
                        help='device seconds each held press is read (2)')
    parser.add_argument('--settle', type=float, nargs='+', default=(), metavar='US',
                        help='settle times of the builds to sweep, the one flashed now first '
                             '(the firmware takes it at build time only)')
    parser.add_argument('--no-presses', action='store_true',
                        help='skip the prompts: no orientation, no ghosting')
    parser.add_argument('--baud', type=int, default=921600, help='(ptys and USB CDC ignore it)')
    return parser


def main(argv=None, ask=ask_stdin) -> int:
    """Check the board, write the report; return the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if '--ros-args' in argv:
        argv = argv[:argv.index('--ros-args')]
    args = _parser().parse_args(argv)
    try:
        if args.seconds <= 0 or args.press_seconds <= 0:
            raise ValueError('--seconds and --press-seconds must be positive')
        if any(us < 0 for us in args.settle):
            raise ValueError('--settle times must be 0 or more microseconds')
        if os.path.exists(args.out) and not os.path.isdir(args.out):
            raise ValueError(f'--out {args.out} is a file; give a directory')
        os.makedirs(args.out, exist_ok=True)     # before the board is read, not after
        found = bring_up(args.port, args.seconds, args.press_seconds, tuple(args.settle),
                         not args.no_presses, ask, args.baud)
        path = write_report(args.out, found)
    except (ValueError, RuntimeError, OSError) as err:
        print(f'bringup: error: {err}', file=sys.stderr)
        return 2
    if found['stopped']:
        print(f'bringup: stopped early ({found["stopped"]}); what was found is in {path}',
              file=sys.stderr)
        return 1
    print(f'bringup: report in {path}')
    return 0
