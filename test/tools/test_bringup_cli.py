"""
The bring-up command on a pty fed by the protocol's encoder: refusals, and a silent board.

A board that goes silent half-way keeps its idle findings in the report.

The board here is a thread writing frames (and its information frame once a second of device
time) with blocking writes, so it runs only as fast as the command reads: no timing is assumed.
"""

import io
import json
import os
import threading

import numpy as np
import pytest

from skin_driver.core.common.boardinfo import BoardInfo
from skin_driver.core.protocol.wire import encode_frame, encode_info
from skin_driver.tools.bringup import cli, reader

INFO = BoardInfo('bench-board', '0123456789abcdef01234567', '1.2.3', 4, 5, 0.004, 100)


class PtyBoard:
    """A 4 x 5 board, 100 scans a second of device time, on a pty; ``silent`` stops it."""

    def __init__(self):
        self.master, slave = os.openpty()
        self.port = os.ttyname(slave)
        self._slave = slave
        self.silent = threading.Event()
        self.done = threading.Event()
        self.rng = np.random.default_rng(3)
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        seq = 0
        try:
            while not self.done.is_set() and not self.silent.is_set():
                if seq % 100 == 0:                          # once a second, as boards do
                    os.write(self.master, encode_info(INFO))
                top = np.rint(300 + 4 * self.rng.standard_normal((4, 5))).astype(np.uint16)
                top[1, 2] = 0                               # a dead taxel
                os.write(self.master, encode_frame(seq, seq * 10_000, top, top.copy()))
                seq += 1
        except OSError:
            pass                                             # the test closed the pty

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.done.set()
        for fd in (self.master, self._slave):
            os.close(fd)
        self.thread.join(5)


def test_a_board_silent_after_the_idle_window_keeps_its_report(tmp_path, monkeypatch, capsys):
    # Nothing arrives once the board is silent: a short bound ends the wait for it.
    monkeypatch.setattr(reader, 'QUIET_S', 0.5)
    out = tmp_path / 'report'
    with PtyBoard() as board:
        status = cli.main(['--port', board.port, '--out', str(out), '--seconds', '1'],
                          ask=lambda step, text: board.silent.set())
    assert status == 1
    assert 'stopped early' in capsys.readouterr().err
    s = json.loads((out / 'summary.json').read_text())
    assert s['board'] == INFO.text and s['shape'] == [4, 5]
    assert s['faults']['top']['dead_taxels'] == [[1, 2]]
    assert s['faults']['bottom']['dead_taxels'] == [[1, 2]]
    assert s['link']['frames'] >= 100 and s['link']['crc_errors'] == 0
    assert s['stopped'].startswith('no frame from') and s['orientation'] is None
    assert 'Stopped early' in (out / 'report.md').read_text()
    assert (out / 'dataset.npz').exists()


def test_without_presses_nothing_is_asked(tmp_path):
    def ask(step, text):
        raise AssertionError(f'asked {step}')

    with PtyBoard() as board:
        status = cli.main(['--port', board.port, '--out', str(tmp_path), '--seconds', '0.5',
                           '--no-presses'], ask=ask)
    assert status == 0
    s = json.loads((tmp_path / 'summary.json').read_text())
    assert s['ghosting'] == [] and s['orientation'] is None
    assert s['noise']['top']['std_median'] == pytest.approx(4, rel=0.3)


@pytest.mark.parametrize('argv, expected', [
    (['--seconds', '0'], '--seconds and --press-seconds must be positive'),
    (['--settle', '10', '-1'], '--settle times must be 0 or more'),
    (['--out', 'FILE'], 'is a file; give a directory'),
])
def test_bad_options_are_refused_before_the_port_is_read(tmp_path, capsys, argv, expected):
    (tmp_path / 'file').write_text('keep me\n')
    argv = ['--port', str(tmp_path / 'no-such-port'), '--out', str(tmp_path / 'out')] + [
        str(tmp_path / 'file') if a == 'FILE' else a for a in argv]
    assert cli.main(argv) == 2
    assert expected in capsys.readouterr().err.strip().splitlines()[-1]
    assert (tmp_path / 'file').read_text() == 'keep me\n'
    assert not (tmp_path / 'out').exists()


def test_a_port_that_sends_nothing_is_named(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(reader, 'QUIET_S', 0.3)
    port = str(tmp_path / 'no-such-port')
    assert cli.main(['--port', port, '--out', str(tmp_path / 'out')]) == 2
    assert f'no frame from {port}' in capsys.readouterr().err


def test_prompts_answered_on_stdin_with_no_press_find_none(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr('sys.stdin', io.StringIO('\n' * 3))
    with PtyBoard() as board:
        status = cli.main(['--port', board.port, '--out', str(tmp_path), '--seconds', '0.5',
                           '--press-seconds', '0.2'])
    assert status == 0
    prompts = [line for line in capsys.readouterr().out.splitlines() if '[' in line]
    assert [p.split('[')[1].split(']')[0] for p in prompts] == ['origin', 'x_end', 'middle']
    s = json.loads((tmp_path / 'summary.json').read_text())
    assert s['orientation']['text'].startswith('undetermined: no press seen')
    assert s['ghosting'][0]['error'].startswith('no press seen')


def test_stdin_ending_before_an_answer_stops_with_the_idle_report(tmp_path, monkeypatch):
    monkeypatch.setattr('sys.stdin', io.StringIO(''))
    with PtyBoard() as board:
        status = cli.main(['--port', board.port, '--out', str(tmp_path), '--seconds', '0.5'])
    assert status == 1
    s = json.loads((tmp_path / 'summary.json').read_text())
    assert s['stopped'] == "stdin ended before the 'origin' prompt was answered"
