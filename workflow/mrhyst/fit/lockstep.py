"""Independent fits in lockstep: the kernel calls they make one by one, integrated as one batch.

The classic J-A kernel is latency-bound: a block of 16 lanes costs about twice one lane (measured on a 650-sample
path at 8 substeps: 1 set 1.24 ms, 6 sets 2.1 ms, 30 sets 4.3 ms), and an LSM step of a five-parameter fit asks
for 6 sets. Fits that do not depend on one another (the held-out folds of `--model auto`, :func:`mrhyst.fit.select.
heldout`) can share blocks: :func:`run_all` runs each in a thread of its own, and a kernel call of a thread
(:meth:`mrhyst.fit.problem.KernelMemo.simulate`) waits until every thread still running waits on one; those with
the same path, form, dman, variant and substep count are then integrated in one call. Each set is integrated in
its own lane whatever batch it sits in (ja_jit.py), so every fit gets the bytes it would get alone; only one
thread runs Python at a time (the GIL), so the threads cost no more CPU than the fits one after another.
"""

from __future__ import annotations

import threading

import numpy as np

_LOCAL = threading.local()


class _Lockstep:
    """The threads of one :func:`run_all` and the kernel calls they wait on."""

    def __init__(self, n: int):
        self.cv = threading.Condition()
        self.live = n
        self.waiting: list = []  # [tag, P, M0, run, result]

    def integrate(self, tag, P, M0, run):
        """``run(P, M0)``, with the calls of the other threads of the same ``tag`` (the kernel's whole input but
        the sets): (B (n, path), ok (n,)) of this call's sets."""
        req = [tag, P, M0, run, None]
        with self.cv:
            self.waiting.append(req)
            if len(self.waiting) >= self.live:
                self._flush()
            while req[4] is None:
                self.cv.wait()
        if isinstance(req[4], BaseException):
            raise req[4]
        return req[4]

    def leave(self) -> None:
        """A thread has ended: the others no longer wait for it."""
        with self.cv:
            self.live -= 1
            if self.waiting and len(self.waiting) >= self.live:
                self._flush()

    def _flush(self) -> None:
        """Every waiting call, one kernel call per tag (the first call's ``run`` on all their sets)."""
        groups: dict = {}
        for req in self.waiting:
            groups.setdefault(req[0], []).append(req)
        self.waiting = []
        try:
            for reqs in groups.values():
                B, ok = reqs[0][3](np.vstack([r[1] for r in reqs]), np.concatenate([r[2] for r in reqs]))
                i = 0
                for r in reqs:
                    n = r[1].shape[0]
                    r[4] = (B[i: i + n], ok[i: i + n])
                    i += n
        except BaseException as e:  # noqa: BLE001  (raised in every thread that waited on it)
            for reqs in groups.values():
                for r in reqs:
                    r[4] = e if r[4] is None else r[4]
        finally:
            self.cv.notify_all()


def integrate(tag, P, M0, run):
    """``run(P, M0)``: in a thread of :func:`run_all`, batched with the other threads' calls of the same ``tag``."""
    step = getattr(_LOCAL, "step", None)
    return run(P, M0) if step is None else step.integrate(tag, P, M0, run)


def run_all(fns: list) -> list:
    """[f() for f in fns], the fs run in lockstep (module doc); the first exception raised is raised again. Inside
    a thread of another run_all (or for fewer than two), one after another."""
    if len(fns) < 2 or getattr(_LOCAL, "step", None) is not None:
        return [f() for f in fns]
    step = _Lockstep(len(fns))
    out: list = [None] * len(fns)
    errors: list = [None] * len(fns)

    def work(i: int) -> None:
        _LOCAL.step = step
        try:
            out[i] = fns[i]()
        except BaseException as e:  # noqa: BLE001  (raised again in the caller's thread)
            errors[i] = e
        finally:
            _LOCAL.step = None
            step.leave()

    threads = [threading.Thread(target=work, args=(i,), daemon=True) for i in range(len(fns))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for e in errors:
        if e is not None:
            raise e
    return out
