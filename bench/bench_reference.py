"""Reference mode (issue 24): one diagnosis of a 256-sample bipolar rig sweep against the Table 1 model.

`NUMBA_NUM_THREADS=1 python bench/bench_reference.py [--repeats 5]`

A virtual-rig sweep (0 -> +2 A, then two cycles +2 -> -2 -> +2 A, 256 samples, 0.15 mT noise) of the paper's
group 1 PSO damper with an added air gap (Nd = 5e-4), diagnosed with `--reference table1:group1_pso` after one
warm-up (numba compiled, caches filled). Prints wall and CPU time (process_time: this process only, which the
other sessions on the shared cores inflate less than the wall clock) per diagnosis, median and minimum over
--repeats, and the verdict. Goal: <= 2 s on one core. Printed, never asserted.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from mrhyst import rig
from mrhyst.diagnose import refdiag
from mrhyst.model import ja

ROOT = Path(__file__).resolve().parent.parent


def path_256(i_max: float = 2.0) -> np.ndarray:
    up = np.linspace(0.0, i_max, 32)
    down = np.linspace(i_max, -i_max, 57)[1:]
    rise = np.linspace(-i_max, i_max, 57)[1:]
    return np.concatenate([up, down, rise, down, rise])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    paper = yaml.safe_load((ROOT / "config.yaml").read_text())["paper"]
    p0 = ja.as_param_array(paper["table1"]["group1"]["pso"])
    cur = path_256()
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "gap.csv"
        V, t, I, side = rig.simulate_case(p0, [("air_gap", {"Nd": 5e-4})], 1.5e-4, 7, cur, n_over_le=3026.4,
                                          dwell_s=0.1)
        rig.write_case(f, V, t, I, side)
        d = refdiag.reference_file(f, "table1:group1_pso", sensor="hall1", paper=paper)  # warm-up
        wall, cpu = [], []
        for _ in range(a.repeats):
            w0, c0 = time.perf_counter(), time.process_time()
            d = refdiag.reference_file(f, "table1:group1_pso", sensor="hall1", paper=paper)
            wall.append(time.perf_counter() - w0)
            cpu.append(time.process_time() - c0)
    print(f"{cur.size} samples: {d['effect']} {d['effect_size']}")
    print(f"wall  median {statistics.median(wall):.3f} s, min {min(wall):.3f} s")
    print(f"cpu   median {statistics.median(cpu):.3f} s, min {min(cpu):.3f} s  (goal <= 2 s on one core)")


if __name__ == "__main__":
    main()
