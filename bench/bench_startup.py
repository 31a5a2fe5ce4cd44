"""Start-up of the command line (issue 26): wall time of `mrhyst --help` and of a warm `mrhyst fit --method lsm`
of the paper's 53-sample loop, and what the imports cost on their own; min of N runs each (the machine may be
shared: the minimum is the figure least disturbed by other load).

    python bench/bench_startup.py [--n 7]

Goals (issue 26): `mrhyst --help` <= 0.3 s, the warm fit <= 0.6 s. "Warm": the numba cache of the kernel is
filled by one run before the timed ones. Each command is a fresh interpreter (`python -m mrhyst ...`), as a user
runs it; the fit writes into a temporary folder. `--tree OTHER/workflow` times another checkout (before/after in
one session: the load then hits both alike).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RAW = ROOT / "data" / "raw" / "li_gong_rig.csv"


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def wall(cmd: list[str], n: int, env: dict, cpu: list | None = None) -> list[float]:
    """Wall seconds of n runs of cmd; their CPU seconds (user + system) appended to ``cpu``."""
    out = []
    for _ in range(n):
        t0, c0 = time.perf_counter(), _cpu()
        r = subprocess.run(cmd, env=env, capture_output=True, text=True)
        out.append(time.perf_counter() - t0)
        if cpu is not None:
            cpu.append(_cpu() - c0)
        if r.returncode != 0:
            raise SystemExit(f"{' '.join(cmd)} failed: {r.stderr.strip()}")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=7, help="runs per figure (min is reported)")
    ap.add_argument("--tree", default=str(ROOT / "workflow"),
                    help="the package tree to time (PYTHONPATH), e.g. another checkout's workflow/ for a before/after")
    a = ap.parse_args()
    measure(a.n, a.tree)


def measure(n: int, tree: str) -> None:
    env = dict(os.environ, PYTHONPATH=tree, MPLBACKEND="agg")
    py = [sys.executable]
    with tempfile.TemporaryDirectory() as tmp:
        loop, fit = Path(tmp) / "loop.csv", Path(tmp) / "fit.json"
        subprocess.run(py + ["-m", "mrhyst", "convert", str(RAW), "--sensor", "hall1", "--out", str(loop)], env=env,
                       check=True)
        fit_cmd = py + ["-m", "mrhyst", "fit", str(loop), "--method", "lsm", "--out", str(fit)]
        wall(fit_cmd, 1, env)  # fills the numba cache
        rows = [
            ("python -c pass (the interpreter alone)", py + ["-c", "pass"]),
            ("mrhyst --help", py + ["-m", "mrhyst", "--help"]),
            ("warm mrhyst fit --method lsm (paper loop, 53 samples)", fit_cmd),
            ("import numpy", py + ["-c", "import numpy"]),
            ("import pandas", py + ["-c", "import pandas"]),
            ("import numba", py + ["-c", "import numba"]),
            ("import scipy.optimize", py + ["-c", "import scipy.optimize"]),
            ("import mrhyst.fit.identify (all the fit needs)", py + ["-c", "import mrhyst.fit.identify"]),
        ]
        print(f"{tree}: min / median of {n} runs, wall seconds, and min CPU seconds (user + system; less "
              "disturbed by other load than wall time), fresh interpreter each")
        for label, cmd in rows:
            c: list = []
            t = sorted(wall(cmd, n, env, c))
            print(f"  {label:58s} wall {t[0]:6.3f} {t[len(t) // 2]:6.3f}   cpu {min(c):6.3f}")


if __name__ == "__main__":
    main()
