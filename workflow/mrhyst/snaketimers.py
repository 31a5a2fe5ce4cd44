"""One pending re-evaluation timer for Snakemake's job scheduler (the workflow's ``onstart`` hook, common.smk).

Snakemake 9's job-rate limiter (``--max-jobs-per-timespan``, default 100/1s) arms a timer at the end of every
scheduler pass that wakes the scheduler once more after the timespan, and a pass that such a timer wakes arms the
next. So every job that finishes while others wait for a core starts one more chain of timers that runs to the end
of the run. Each pass reads the size of every input of every ready job (a blind block has 200), so in a fresh
build of this workflow (3 min 31 s, 83 jobs, this 2-core machine) the main process made ~4,500 passes and spent
19 s of CPU on them, beside the jobs on their two cores (bench/README.md, "Eleventh session").

:func:`one_reevaluation_timer` keeps one timer pending at a time. The scheduler is then woken at least as often as
the limiter needs (the pending timer fires within the timespan and the pass it wakes arms the next), and a job
that finishes wakes it at once, as before. The timer is a daemon thread, so the run exits without waiting for it.
It touches two members of Snakemake's JobScheduler; where they are missing (another Snakemake) it changes nothing
(tests/test_snaketimers.py checks the installed Snakemake has them). No Snakemake import here.
"""

from __future__ import annotations

import threading


def one_reevaluation_timer(scheduler) -> bool:
    """Replace ``scheduler``'s re-evaluation timers by one pending timer at a time; False where it cannot."""
    wake = getattr(scheduler, "_open_jobs", None)
    if wake is None or not callable(getattr(scheduler, "_schedule_reevalutation", None)):
        return False
    lock = threading.Lock()
    pending = [False]

    def fire() -> None:
        with lock:
            pending[0] = False
        wake.release()

    def arm(delay) -> None:
        with lock:
            if pending[0]:
                return
            pending[0] = True
        timer = threading.Timer(delay, fire)
        timer.daemon = True
        timer.start()

    scheduler._schedule_reevalutation = arm
    return True
