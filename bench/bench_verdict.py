"""Wall time of one diagnosis verdict (issue 12 goal: within 10 s per sweep on this machine).

`NUMBA_NUM_THREADS=1 python bench/bench_verdict.py [--repeats 2]`

Diagnoses data/raw's sweep (hall1, hall2) and rig sweeps with one effect each (and a plain one) at the
config's diagnose settings (the defaults: 1500 random starts, 2 seeds, model-form candidates when a gap is
left), after one warm-up call that compiles the J-A kernel. Prints the median and the maximum per sweep.
Printed, not asserted: the machine is shared, and the figures say so.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np
import yaml
from mrhyst import diagnose as dg
from mrhyst import rig
from mrhyst.model import hall, ja

ROOT = Path(__file__).resolve().parent.parent
TRUTH = np.array([1.357e6, 2.6882e4, 1.4697e-4, 0.4199, 5.6943e3])
RIG = [[], [("eddy_lag", {"lag": 0.3})], [("thermal_drift", {"drift_T_per_s": 3e-3})],
       [("hall_offset", {"offset_T": 3e-3})], [("sensor_saturation", {"B_sat_T": 0.08})]]


def rig_sweep(effects, seed):
    current = ja.paper_current_path()
    peak = float(np.max(ja.simulate(TRUTH, current, 3026.4, form="physical", substeps=8)[0]))
    v, t, cur, side = rig.simulate_case(TRUTH, effects, 1.5e-4, seed, current, n_over_le=3026.4, dwell_s=0.1,
                                        sensitivity_V_per_T=min(5.0, 1.3 / peak), declare_limits=False)
    s = side["sensors"]["hall1"]
    B = hall.volts_to_tesla(v["hall1"], s["sensitivity_V_per_T"], s["quiescent_V"])
    return dg.sweep_from_arrays(cur, t, B, 3026.4, dwell_s=0.1, sensor_info={
        "sensitivity_V_per_T": s["sensitivity_V_per_T"], "quiescent_V": s["quiescent_V"], "supply_V": 3.3})


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args(argv)
    cfg = dg.resolve_config(yaml.safe_load((ROOT / "config.yaml").read_text()).get("diagnose"))
    cfg["series"] = False
    raw = ROOT / "data/raw/li_gong_rig.csv"
    sweeps = {f"data/raw {s}": dg.load_sweep(raw, s, cfg) for s in ("hall1", "hall2")}
    sweeps.update({"rig " + ("+".join(e for e, _ in eff) or "plain"): rig_sweep(eff, 7) for eff in RIG})
    dg.diagnose(sweeps["data/raw hall1"], cfg)  # warm-up: kernel compilation
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores (shared machine)")
    allt = []
    for name, sw in sweeps.items():
        ts = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            d = dg.diagnose(sw, cfg)
            ts.append(time.perf_counter() - t0)
        allt += ts
        print(f"{name:<28} {d['effect']:<18} median {statistics.median(ts):5.2f} s  max {max(ts):5.2f} s")
    print(f"all: median {statistics.median(allt):.2f} s, max {max(allt):.2f} s over {len(allt)} verdicts")


if __name__ == "__main__":
    main()
