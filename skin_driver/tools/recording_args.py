"""The command-line options shared by the two ways of recording a skin (live and from a bag)."""

import argparse
import math

from skin_driver.core.estimation.data.recording import Labels


def add_recording_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the tare and ground-truth options to ``parser``."""
    parser.add_argument('--tare-frames', type=int, default=0, metavar='N',
                        help='the first N scans (nothing on the skin) become the tare '
                             '(default 0: no tare)')
    parser.add_argument('--azimuth-deg', type=float, default=math.nan, metavar='DEG',
                        help='ground truth: the azimuth of the press every frame shows')
    parser.add_argument('--alpha-deg', type=float, default=0.0, metavar='DEG',
                        help='ground truth: its polar angle (default 0: normal or unknown)')
    parser.add_argument('--force-n', type=float, default=None, metavar='N',
                        help='ground truth: its total force in newtons')


def labels_of(args: argparse.Namespace) -> Labels:
    """Return the ground truth the options give."""
    return Labels(azimuth_deg=args.azimuth_deg, alpha_deg=args.alpha_deg, force_n=args.force_n)
