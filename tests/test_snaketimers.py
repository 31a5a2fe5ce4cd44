"""mrhyst.snaketimers: one pending re-evaluation timer for Snakemake's scheduler (the workflow's onstart hook)."""

import inspect
import threading
import time

from mrhyst.snaketimers import one_reevaluation_timer


class _Scheduler:
    """The two members of Snakemake's JobScheduler the hook uses."""

    def __init__(self):
        self._open_jobs = threading.Semaphore(0)
        self.armed = 0

    def _schedule_reevalutation(self, delay):
        self.armed += 1


def _wakes(sem) -> int:
    n = 0
    while sem.acquire(blocking=False):
        n += 1
    return n


def test_many_arms_while_pending_wake_once_then_arm_again():
    s = _Scheduler()
    assert one_reevaluation_timer(s)
    for _ in range(5):  # five scheduler passes within the timespan: one timer
        s._schedule_reevalutation(0.05)
    assert s._open_jobs.acquire(timeout=10)  # it fires (waited for, not slept for: a loaded machine is slow)
    time.sleep(0.3)  # six times the timespan: a second timer would have fired by now
    assert _wakes(s._open_jobs) == 0
    assert s.armed == 0  # Snakemake's own timer method is no longer called
    s._schedule_reevalutation(0.05)  # the pass that timer woke arms the next
    assert s._open_jobs.acquire(timeout=10)


def test_pending_timer_is_a_daemon():
    s = _Scheduler()
    one_reevaluation_timer(s)
    s._schedule_reevalutation(5.0)
    timers = [t for t in threading.enumerate() if isinstance(t, threading.Timer) and t.is_alive()]
    assert timers and all(t.daemon for t in timers)
    for t in timers:
        t.cancel()


def test_an_object_without_the_members_is_left_alone():
    assert one_reevaluation_timer(None) is False
    assert one_reevaluation_timer(object()) is False


def test_the_installed_snakemake_has_both_members():
    """Where a Snakemake release renames them, the hook silently changes nothing: this test says so."""
    from snakemake.scheduling.job_scheduler import JobScheduler

    assert callable(getattr(JobScheduler, "_schedule_reevalutation", None))
    assert "self._open_jobs" in inspect.getsource(JobScheduler.__init__)
    src = inspect.getsource(JobScheduler._schedule_reevalutation)
    assert "_open_jobs.release" in src  # what the timer does: wake the scheduler, nothing else
