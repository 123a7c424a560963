"""
Several simulated patches from one patch scene: one board per patch, each on its own pty.

Run ``python -m skin_driver.tools.patches_sim --scene crossing`` (or ``ros2 run skin_driver
patches_sim``): every patch of the scene (:mod:`skin_driver.core.sim.patch_scene`) gets a board
that renders the scene's presses in that patch's frame, linked where the driver in the patch's
namespace looks by default (``$XDG_RUNTIME_DIR/skin_driver/<patch>/skin0``) or, with
``--link-dir DIR``, at ``DIR/<patch>/skin0``. Stdout has one ``SKIN_PORT <patch> <path>`` line
per patch; human messages go to stderr. Each board has its own unique ID, made from its
patch's name (the same at every run).
"""

import argparse
import math
import os
import sys

from skin_driver.core.common.atomic import check_writable
from skin_driver.core.protocol.link import default_port
from skin_driver.core.sim.board import sim_board_info, SimulatedSkin
from skin_driver.core.sim.patch_scene import bundled_patch_scene_names, load_patch_scene
from skin_driver.tools.sim import announce_epoch, stop_on_signal


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='patches_sim', description='Simulated skin patches of one scene, one pty each.')
    parser.add_argument('--scene', default='crossing',
                        help='bundled patch scene (' + ', '.join(bundled_patch_scene_names())
                             + ') or the path of a patch scene YAML file (default: crossing)')
    parser.add_argument('--rate', type=float, default=100.0,
                        help='frames per second of each board (100)')
    parser.add_argument('--link-dir', default=None,
                        help='link each board at DIR/<patch>/skin0 (default: where the driver '
                             "in the patch's namespace looks)")
    parser.add_argument('--duration', type=float, default=None,
                        help='stop after this many seconds (default: run until Ctrl-C)')
    parser.add_argument('--loop', action='store_true', help='replay the scene when it ends')
    parser.add_argument('--noise-seed', type=int, default=0, help='noise seed, 0 or more (0)')
    return parser


def link_path(patch: str, link_dir=None) -> str:
    """Return where the board of ``patch`` links its pty."""
    if link_dir:
        return os.path.join(link_dir, patch.replace('/', '_'), 'skin0')
    return default_port(patch)


def main(argv=None) -> int:
    """Run the boards from the command line; return the process exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if '--ros-args' in argv:  # launch may append them; a device has no use for them
        argv = argv[:argv.index('--ros-args')]
    args = _parser().parse_args(argv)
    boards = []
    try:
        if args.noise_seed < 0:
            raise ValueError(f'--noise-seed must be 0 or more, got {args.noise_seed}')
        if args.duration is not None and not (math.isfinite(args.duration)
                                              and args.duration >= 0):
            raise ValueError(f'--duration must be a non-negative number, got {args.duration}')
        scene = load_patch_scene(args.scene)
        for i, patch in enumerate(scene.patch_names):
            path = link_path(patch, args.link_dir)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            check_writable(path)
            # Each board its own noise and its own uid (from the patch's name: the same at
            # every run), as boards of several patches have.
            view = scene.view(patch)
            model = view.model
            identity = sim_board_info(model.rows, model.cols, model.pitch_m, args.rate, patch)
            boards.append((patch, SimulatedSkin(view, rate_hz=args.rate, link_path=path,
                                                noise_seed=args.noise_seed + 7 * i, loop=args.loop,
                                                identity=identity)))
        for patch, board in boards:
            print(f'SKIN_PORT {patch} {board.start()}', flush=True)
    except (ValueError, OSError) as err:
        for _, board in boards:
            board.stop()
        print(f'patches_sim: error: {err}', file=sys.stderr)
        return 2
    done = stop_on_signal()
    announce_epoch(boards[0][1].epoch_monotonic)
    print(f'patches_sim: scene {scene.name!r} ({scene.duration_s:.1f} s'
          f'{", looped" if args.loop else ""}), patches {", ".join(scene.patch_names)} at '
          f'{args.rate:g} Hz; Ctrl-C stops', file=sys.stderr)
    for patch, board in boards:
        print(f'patches_sim: {patch}: board {board.identity.board} uid {board.identity.uid}',
              file=sys.stderr)
    try:
        done.wait(args.duration)
    finally:
        for _, board in boards:
            board.stop()
    print('patches_sim: stopped after ' + ', '.join(
        f'{patch} {board.frames_sent} frames' for patch, board in boards), file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
