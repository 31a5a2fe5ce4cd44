"""Per-loop and joint J-A fits of the external multi-loop materials (issue 17): RMS per loop (% of its
peak |B|), substep count chosen, wall time. Prints a table; timings depend on machine load.

    PYTHONPATH=workflow python bench/bench_joint.py [config.yaml]

"cli" = `mrhyst fit FILE --method lsm --start cyclic --loop-index N|all --config config.yaml`; "workflow" =
rule external_fit (mrhyst.materials.external.fit_source: multi-start search per loop, then the joint fit).
"""

import sys
import time

from mrhyst.config import load_config
from mrhyst.data.io import loop_indices, read_loops
from mrhyst.fit import identify
from mrhyst.materials import external

FILES = {"m130_27s": "data/external/m130-27s-jamodel/loops.csv",
         "mnzn_ferrite": "data/external/mnzn-ferrite-jamodel/loops.csv"}


def pct(v):
    return "  n/a " if v is None else f"{100 * v:6.2f}"


def row(name, what, i, rel, n, dt=""):
    print(f"{name:13s} {what:20s} {i:4d}  {pct(rel)}  {n:8d}  {dt}")


def main(config="config.yaml"):
    cfg = load_config(config)  # the workflow's sources and their start states (M130-27s: cyclic)
    print("material      fit                  loop  rms %peak  substeps  time s")
    for name, path in FILES.items():
        for i in loop_indices(read_loops(path)):
            t = time.perf_counter()
            r = identify.fit_file(path, "lsm", start="cyclic", loop_index=i, config=cfg)
            row(name, "cli per-loop lsm", i, r["per_loop"][0]["rms_rel"], r["substeps"],
                f"{time.perf_counter() - t:.2f}")
        t = time.perf_counter()
        r = identify.fit_file(path, "lsm", start="cyclic", loop_index="all", config=cfg)
        dt = f"{time.perf_counter() - t:.2f} (all loops)"
        for e in r["per_loop"]:
            row(name, "cli joint lsm", e["loop_index"], e["rms_rel"], r["substeps"], dt)
        for m in cfg["external"]["sources"][name].get("joint_models", []):
            t = time.perf_counter()
            r = identify.fit_file(path, "lsm", start="cyclic", loop_index="all", config=cfg, model=m)
            dt = f"{time.perf_counter() - t:.2f} (all loops)"
            for e in r["per_loop"]:
                row(name, f"cli joint {m}"[:20], e["loop_index"], e["rms_rel"], r["substeps"], dt)
        t = time.perf_counter()
        res = external.fit_source(cfg["external"]["sources"][name]["path"], name, config=cfg)
        dt = f"{time.perf_counter() - t:.2f} (file, both)"
        for lp in res["loops"]:
            row(name, "workflow per-loop", lp["loop_index"], lp["rms_rel_peak"], lp["substeps"], dt)
        for e in (res.get("joint") or {}).get("per_loop", []):
            row(name, "workflow joint", e["loop_index"], e["rms_rel"], res["joint"]["substeps"])
        for m, j in (res.get("joint_variants") or {}).items():
            for e in j["per_loop"]:
                row(name, f"workflow joint {m}"[:20], e["loop_index"], e["rms_rel"], j["substeps"])


if __name__ == "__main__":
    main(*sys.argv[1:2])
