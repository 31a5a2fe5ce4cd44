"""The build's warm-up (rule warmup, mrhyst.warmup): what each group compiles into an empty numba cache, and how long.

    python bench/bench_warmup.py [--rounds 2] [--tree OTHER/workflow ...] [--detail]

Each group runs as the rule's job does: a fresh interpreter, one thread, an empty cache of its own (NUMBA_CACHE_DIR
in a temporary folder; the `variants` job after `ja` in the same folder, as the two jobs share the tree's cache).
Printed per tree and round: wall and CPU s of each group, the cache files it leaves, and then the kinds of calls the
study's first jobs make (tests/test_warmup.py's JOBS) in that cache: their CPU s and the files they add (0: the
warm-up covers them). Trees given twice or more alternate round by round (before/after in one session).
`--detail`: each group once more in this tree, with numba's compile events (numba.core.event, "numba:compile"):
seconds per compiled function and signature, nested compiles included in their caller's time.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import resource
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
GROUPS = ("ja", "variants")
DETAIL = """
import sys
from numba.core import event
from mrhyst import warmup
with event.install_recorder("numba:compile") as rec:
    warmup.warm(sys.argv[1])
open_, done = {}, []
for ts, ev in rec.buffer:
    key = (ev.data["dispatcher"].py_func.__qualname__, str(ev.data["args"]))
    if ev.is_start:
        open_.setdefault(key, []).append(ts)
    else:
        done.append((ts - open_[key].pop(), key))
for dt, (name, args) in sorted(done, key=lambda d: -d[0]):
    if dt >= 0.1:
        print(f"    {dt:6.2f} s  {name}  {args[:140]}")
"""


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _run(args: list, tree: str, cache: str) -> tuple[float, float, str]:
    env = dict(os.environ, PYTHONPATH=tree, NUMBA_CACHE_DIR=cache, NUMBA_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    t0, c0 = time.perf_counter(), _cpu()
    p = subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True)
    if p.returncode:
        raise SystemExit(p.stderr[-2000:])
    return time.perf_counter() - t0, _cpu() - c0, p.stdout


def _files(cache: str) -> int:
    return len(list(pathlib.Path(cache).rglob("*.nbc")))


def _jobs() -> str:
    sys.path.insert(0, str(ROOT / "tests"))
    from test_warmup import JOBS

    return JOBS


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--tree", action="append", default=None, help="a package tree (PYTHONPATH); default this one's")
    ap.add_argument("--detail", action="store_true", help="numba's compile events per group (this tree)")
    a = ap.parse_args()
    trees, jobs = a.tree or [str(ROOT / "workflow")], _jobs()
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    for r in range(a.rounds):
        for i, tree in enumerate(trees):
            with tempfile.TemporaryDirectory() as cache:
                row = [_run(["-c", f"from mrhyst import warmup; warmup.warm({g!r})"], tree, cache) for g in GROUPS]
                n = _files(cache)
                _, jobs_cpu, _ = _run(["-c", jobs], tree, cache)
                print(f"round {r + 1} tree {i + 1} ({tree}): " + "  ".join(
                    f"{g} {w:.2f} s wall / {c:.2f} s CPU" for g, (w, c, _) in zip(GROUPS, row))
                    + f"; {n} cache files; the jobs' calls after it {jobs_cpu:.2f} CPU s, +{_files(cache) - n} files")
    if a.detail:
        with tempfile.TemporaryDirectory() as cache:
            for g in GROUPS:
                w, c, out = _run(["-c", DETAIL, g], trees[-1], cache)
                print(f"{g}: {w:.2f} s wall, {c:.2f} s CPU; compiles >= 0.1 s:\n{out.rstrip()}")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
