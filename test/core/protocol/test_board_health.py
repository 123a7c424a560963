"""The board's health from its information frame, by name: reset cause, fault, clock, counters."""

from types import SimpleNamespace

import numpy as np
import pytest
from skin_driver.core.common.boardhealth import BoardHealth
from skin_driver.core.protocol.health import LinkHealth, OK, WARN
from skin_driver.core.protocol.hold import RowHold
from skin_driver.core.protocol.link import CONNECTED, LinkStats
from skin_driver.core.protocol.wire import BoardInfo, encode_frame, encode_info, FrameDecoder

# The Nucleo's text as the firmware builds it (firmware/core/src/info.c), built for protocol
# version 1 (-DSKIN_FW_PROTOCOL=1: it counts dropped scans, 'drop'); V2_HEALTHY is the default
# image's (it counts frames sent with a row marked, 'flagged').
IDENTITY = ('board=nucleo-f446re;uid=0039001e3438510b34313939;fw=0.1.0;grid=16x16;'
            'pitch_um=5000;rate_hz=80')
HEALTHY = (f'{IDENTITY};reset=por;clock=hse;drop=0;adc_ovr=0;adc_to=0;link_to=0;hse_lost=0;'
           'mux=0')
V2_HEALTHY = (f"{IDENTITY.replace('rate_hz=80', 'rate_hz=100')};reset=por;clock=hse;flagged=0;"
              'adc_ovr=0;adc_to=0;link_to=0;hse_lost=0;mux=0')


def link_after(stream, decoder=None):
    decoder = decoder or FrameDecoder(expected_shape=(16, 16))
    hold = RowHold()
    hold.apply(decoder.feed(stream))
    return SimpleNamespace(stats=LinkStats(), decoder=decoder, state=CONNECTED, hold=hold)


def frames(first=0, count=2):
    counts = np.zeros((16, 16), np.uint16)
    return b''.join(encode_frame(s, 12500 * s, counts, counts)
                    for s in range(first, first + count))


def test_a_healthy_board_is_ok_and_says_so_by_name():
    health = LinkHealth((16, 16), 0.005).assess(link_after(encode_info(HEALTHY) + frames()), 'ok')
    assert health.level == OK and health.message == 'connected: ok'
    values = health.values
    assert values['board reset cause'] == 'por: power-on'
    assert values['board fault before the reset'] == 'none'
    assert values['board clock'] == 'hse: external 8 MHz (the ST-LINK MCO)'
    assert values['board frames dropped by the board (a row failed to sample)'] == '0'
    assert values['board ADC overruns'] == '0'
    assert values['board link timeouts (a transfer to the host did not end)'] == '0'
    # Named, not shown again under the raw key.
    assert 'board reset' not in values and 'board adc_ovr' not in values


def test_frames_the_board_dropped_are_told_from_line_noise():
    # A row overran on three scans: the board sent none of them and numbered the others on, so
    # the stream has no gap and no corrupt frame; the information frame names the cause.
    text = HEALTHY.replace('drop=0;adc_ovr=0', 'drop=3;adc_ovr=3')
    checker = LinkHealth((16, 16), 0.005)
    decoder = FrameDecoder(expected_shape=(16, 16))
    checker.assess(link_after(encode_info(HEALTHY) + frames(0, 2), decoder), 'ok')
    health = checker.assess(link_after(encode_info(text) + frames(2, 2), decoder), 'ok')
    assert health.level == WARN
    assert '3 frames dropped by the board (a row failed to sample)' in health.message
    assert '3 ADC overruns' in health.message
    assert 'line noise' not in health.message and 'sequence gaps' not in health.message
    assert health.values['crc errors'] == 0 and health.values['sequence gaps'] == 0
    # Once reported, the same counts are no news.
    again = checker.assess(link_after(encode_info(text) + frames(4, 2), decoder), 'ok')
    assert again.level == OK


def test_frames_a_version_2_board_flagged_are_named_with_its_fault_bits():
    # A row overran on three scans: the board sent them with the row marked (fault bit 0) and
    # counted them; the host names both the frames' word and the board's counters.
    counts = np.zeros((16, 16), np.uint16)
    valid = np.ones((2, 16), bool)
    valid[0, 5] = False
    clean = b''.join(encode_frame(s, 10000 * s, counts, counts, 2) for s in range(2))
    flagged = b''.join(encode_frame(s, 10000 * s, counts, counts, 2, faults=1, row_valid=valid)
                       for s in range(2, 5))
    text = V2_HEALTHY.replace('flagged=0;adc_ovr=0', 'flagged=3;adc_ovr=6')
    checker = LinkHealth((16, 16), 0.005)
    decoder = FrameDecoder(expected_shape=(16, 16))
    assert checker.assess(link_after(encode_info(V2_HEALTHY) + clean, decoder), 'ok').level == OK
    health = checker.assess(link_after(encode_info(text) + flagged, decoder), 'ok')
    assert health.level == WARN
    assert '3 frames sent with a row the board failed to sample marked' in health.message
    assert '6 ADC overruns' in health.message and '(row failed)' in health.message
    assert health.values['board frames sent with a row the board failed to sample marked'] == '3'
    assert 'line noise' not in health.message and health.values['sequence gaps'] == 0


@pytest.mark.parametrize('sent, named, value', [
    # reset by the watchdog: the firmware hung and came back
    (('reset=por', 'reset=iwdg'),
     'the board was reset by its independent watchdog (the firmware hung)',
     ('board reset cause', 'iwdg: independent watchdog (the firmware hung)')),
    # a fault exception recorded before a software reset
    (('reset=por', 'reset=sw;fault=busfault'), 'the board restarted after a bus fault',
     ('board fault before the reset', 'busfault: a bus fault')),
    # the HSE lost at run time: on the HSI since
    (('clock=hse;drop=0;adc_ovr=0;adc_to=0;link_to=0;hse_lost=0',
      'clock=hsi;drop=0;adc_ovr=0;adc_to=0;link_to=0;hse_lost=1'), '1 external clock failures',
     ('board clock', 'hsi: internal 16 MHz (the HSE was absent at start or failed since)')),
    # transfers to the host that did not end in their bound
    (('link_to=0', 'link_to=2'), '2 link timeouts (a transfer to the host did not end)',
     ('board link timeouts (a transfer to the host did not end)', '2')),
    # scans whose rows were all alike while pressed: the row mux stuck, not the line (counted as
    # mux only, in either version: drop stays 0)
    (('hse_lost=0;mux=0', 'hse_lost=0;mux=4'),
     '4 scans dropped by the board with every row of a layer alike while pressed '
     '(row mux stuck?)',
     ('board scans dropped by the board with every row of a layer alike while pressed '
      '(row mux stuck?)', '4')),
])
def test_each_fault_is_a_warning_that_names_it(sent, named, value):
    text = HEALTHY.replace(*sent)
    health = LinkHealth((16, 16)).assess(link_after(encode_info(text) + frames()), 'ok')
    assert health.level == WARN
    assert named in health.message
    assert health.values[value[0]] == value[1]


def test_a_board_that_restarted_counts_from_zero_again():
    before = BoardHealth.of(BoardInfo.parse(HEALTHY.replace('drop=0', 'drop=7')))
    after = BoardHealth.of(BoardInfo.parse(HEALTHY.replace('drop=0', 'drop=2')))
    assert after.problems(before) == ['2 frames dropped by the board (a row failed to sample)']


def test_values_the_host_does_not_know_are_shown_as_sent():
    text = f'{IDENTITY};reset=xyz;fault=brownout;drop=many'
    health = BoardHealth.of(BoardInfo.parse(text))
    values = health.values()
    assert values['board reset cause'] == 'xyz' and values['board clock'] == 'not sent'
    assert values['board fault before the reset'] == 'brownout'
    assert values['board frames dropped by the board (a row failed to sample)'] == 'many'
    assert health.problems(None) == ['the board restarted after brownout']


def test_a_board_without_health_keys_has_none():
    assert BoardHealth.of(BoardInfo.parse(IDENTITY)) is None
    assert BoardHealth.of(None) is None
    health = LinkHealth((16, 16)).assess(link_after(encode_info(IDENTITY) + frames()), 'ok')
    assert health.level == OK and 'board reset cause' not in health.values


def test_the_identity_leaves_the_health_out():
    info = BoardInfo.parse(HEALTHY.replace('drop=0', 'drop=5') + ';adc=3x12bit')
    assert info.identity == BoardInfo.parse(IDENTITY + ';adc=3x12bit')
    assert info.identity != info
    assert BoardInfo.parse(IDENTITY).identity == BoardInfo.parse(IDENTITY)


def test_skin_info_lines_name_each_counter():
    health = BoardHealth.of(BoardInfo.parse(HEALTHY.replace('adc_to=0', 'adc_to=4')))
    lines = health.named()
    assert 'reset cause: por: power-on' in lines
    assert 'ADC timeouts: 4' in lines
    assert 'clock: hse: external 8 MHz (the ST-LINK MCO)' in lines
