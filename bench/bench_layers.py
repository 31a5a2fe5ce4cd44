"""What the layered diagnosis (issue 23) costs: a real loop of data/external and the rig's 53-sample sweep.

`NUMBA_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python bench/bench_layers.py [--repeats 2]`

For each input: the whole diagnosis (CPU s of this process, then wall s), and within it the layers' share (the
flexible base, its lam by CV, every increment and its stability refits: `mrhyst.diagnose.layerfit.evidence`,
timed by wrapping it). The issue's goals: a 256-sample real loop <= 3 s, the paper's 53-sample sweep <= 1 s, on
one core. Printed, not asserted (the machine is shared: CPU time is the steadier figure; compare ratios).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from mrhyst import diagnose as dg
from mrhyst.diagnose import layerfit

ROOT = Path(__file__).resolve().parent.parent
SPENT = []


def _timed(fn):
    def run(*a, **k):
        t0 = time.process_time()
        try:
            return fn(*a, **k)
        finally:
            SPENT.append(time.process_time() - t0)
    return run


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args(argv)
    layerfit.evidence = _timed(layerfit.evidence)
    cases = {"M130-27s loop 2 (256 samples in the file)":
             lambda: dg.diagnose_bh_file(ROOT / "data/external/m130-27s-jamodel/loops.csv", 2),
             "rig sweep, hall1 (53 samples)": lambda: dg.diagnose_file(ROOT / "data/raw/li_gong_rig.csv", "hall1")}
    for name, run in cases.items():
        run()  # numba caches loaded, imports done
        cpu, wall, lay = [], [], []
        for _ in range(args.repeats):
            SPENT.clear()
            c0, w0 = time.process_time(), time.perf_counter()
            d = run()
            cpu.append(time.process_time() - c0)
            wall.append(time.perf_counter() - w0)
            lay.append(sum(SPENT))
        print(f"{name}: {d['effect']}; diagnosis {statistics.median(cpu):.2f} CPU s ({statistics.median(wall):.2f} s "
              f"wall), of which the layers {statistics.median(lay):.2f} CPU s; samples fitted {d['input']['n_valid']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
