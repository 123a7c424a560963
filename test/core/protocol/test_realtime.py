"""The reader's real-time request: granted, refused with a warning that says how, or not made."""

import os

from skin_driver.core.protocol.realtime import NORMAL, schedule_this_thread, StageCpu


class Recorder:
    """A stand-in for os.sched_setscheduler that records its calls and may refuse them."""

    def __init__(self, error=None):
        self.calls = []
        self.error = error

    def __call__(self, pid, policy, param):
        self.calls.append((pid, policy, param.sched_priority))
        if self.error is not None:
            raise self.error


def test_priority_zero_asks_for_nothing():
    setter = Recorder()
    assert schedule_this_thread(0, setter).policy == NORMAL
    assert setter.calls == []


def test_a_granted_priority_is_fifo_for_the_calling_thread_only():
    setter = Recorder()
    got = schedule_this_thread(50, setter)
    assert (got.policy, got.warning) == ('SCHED_FIFO 50', '')
    assert setter.calls == [(0, os.SCHED_FIFO, 50)]


def test_a_refused_priority_stays_normal_and_says_how_to_grant_it():
    got = schedule_this_thread(80, Recorder(PermissionError(1, 'Operation not permitted')))
    assert got.policy == NORMAL
    assert got.warning.startswith('SCHED_FIFO 80 not permitted (the rtprio limit is ')
    assert 'CAP_SYS_NICE' in got.warning and 'rtprio 98' in got.warning
    assert got.warning.endswith('reading at normal priority')


def test_another_refusal_carries_the_kernels_reason():
    got = schedule_this_thread(10, Recorder(OSError(22, 'Invalid argument')))
    assert got.policy == NORMAL
    assert 'Invalid argument' in got.warning and 'normal priority' in got.warning


def test_a_priority_outside_fifos_range_is_not_asked_for():
    setter = Recorder()
    got = schedule_this_thread(150, setter)
    assert setter.calls == [] and 'outside 1..99' in got.warning


def test_stage_cpu_reports_per_scan_means_of_the_sampled_passes_only():
    cpu = StageCpu(('work', 'rest'), every=2)
    for _ in range(4):  # passes 2 and 4 are measured, two scans each
        cpu.begin()
        sum(range(20000))
        cpu.mark('work')
        cpu.frames(2)
    means = cpu.take()
    assert set(means) == {'work', 'rest'}
    assert means['work'] > 0.0 and means['rest'] == 0.0
    assert cpu.take() == {'work': 0.0, 'rest': 0.0}
