"""The link's health as the diagnostics show it: the board's identity and its disagreements."""

from types import SimpleNamespace

import numpy as np
from skin_driver.core.protocol.health import LinkHealth, NO_BOARD_IDENTITY, OK, WARN
from skin_driver.core.protocol.hold import RowHold
from skin_driver.core.protocol.link import CONNECTED, LinkStats
from skin_driver.core.protocol.wire import BoardInfo, encode_frame, encode_info, FrameDecoder

NUCLEO = BoardInfo('nucleo-f446re', '0039001e3438510b34313939', '0.1.0', 16, 16, 0.005, 1000,
                   (('adc', '3x12bit'),))


def link_after(stream, link=None):
    """Return a link (``link`` again if given) that has read stream."""
    if link is None:
        link = SimpleNamespace(stats=LinkStats(), decoder=FrameDecoder(max_rows=32, max_cols=32),
                               state=CONNECTED, hold=RowHold())
    link.hold.apply(link.decoder.feed(stream))
    return link


def frames(shape=(16, 16), count=2, version=1, first=0, **flags):
    counts = np.zeros(shape, np.uint16)
    return b''.join(encode_frame(s, 1000 * s, counts, counts, version, **flags)
                    for s in range(first, first + count))


def test_a_version_1_stream_says_it_has_no_identity_and_is_ok():
    health = LinkHealth((16, 16), 0.005).assess(link_after(frames()), 'reading')
    assert health.level == OK
    assert health.values['board'] == NO_BOARD_IDENTITY == 'no board identity (version-1 stream)'
    assert 'board uid' not in health.values
    assert health.values['board info frames'] == 0


def test_the_board_identity_is_in_the_values():
    health = LinkHealth((16, 16), 0.005).assess(link_after(encode_info(NUCLEO) + frames()),
                                                'reading')
    assert health.level == OK and health.message == 'connected: reading'
    values = health.values
    assert (values['board'], values['board uid'], values['board firmware']) == (
        'nucleo-f446re', '0039001e3438510b34313939', '0.1.0')
    assert (values['board grid'], values['board pitch [mm]'], values['board scan rate [Hz]']) == (
        '16x16', 5.0, 1000)
    assert values['board adc'] == '3x12bit'
    assert values['board info frames'] == 1 and values['board info errors'] == 0


def test_a_board_that_states_another_grid_than_its_frames_is_a_warning_while_it_does():
    health = LinkHealth((8, 8)).assess(link_after(encode_info(NUCLEO) + frames((8, 8))), 'ok')
    assert health.level == WARN
    assert 'board nucleo-f446re says its grid is 16x16, its frames are 8x8' in health.message
    # Not a one-off: the board says so at every assessment until it says otherwise.
    checker = LinkHealth((8, 8))
    link = link_after(encode_info(NUCLEO) + frames((8, 8)))
    checker.assess(link, 'ok')
    assert checker.assess(link, 'ok').level == WARN


def test_a_board_that_states_another_pitch_than_the_driver_is_a_warning():
    link = link_after(encode_info(NUCLEO) + frames())
    health = LinkHealth((16, 16), 0.004).assess(link, 'ok')
    assert health.level == WARN
    assert 'says its pitch is 5.000 mm, the driver is configured with 4.000 mm' in health.message
    assert LinkHealth((16, 16), 0.005).assess(link, 'ok').level == OK


def test_malformed_info_frames_are_a_warning_once():
    bad = encode_info(NUCLEO.text.replace('fw=0.1.0', 'fw=zero'))
    checker = LinkHealth((16, 16))
    link = link_after(frames() + bad)
    health = checker.assess(link, 'ok')
    assert health.level == WARN and '1 malformed board information frames' in health.message
    assert health.values['board info errors'] == 1
    assert checker.assess(link, 'ok').level == OK


def test_the_protocol_version_of_the_newest_frame_is_reported():
    checker = LinkHealth((16, 16))
    assert checker.assess(link_after(b''), 'ok').values['protocol version'] == 'no frame yet'
    link = link_after(frames(version=1))
    assert checker.assess(link, 'ok').values['protocol version'] == 1
    link = link_after(frames(version=2, first=2), link)
    health = checker.assess(link, 'ok')
    assert health.level == OK and health.values['protocol version'] == 2


def test_rows_not_sampled_and_board_faults_are_a_warning_for_the_assessment_they_arrived_in():
    checker = LinkHealth((16, 16))
    link = link_after(frames(version=2))
    assert checker.assess(link, 'ok').level == OK
    row_valid = np.ones((2, 16), bool)
    row_valid[1, 4] = False
    link = link_after(frames(version=2, first=2, count=3, faults=0b10001, row_valid=row_valid),
                      link)
    health = checker.assess(link, 'ok')
    assert health.level == WARN
    assert '3 frames with rows the board did not sample (held at their last valid counts)' \
        in health.message
    assert '3 frames with board faults (row failed, watchdog reset)' in health.message
    assert health.values['rows held at their last valid counts'] == 3
    assert health.values['board fault bits (newest frame)'] == 'row failed, watchdog reset'
    assert health.values['frames dropped, board-flagged (a row never sampled yet)'] == 0
    assert checker.assess(link, 'ok').level == OK
