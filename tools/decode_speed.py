"""
Frames per second FrameDecoder takes, protocol version 1 beside version 2, 16 x 16 by default.

A stream of frames of random counts is fed as a driver's reads would bring it: one frame per
read (a read at 1 kHz), and 4 kB and 64 kB reads (a backlog; frames cross the reads' ends).
Each figure is frames over the thread's CPU time (time.thread_time), the best of alternating
rounds, so that other jobs on the machine slow every variant alike and waiting is not counted.
With ``--before REV`` the decoder of that git revision (core/protocol and core/common, taken
with ``git archive``) is measured in the same rounds, for a before/after in one run.

Run pinned to one core, e.g. ``taskset -c 1 tools/with-env.sh python tools/decode_speed.py
--before main``. The figures are only as quiet as the machine: state its load beside them.
"""

import argparse
import importlib
import os
import subprocess
import sys
import tarfile
import tempfile
import time

import numpy as np
from skin_driver.core.protocol import wire

READS = (('one frame', 0), ('4 kB', 4096), ('64 kB', 65536))


def stream(rows: int, cols: int, version: int, frames: int) -> bytes:
    """Return ``frames`` frames of random counts in protocol ``version``."""
    rng = np.random.default_rng(0)
    return b''.join(wire.encode_frame(i, 1000 * i, rng.integers(0, 4096, (rows, cols)),
                                      rng.integers(0, 4096, (rows, cols)), version=version)
                    for i in range(frames))


def decoder_of(rev: str, workdir: str):
    """Return the FrameDecoder class of git revision ``rev``, imported under another name."""
    root = subprocess.run(['git', 'rev-parse', '--show-toplevel'], check=True,
                          capture_output=True, text=True).stdout.strip()
    archive = os.path.join(workdir, 'before.tar')
    subprocess.run(['git', '-C', root, 'archive', '-o', archive, rev,
                    'skin_driver/core/protocol', 'skin_driver/core/common'], check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(workdir, filter='data')
    package = os.path.join(workdir, 'skin_driver_before')
    os.rename(os.path.join(workdir, 'skin_driver'), package)
    for path in (package, os.path.join(package, 'core')):
        open(os.path.join(path, '__init__.py'), 'a').close()
    sys.path.insert(0, workdir)
    return importlib.import_module('skin_driver_before.core.protocol.wire').FrameDecoder


def rate(decoder_class, reads: list, frames: int, shape: tuple) -> float:
    """Return frames per CPU second of one fresh decoder fed ``reads``."""
    decoder = decoder_class(expected_shape=shape)
    start = time.thread_time()
    got = 0
    for data in reads:
        got += len(decoder.feed(data))
    spent = time.thread_time() - start
    if got != frames:
        raise RuntimeError(f'decoded {got} frames of {frames}')
    return frames / spent


def main(argv=None) -> None:
    """Measure and print frames/s per decoder, version and read size."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--rows', type=int, default=16)
    parser.add_argument('--cols', type=int, default=16)
    parser.add_argument('--frames', type=int, default=2000, help='frames per round')
    parser.add_argument('--rounds', type=int, default=15)
    parser.add_argument('--before', metavar='REV', help='also measure the decoder of REV')
    args = parser.parse_args(argv)
    shape = (args.rows, args.cols)
    with tempfile.TemporaryDirectory() as workdir:
        decoders = {'now': wire.FrameDecoder}
        if args.before:
            decoders[args.before] = decoder_of(args.before, workdir)
        cases = []
        for version in (1, 2):
            data = stream(*shape, version, args.frames)
            size = wire.frame_size(*shape, version)
            for label, chunk in READS:
                chunk = chunk or size
                reads = [data[i:i + chunk] for i in range(0, len(data), chunk)]
                cases += [(name, version, label, reads) for name in decoders]
        best = {}
        for _ in range(args.rounds):
            for name, version, label, reads in cases:
                key = (name, version, label)
                best[key] = max(best.get(key, 0.0),
                                rate(decoders[name], reads, args.frames, shape))
    print(f'{args.rows} x {args.cols}, frames/s of thread CPU, best of {args.rounds} rounds '
          f'(load {os.getloadavg()[0]:.1f}):')
    for name in decoders:
        for version in (1, 2):
            print(f'  {name:>8} version {version}: ' + ', '.join(
                f'{label} {best[(name, version, label)]:,.0f}' for label, _ in READS))


if __name__ == '__main__':
    main()
