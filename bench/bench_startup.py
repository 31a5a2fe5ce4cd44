"""Start-up of the command line (issue 26): wall and CPU time of `mrhyst --help` and of a warm `mrhyst fit
--method lsm` of the paper's 53-sample loop, and what each stage of a fit's start-up costs; min and median of N
runs each (the machine may be shared: the minimum is the figure least disturbed by other load, CPU seconds less
disturbed than wall seconds).

    python bench/bench_startup.py [--n 7]

Stages: each is a fresh interpreter doing everything the stage before did and one thing more (numpy, numba,
scipy.optimize, numba's registries, the numba cache load of the J-A kernel, the fit's own modules), so the
difference of two rows' medians is that stage's cost. They run as the process entry runs a fit (mrhyst.startup:
one BLAS thread, the cyclic collector off while loading, no interpreter teardown), so the fourth row is the floor
of the stack: what loading numpy, numba and scipy.optimize costs before any of mrhyst's code. pandas and
jsonschema are timed on their own: a fit of a loop file no longer loads them (tests/test_startup.py).

Goals (issue 26): `mrhyst --help` <= 0.3 s, the warm fit <= 0.6 s. "Warm": the numba cache of the kernel, Python's
bytecode of mrhyst and the parsed config schema (mrhyst.startup.cached_yaml) are filled by one run before the timed
ones, as Python does by default; with PYTHONDONTWRITEBYTECODE set (or -B) nothing of mrhyst's is ever cached, so
when the caller's environment sets it, the warm fit is timed that way too (its own row). Each command is a fresh
interpreter (`python -m mrhyst ...`), as a user runs it; the fit writes into a temporary folder. The row "bare
import" is `python -c "import numpy, scipy.optimize, numba"` run the same way, without mrhyst.startup's settings.
`--tree OTHER/workflow` times another checkout; given twice or more (`--tree OLD/workflow --tree NEW/workflow`), the
rows of the commands alternate between the trees run by run (before/after in one session: the load hits both
alike) and the stages are timed for the first tree.

The ahead-of-time J-A module (mrhyst.model.aot, issue 26): in a tree that has it, the module is built first
(`python -m mrhyst.model.aot_build`, its wall time printed), and the warm fit is timed twice, alternated run by run
in the same session: with the module, and with it off (MRHYST_AOT=0: numba's JIT kernel from its cache, as
before). The numba stages run with it off; the stages "with the AOT module" load numpy, scipy.optimize and the
module's kernel, no numba.
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
    ap.add_argument("--n", type=int, default=7, help="runs per figure (min and median are reported)")
    ap.add_argument("--tree", action="append", default=None,
                    help="a package tree to time (PYTHONPATH), e.g. another checkout's workflow/; twice or more: "
                         "alternated run by run (default: this checkout's)")
    a = ap.parse_args()
    measure(a.n, a.tree or [str(ROOT / "workflow")])


# the numba cache load: one simulate of the kernel the fit runs, on the paper's path (cache filled first)
KERNEL = ("import numpy as np; from mrhyst.model import ja; ja.simulate_h(np.array([[1.2e6, 900.0, 1e-4, 0.2, "
          "800.0]]), np.linspace(0.0, 4e4, 53), form='paper', substeps=8)")
# numba's registries of lowerings, loaded before its first compile or cache load (numba.core.cpu)
REFRESH = "from numba.core.registry import cpu_target; cpu_target.target_context.refresh()"
# each stage as the process entry runs it (mrhyst.startup): the collector off, one BLAS thread (env), no teardown
_OFF, _END = "import gc, os; gc.disable(); ", "; os._exit(0)"
STAGES = [
    ("numpy", "import numpy"),
    ("+ numba", "import numpy, numba"),
    ("+ scipy.optimize (least_squares)", "import numpy, numba, scipy.optimize"),
    ("+ numba's registries (the floor of numpy, numba, scipy)", "import numpy, numba, scipy.optimize; " + REFRESH),
    ("+ the J-A kernel from numba's cache", "import scipy.optimize; " + REFRESH + "; " + KERNEL),
    ("+ the fit's modules (mrhyst.fit.identify)", "import scipy.optimize, mrhyst.fit.identify; " + KERNEL),
]
AOT_STAGES = [
    ("numpy", "import numpy"),
    ("+ scipy.optimize (least_squares)", "import numpy, scipy.optimize"),
    ("+ the J-A kernel from the AOT module (no numba)", "import scipy.optimize; " + KERNEL),
    ("+ the fit's modules (mrhyst.fit.identify)", "import scipy.optimize, mrhyst.fit.identify; " + KERNEL),
]
ALONE = [("pandas alone (not on the fit path)", "import pandas"),
         ("jsonschema alone (not on the fit path)", "import jsonschema"),
         ("yaml + the config schema read (libyaml)", "from mrhyst import config; config._schema()")]


def _row(label: str, cmd: list[str], n: int, env: dict) -> tuple[float, float]:
    return _stats(label, *_runs(cmd, n, env))


def _stats(label: str, t: list, c: list) -> tuple[float, float]:
    t, c = sorted(t), sorted(c)
    print(f"  {label:58s} wall {t[0]:6.3f} {t[len(t) // 2]:6.3f}   cpu {c[0]:6.3f} {c[len(c) // 2]:6.3f}")
    return t[len(t) // 2], c[len(c) // 2]


def _alternated(label: str, cmds: list, n: int, envs: list, tags: list | None = None) -> list:
    """``cmds[i]`` in ``envs[i]`` (one per tree, or ``tags[i]`` names the row), run after one another n times."""
    t: list = [[] for _ in cmds]
    c: list = [[] for _ in cmds]
    for _ in range(n):
        for i, (cmd, env) in enumerate(zip(cmds, envs)):
            t[i] += wall(cmd, 1, env, c[i])
    tags = tags or [f" [tree {i + 1}]" if len(cmds) > 1 else "" for i in range(len(cmds))]
    return [_stats(f"{label}{tags[i]}", t[i], c[i]) for i in range(len(cmds))]


def _has_aot(tree: str) -> bool:
    return (Path(tree) / "mrhyst" / "model" / "aot_build.py").is_file()


def _build_aot(py: list, env: dict) -> None:
    t0 = time.perf_counter()
    r = subprocess.run(py + ["-m", "mrhyst.model.aot_build"], env=env, capture_output=True, text=True)
    print(f"AOT module: {r.stdout.strip()} (exit {r.returncode}, {time.perf_counter() - t0:.1f} s wall here)")


def measure(n: int, trees: list) -> None:
    user_b = bool(os.environ.get("PYTHONDONTWRITEBYTECODE"))
    base = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # Python's default: bytecode cached
    envs = [dict(base, PYTHONPATH=t, MPLBACKEND="agg") for t in trees]
    py = [sys.executable]
    with tempfile.TemporaryDirectory() as tmp:
        loop = Path(tmp) / "loop.csv"
        fits = [py + ["-m", "mrhyst", "fit", str(loop), "--method", "lsm", "--out", str(Path(tmp) / f"fit{i}.json")]
                for i in range(len(trees))]
        subprocess.run(py + ["-m", "mrhyst", "convert", str(RAW), "--sensor", "hall1", "--out", str(loop)],
                       env=envs[0], check=True)
        off = [dict(e, MRHYST_AOT="0") for e in envs]  # no AOT module: numba's JIT kernel (trees without: as is)
        for f, env0 in zip(fits, off):
            wall(f, 1, env0)  # fills the numba cache, mrhyst's bytecode and the schema's cache
            wall(py + ["-c", KERNEL], 1, env0)
        for i, t in enumerate(trees):
            print(f"tree {i + 1}: {t}")
            if _has_aot(t):
                _build_aot(py, envs[i])
                wall(fits[i], 1, envs[i])
        print(f"wall and CPU seconds (user + system), min and median of {n} runs, fresh interpreter each; "
              f"PYTHONDONTWRITEBYTECODE in the caller's environment: {'yes' if user_b else 'no'}; "
              f"load average before: {os.getloadavg()[0]:.2f}")
        _stats("python -c pass (the interpreter alone)", *_runs(py + ["-c", "pass"], n, envs[0]))
        _stats("bare import: python -c 'import numpy, scipy.optimize, numba'",
               *_runs(py + ["-c", "import numpy, scipy.optimize, numba"], n, envs[0]))
        _alternated("mrhyst --help", [py + ["-m", "mrhyst", "--help"]] * len(trees), n, envs)
        rows = [(f, e, f" [tree {i + 1}]" if len(trees) > 1 else "") for i, (f, e) in enumerate(zip(fits, envs))]
        rows += [(f, e0, f"{r[2]}, MRHYST_AOT=0") for r, f, t, e0 in zip(list(rows), fits, trees, off) if _has_aot(t)]
        meds = _alternated("warm mrhyst fit --method lsm (paper loop, 53 samples)", [r[0] for r in rows], n,
                           [r[1] for r in rows], [r[2] or " (AOT module if the tree has one)" for r in rows])
        if user_b:
            _alternated("the same, PYTHONDONTWRITEBYTECODE=1 (mrhyst compiled each run)", fits, n,
                        [dict(e, PYTHONDONTWRITEBYTECODE="1") for e in envs])
        _stages(py, n, off[0], meds[len(trees)] if _has_aot(trees[0]) else meds[0], STAGES)
        if _has_aot(trees[0]):
            print("  with the AOT module (no numba):")
            _stages(py, n, envs[0], meds[0], AOT_STAGES)
        for label, code in ALONE:
            _row(label, py + ["-c", code], n, envs[0])
        print(f"load average after: {os.getloadavg()[0]:.2f}")


def _runs(cmd: list, n: int, env: dict) -> tuple[list, list]:
    c: list = []
    return wall(cmd, n, env, c), c


def _stages(py: list, n: int, env: dict, fit_med: tuple, stages: list) -> None:
    print("  stages of a fit's start-up (cumulative; the stage's cost = its median CPU - the row above's):")
    prev = 0.0
    for label, code in stages:
        w, c = _row(label, py + ["-c", _OFF + code + _END], n, dict(env, OPENBLAS_NUM_THREADS="1"))
        print(f"  {'':58s} stage cpu {c - prev:+6.3f}")
        prev = c
    print(f"  {'the fit itself and its output (warm fit - last stage)':58s} stage cpu {fit_med[1] - prev:+6.3f}")


if __name__ == "__main__":
    main()
