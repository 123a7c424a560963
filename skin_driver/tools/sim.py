"""
The simulated skin from the command line: a board on a pty, or a scene rendered as a dataset.

Run ``python -m skin_driver.tools.sim --scene seed --rate 100 --link /tmp/skin`` and open the
printed port (or the link) like the real board.  The first stdout line is ``SKIN_PORT <path>``;
human messages go to stderr.  ``--export OUT.npz`` renders the scene offline into a dataset;
``--goals`` prints the calibration goals its labelled presses answer (:mod:`.scene_goals`).
The board itself is :mod:`skin_driver.core.sim.board`.
"""

import argparse
import math
import os
import signal
import sys
import threading
import time

from skin_driver.core.common.atomic import check_writable
from skin_driver.core.estimation.data.dataset import save_dataset
from skin_driver.core.protocol.link import default_port
from skin_driver.core.protocol.wire import BoardInfo
from skin_driver.core.sim.board import SIM, SimulatedSkin
from skin_driver.core.sim.scene import bundled_scene_names, load_scene
from skin_driver.tools.export import render_scene
from skin_driver.tools.scene_goals import scene_goals


# ---- command line ---------------------------------------------------------------------------

def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='sim', description='Simulated two-layer tactile skin on a pseudo-terminal.')
    parser.add_argument('--scene', default='seed',
                        help='bundled scene (' + ', '.join(bundled_scene_names()) +
                             ') or the path of a scene YAML file (default: seed)')
    parser.add_argument('--rate', type=float, default=100.0, help='frames per second (100)')
    parser.add_argument('--link', default=None,
                        help='make this path a symlink to the port (default: '
                             f'{default_port()}, where the driver looks by default)')
    parser.add_argument('--duration', type=float, default=None,
                        help='stop after this many seconds (default: run until Ctrl-C)')
    parser.add_argument('--loop', action='store_true', help='replay the scene when it ends')
    parser.add_argument('--replay', action='store_true',
                        help='with --loop: render one pass before starting and send those scans '
                             'again on every pass (next to no CPU per scan; a benchmark board)')
    parser.add_argument('--noise-seed', type=int, default=0, help='noise seed, 0 or more (0)')
    parser.add_argument('--protocol', type=int, choices=(1, 2), default=2,
                        help='wire protocol version of the frames (2; 1: unpacked counts, '
                             'docs/protocol.md)')
    parser.add_argument('--export', metavar='OUT.npz', default=None,
                        help='render the scene into a dataset file and exit, without a pty')
    parser.add_argument('--goals', action='store_true',
                        help="print the calibration goals the scene's labelled presses answer "
                             '(ros2 action send_goal commands, namespace /skin) and exit')
    parser.add_argument('--samples-per-press', type=int, default=1,
                        help='dataset samples per press with --export (1)')
    parser.add_argument('--board-info', default=SIM, metavar='TEXT',
                        help='who the board says it is (docs/protocol.md): "sim" (default, a '
                             'fake identity), "none" (a version-1 board) or an information text '
                             'such as "board=nucleo-f446re;uid=<24 hex>;fw=0.1.0;grid=16x16;'
                             'pitch_um=5000;rate_hz=100"')
    return parser


def stop_on_signal() -> threading.Event:
    """Return an event that SIGINT or SIGTERM sets: how a board tool is asked to stop."""
    done = threading.Event()

    def _on_signal(signum, frame):
        done.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _on_signal)
    return done


def announce_epoch(epoch_monotonic: float) -> None:
    """Print the wall-clock instant of device time 0 (SKIN_EPOCH) on stderr."""
    # So that a host can turn device stamps into latency.
    epoch = time.time() - (time.monotonic() - epoch_monotonic)
    print(f'SKIN_EPOCH {epoch:.6f}', file=sys.stderr, flush=True)


def main(argv=None) -> int:
    """Run the simulator from the command line; return the process exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    # `ros2 run` and launch may append ROS arguments; the simulated device has no use for them.
    if '--ros-args' in argv:
        argv = argv[:argv.index('--ros-args')]
    args = _parser().parse_args(argv)
    try:
        if args.noise_seed < 0:
            raise ValueError(f'--noise-seed must be 0 or more, got {args.noise_seed}')
        for path in (args.link, args.export):
            if path:
                check_writable(path)
        scene = load_scene(args.scene)
        if args.duration is not None and not (math.isfinite(args.duration)
                                              and args.duration >= 0):
            raise ValueError(f'--duration must be a non-negative number, got {args.duration}')
        identity = {SIM: SIM, 'none': None}.get(args.board_info)
        if args.board_info not in (SIM, 'none'):
            try:
                identity = BoardInfo.parse(args.board_info)
            except ValueError as err:
                raise ValueError(f'--board-info: {err}') from None
        if args.goals:
            for start_s, label, command in scene_goals(scene):
                print(f'# {label}: its first press at {start_s:g} s\n{command}')
            return 0
        if args.export:
            data = render_scene(scene, noise_seed=args.noise_seed,
                                samples_per_press=args.samples_per_press)
            save_dataset(args.export, data)
            n = data.frames
            print(f'sim: wrote {n} samples of scene {scene.name!r} to {args.export}',
                  file=sys.stderr)
            return 0
        if not args.link:
            # The default place is the simulator's own: its folder is made as needed.
            args.link = default_port()
            os.makedirs(os.path.dirname(args.link), exist_ok=True)
        skin = SimulatedSkin(scene, rate_hz=args.rate, link_path=args.link,
                             noise_seed=args.noise_seed,
                             loop=args.loop, replay=args.replay, identity=identity,
                             protocol=args.protocol)
        port = skin.start()
    except (ValueError, OSError) as err:
        print(f'sim: error: {err}', file=sys.stderr)
        return 2
    done = stop_on_signal()
    print(f'SKIN_PORT {port}', flush=True)
    announce_epoch(skin.epoch_monotonic)
    model = scene.model
    print(f'sim: scene {scene.name!r} ({scene.duration_s:.1f} s{", looped" if args.loop else ""}'
          f'{", drifting" if scene.drifts else ""}), {model.rows}x{model.cols} taxels at '
          f'{args.rate:g} Hz on {skin.port}'
          + (f' (link {port})' if args.link else '') + '; Ctrl-C stops', file=sys.stderr)
    try:
        done.wait(args.duration)
    finally:
        skin.stop()
    print(f'sim: stopped after {skin.frames_sent} frames sent, {skin.frames_dropped} dropped',
          file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
