"""
Convert a rosbag2 bag of skin ``frame`` messages into an offline dataset; no ROS install needed.

Usage::

    bag_to_dataset BAG_DIR OUT.npz [--topic /skin/frame] [--tare-frames N]
                   [--azimuth-deg DEG --alpha-deg DEG --force-n N]

Reads sqlite3 and MCAP bags with rosbags (a pure-Python bag reader), in the order the messages
were recorded. The bag's own message definitions are used (rosbag2 stores them since Iron); an
older bag without them is read with skin_msgs/msg/SkinFrame.msg of this workspace or of a
sourced install. The board's identity (std_msgs/String board_info beside the frame topic, when
the bag holds it) stamps the dataset (``board_info``). Then evaluate it: ``python -m
skin_lab.evaluate OUT.npz``.
"""

import argparse
import os
import pathlib
import posixpath
import sys

from skin_driver.core.common.atomic import check_writable
from skin_driver.core.estimation.data.dataset import save_dataset
from skin_driver.core.estimation.data.recording import layers_of, Recording
from skin_driver.tools.recording_args import add_recording_arguments, labels_of

SKIN_FRAME = 'skin_msgs/msg/SkinFrame'
STRING = 'std_msgs/msg/String'


def _skin_frame_definition() -> str:
    """Return the text of SkinFrame.msg from this source tree or a ROS prefix, or ''."""
    candidates = [pathlib.Path(__file__).resolve().parents[2] / 'skin_msgs' / 'msg']
    candidates += [pathlib.Path(prefix) / 'share' / 'skin_msgs' / 'msg'
                   for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)
                   if prefix]
    for folder in candidates:
        path = folder / 'SkinFrame.msg'
        if path.is_file():
            return path.read_text()
    return ''


def _fallback_typestore():
    """Return Jazzy's types plus SkinFrame, for bags without embedded definitions."""
    from rosbags.typesys import get_types_from_msg, get_typestore, Stores
    store = get_typestore(Stores.ROS2_JAZZY)
    definition = _skin_frame_definition()
    if definition:
        store.register(get_types_from_msg(definition, SKIN_FRAME))
    return store


def read_bag(path, topic: str = None, tare_frames: int = 0) -> Recording:
    """Return the SkinFrame messages of ``topic`` (default: the only such topic) in ``path``."""
    from rosbags.highlevel import AnyReader, AnyReaderError
    path = pathlib.Path(path)
    if not path.exists():
        raise ValueError(f'{path}: no such bag (a rosbag2 directory or its .db3/.mcap file)')
    recording = Recording(tare_frames)
    try:
        with AnyReader([path], default_typestore=_fallback_typestore()) as reader:
            frames = [c for c in reader.connections if c.msgtype == SKIN_FRAME]
            if topic is not None:
                frames = [c for c in frames if c.topic == topic]
            topics = sorted({c.topic for c in frames})
            if len(topics) != 1:
                found = sorted({c.topic for c in reader.connections if c.msgtype == SKIN_FRAME})
                raise ValueError(
                    f'{path}: ' + (f'no {SKIN_FRAME} topic {topic!r}' if topic else
                                   f'{len(topics)} {SKIN_FRAME} topics') +
                    f'; it holds {", ".join(found) or "none"}' +
                    ('; choose one with --topic' if len(topics) > 1 else ''))
            chosen = [c for c in frames if c.topic == topics[0]]
            # The driver's board_info sits beside its frame topic.
            board_topic = posixpath.join(posixpath.dirname(topics[0]) or '/', 'board_info')
            chosen += [c for c in reader.connections
                       if c.topic == board_topic and c.msgtype == STRING]
            for connection, _, raw in reader.messages(connections=chosen):
                msg = reader.deserialize(raw, connection.msgtype)
                if connection.msgtype == STRING:
                    recording.set_board(msg.data)
                    continue
                recording.add(msg.pitch, *layers_of(msg.rows, msg.cols, msg.top, msg.bottom))
    except (AnyReaderError, OSError) as err:
        raise ValueError(f'{path}: cannot read as a rosbag2 bag: {err}') from None
    return recording


def main(argv=None) -> int:
    """Run the command line; return the exit status."""
    parser = argparse.ArgumentParser(prog='bag_to_dataset',
                                     description=__doc__.strip().split('\n')[0])
    parser.add_argument('bag', help='rosbag2 bag: its directory, or its .db3 or .mcap file')
    parser.add_argument('out', help='dataset .npz to write')
    parser.add_argument('--topic', default=None,
                        help='SkinFrame topic to read (default: the only one in the bag)')
    add_recording_arguments(parser)
    args = parser.parse_args(argv)
    try:
        check_writable(args.out)
        recording = read_bag(args.bag, args.topic, args.tare_frames)
        data = recording.dataset(labels_of(args))
        save_dataset(args.out, data)
    except (OSError, ValueError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 2
    board = recording.board
    print(f'wrote {data.frames} frames ({args.tare_frames} tare scans) to {args.out}; '
          + (f'board {board.board} uid {board.uid}' if board else 'no board identity'))
    return 0


if __name__ == '__main__':
    sys.exit(main())
