"""The message definitions, the protocol document and the README say the same about the data."""

import pathlib
import re

from skin_driver.core.protocol import wire as protocol

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _comment_above(msg_text, field):
    """Return the comment lines right above a field's definition in a .msg file."""
    lines = msg_text.splitlines()
    at = next(i for i, line in enumerate(lines) if re.fullmatch(rf'\S+ {field}', line.strip()))
    comment = []
    for line in reversed(lines[:at]):
        if not line.startswith('#'):
            break
        comment.insert(0, line)
    return ' '.join(comment)


def test_skin_frame_device_time_is_described_as_the_protocol_defines_it():
    # The wire carries a 64-bit clock read at the start of the scan.
    assert protocol.HEADER.format.endswith('IQBB')
    assert 'at the start of the scan' in (ROOT / 'docs' / 'protocol.md').read_text()
    comment = _comment_above((ROOT / 'skin_msgs' / 'msg' / 'SkinFrame.msg').read_text(),
                             'device_time_us')
    assert 'start of the scan' in comment and '64 bits' in comment
    assert 'end of the scan' not in comment and '2^32' not in comment


def test_readme_does_not_promise_a_frame_id_on_diagnostics():
    readme = (ROOT / 'README.md').read_text()
    paragraph = next(p for p in readme.split('\n\n') if '`skin_link` by default' in p)
    assert '/diagnostics` cannot' in paragraph
