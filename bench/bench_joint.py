"""Per-loop and joint J-A fits of the external multi-loop materials (issue 17): RMS per loop (% of its peak
|B|), the joint fit's RMS over the loop's own per-loop RMS ("x own"; goal for the ferrite: every loop <= 2),
substep count, wall time. Prints a table; timings depend on machine load.

    PYTHONPATH=workflow python bench/bench_joint.py [config.yaml]

"cli" = `mrhyst fit FILE --method lsm --start cyclic --loop-index N|all [--model M] --config config.yaml`
(joint weight: config ja.joint_weight; "x own" against the cli per-loop rows). "workflow" = rule external_fit
(mrhyst.materials.external.fit_source: multi-start search per loop, then the joint fit with the source's
joint_model / joint_weight / joint_rounds and the joint_models beside it; "x own" against the workflow's
per-loop rows).
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
    return "   n/a" if v is None else f"{100 * v:6.2f}"


def row(name, what, model, i, rel, ratio, n, dt=""):
    r = "   -  " if ratio is None else f"{ratio:6.2f}"
    print(f"{name:13s} {what:18s} {model:12s} {i:4d}  {pct(rel)}  {r}  {n:8d}  {dt}")


def cli_rows(name, path, cfg, src):
    own = {}
    for i in loop_indices(read_loops(path)):
        t = time.perf_counter()
        r = identify.fit_file(path, "lsm", start="cyclic", loop_index=i, config=cfg)
        own[i] = r["per_loop"][0]["rms_T"]
        row(name, "cli per-loop", "ja", i, r["per_loop"][0]["rms_rel"], None, r["substeps"],
            f"{time.perf_counter() - t:.2f}")
    models = ["ja"] + [m for m in dict.fromkeys([src.get("joint_model", "ja")] + src.get("joint_models", []))
                       if m != "ja"]
    for m in models:
        t = time.perf_counter()
        r = identify.fit_file(path, "lsm", start="cyclic", loop_index="all", config=cfg, model=m)
        dt = f"{time.perf_counter() - t:.2f} (all loops, weight {r['joint_weight']})"
        for e in r["per_loop"]:
            row(name, "cli joint", m, e["loop_index"], e["rms_rel"], e["rms_T"] / own[e["loop_index"]],
                r["substeps"], dt)


def workflow_rows(name, cfg, src):
    t = time.perf_counter()
    res = external.fit_source(src["path"], name, config=cfg)
    dt = f"{time.perf_counter() - t:.2f} (file: per-loop and every joint fit)"
    own = {}
    for lp in res["loops"]:
        own[lp["loop_index"]] = lp["rms_T"]
        row(name, "workflow per-loop", lp["model"], lp["loop_index"], lp["rms_rel_peak"], None, lp["substeps"], dt)
        dt = ""
    for j in [res.get("joint")] + list((res.get("joint_variants") or {}).values()):
        if not j:
            continue
        what = f"wf joint w={j['joint_weight']}" + (f" x{len(j['joint_rounds'])}" if "joint_rounds" in j else "")
        for e in j["per_loop"]:
            row(name, what, j["model"], e["loop_index"], e["rms_rel"], e["rms_T"] / own[e["loop_index"]],
                j["substeps"])


def main(config="config.yaml"):
    cfg = load_config(config)  # the workflow's sources, their start states and joint settings
    print("material      fit                model        loop  rms %pk  x own  substeps  time s")
    for name, path in FILES.items():
        src = cfg["external"]["sources"][name]
        cli_rows(name, path, cfg, src)
        workflow_rows(name, cfg, src)


if __name__ == "__main__":
    main(*sys.argv[1:2])
