"""CPU seconds of rule external_fit's stages (issue 23).

`NUMBA_NUM_THREADS=1 python bench/bh_stages.py SOURCE [config.yaml [HELDOUT_FTOL [OUT.json]]]`: HELDOUT_FTOL sets
config ja.auto.heldout_ftol and ja.joint_round_ftol (1e-12 = lsm.ftol, the path before they existed);
OUT.json gets the fit's JSON.

Wraps the stage functions of mrhyst.materials.external and mrhyst.fit.select with process-time counters (exclusive
of nested wrapped calls) and prints one line per stage: the loops' own searches (LSM multistart, PSO, its polish),
the warm starts across loops, the substep settling, each joint variant's fit, each variant's held-out block refits
and the refits from a held-out optimum. One run, one process; numba's kernels warmed first.
"""
from __future__ import annotations

import sys
import time
from collections import defaultdict

from mrhyst.fit import identify, select
from mrhyst.materials import external

T: dict = defaultdict(float)
N: dict = defaultdict(int)
_stack: list = []


def _wrap(owner, name, label):
    f = getattr(owner, name)

    def g(*a, **k):
        lab = label(a, k) if callable(label) else label
        _stack.append(0.0)
        t0 = time.process_time()
        try:
            return f(*a, **k)
        finally:
            dt = time.process_time() - t0
            child = _stack.pop()
            T[lab] += dt - child
            N[lab] += 1
            if _stack:
                _stack[-1] += dt
    setattr(owner, name, g)


def main(source: str, config: str = "config.yaml", heldout_ftol: str | None = None, out: str | None = None) -> None:
    import yaml
    from mrhyst.materials.external import external_config

    config = yaml.safe_load(open(config))
    if heldout_ftol is not None:
        config.setdefault("ja", {}).setdefault("auto", {})["heldout_ftol"] = float(heldout_ftol)
        config["ja"]["joint_round_ftol"] = float(heldout_ftol)
    ext = external_config(config)
    path = ext["sources"][source]["path"]
    _wrap(identify, "run_pso", "loop search: PSO")
    _wrap(external._LoopFit, "search", "loop search: settle + screen")
    _wrap(external._LoopFit, "lsm", lambda a, k: "loop LSM (multistart/polish/warm/settle)")
    _wrap(external._LoopFit, "from_other_loops", "warm start across loops (excl. LSM)")
    _wrap(external._LoopFit, "settle_substeps", "settle substeps (excl. LSM)")
    _wrap(external, "fit_joint", lambda a, k: f"joint fit {k.get('model')}")
    _wrap(select, "heldout", lambda a, k: f"held-out blocks {a[2].get('model')}")
    _wrap(select, "fit_from", lambda a, k: ("held-out fold fit " if a[4] else "refit from held-out ")
          + str(a[2].get("model")))
    t0 = time.process_time()
    external.fit_source(path, source, config=config, out=out)
    total = time.process_time() - t0
    for lab in sorted(T, key=lambda s: -T[s]):
        print(f"{source:14s} {lab:45s} {T[lab]:7.2f} s  ({N[lab]} calls)")
    print(f"{source:14s} {'TOTAL':45s} {total:7.2f} s")


if __name__ == "__main__":
    main(*sys.argv[1:])
