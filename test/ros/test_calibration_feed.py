"""A running calibration takes its scans on a worker thread, never on the scans' own."""

import threading

from skin_driver.ros import calibration_services
from skin_driver.ros.calibration_services import RunningCalibration

WAIT_S = 10.0


class _Session:
    """A session that records where and what it is given, and holds its first scan."""

    def __init__(self, wanted: int):
        self.given, self.threads = [], set()
        self.entered, self.release, self.all_given = (threading.Event(), threading.Event(),
                                                      threading.Event())
        self._wanted = wanted

    def add_scan(self, top, bottom, contacts, wrench) -> str:
        self.threads.add(threading.get_ident())
        self.entered.set()
        assert self.release.wait(WAIT_S)
        self.given.append(top)
        if len(self.given) == self._wanted:
            self.all_given.set()
        return f'scan {top}' if top == 3 else ''


def test_the_scans_go_to_a_worker_in_order_and_one_finding_the_queue_full_is_counted(
        monkeypatch):
    monkeypatch.setattr(calibration_services, 'MAX_WAITING_SCANS', 4)
    session = _Session(wanted=5)
    notes = []
    running = RunningCalibration(session, None, lambda r, note: notes.append(note))
    running.offer(0, None, [], None)
    assert session.entered.wait(WAIT_S)  # the worker holds scan 0: the queue is empty
    for scan in range(1, 10):
        running.offer(scan, None, [], None)  # never blocks: 1-4 wait, 5-9 find no room
    assert running.dropped == 5
    session.release.set()
    assert session.all_given.wait(WAIT_S)
    running.close()
    assert session.given == [0, 1, 2, 3, 4]
    assert notes == ['scan 3']
    assert session.threads and threading.get_ident() not in session.threads
    running.offer(10, None, [], None)  # closed: taken by nobody, and not a drop
    assert running.dropped == 5 and session.given == [0, 1, 2, 3, 4]
