"""The flexible base's NNLS solves (mrhyst.diagnose.everett; issue 23's speed goal): their share of a diagnosis and
what cheaper solve of the same systems exists.

`NUMBA_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=workflow python bench/bench_nnls.py [--lag] CASE ...`

A CASE is a Hall sweep's CSV with its sidecar (a blind or real-cores case) or a B(H) loop's CSV (a real-cores B(H)
case; ``loops.csv:I``: loop I of a data/external file), diagnosed as bench/ab_cpu.py does (one warm-up first).
Prints per case the diagnosis's CPU seconds and those inside scipy.optimize.nnls, the solves by system width
(columns: 111 / 183 / 273 for 10 / 13 / 16 fields), and for every system solved the CPU of: scipy's nnls as the
diagnosis calls it; the same on the square system of the same minimum (R and Q'b of the QR of [M b], rows =
columns) and that QR; scipy's lsq_linear (BVLS) with bounds [0, inf); and how many columns of its solution's
support differ from the nearest earlier system of the same width (what a warm-started active set would have to add
or drop, one column an iteration). ``--lag``: every lag search (everett._lag) also evaluates the whole lag grid;
counts the searches whose walked grid (everett._walk) has another minimum, and the solves the walk left out (the
whole grid's extra solves then count in the CPU figures). ``--quick``: the counts and CPU alone. Printed, not
asserted; one process, so ratios are the figure.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def diagnose(case: str):
    import yaml
    from mrhyst import diagnose as dg
    from mrhyst.data import io
    from mrhyst.materials.extsettings import loop_fit_settings

    conf = yaml.safe_load((ROOT / "config.yaml").read_text())
    cfg = dg.resolve_config(conf.get("diagnose"))
    path, _, loop = case.partition(".csv:")
    path = path if path.endswith(".csv") else path + ".csv"
    if io.sidecar_path(Path(path)).exists():
        return dg.diagnose_file(path, "hall1", config=cfg)
    material = loop_fit_settings({k: conf[k] for k in ("external", "ja", "pso", "lsm") if k in conf})
    return dg.diagnose_bh_file(path, int(loop) if loop else None, config=cfg, material=material)


def record(everett):
    """Wrap everett's nnls: the systems solved, their solutions and CPU seconds."""
    seen, orig = [], everett.nnls

    def spy(M, b, maxiter=None):
        t0 = time.process_time()
        w, r = orig(M, b, maxiter=maxiter)
        seen.append((M.copy(), b.copy(), w, time.process_time() - t0))
        return w, r

    everett.nnls = spy
    return seen


def cpu(f, *args, **kw):
    t0 = time.process_time()
    out = f(*args, **kw)
    return time.process_time() - t0, out


def alternatives(systems) -> dict:
    """CPU seconds of the alternatives on the recorded systems (module docstring) and the warm start's distance."""
    from scipy.optimize import lsq_linear, nnls

    tot = dict(scipy=0.0, square=0.0, qr=0.0, bvls=0.0)
    dev, dist = 0.0, []
    for i, (M, b, w, _) in enumerate(systems):
        k = M.shape[1]
        t, _ = cpu(nnls, M, b, maxiter=50 * k)
        tot["scipy"] += t
        t, Ra = cpu(np.linalg.qr, np.column_stack([M, b]), mode="r")
        tot["qr"] += t
        t, (wr, _) = cpu(nnls, Ra[:k, :k], Ra[:k, k], maxiter=50 * k)
        tot["square"] += t
        t, r = cpu(lsq_linear, M, b, bounds=(0, np.inf), method="bvls", tol=1e-14)
        tot["bvls"] += t
        dev = max(dev, float(np.max(np.abs(wr - w)) / max(np.max(np.abs(w)), 1e-300)),
                  float(np.max(np.abs(r.x - w)) / max(np.max(np.abs(w)), 1e-300)))
        prior = [(np.abs(M2 - M).sum(), w2) for M2, _, w2, _ in systems[:i] if M2.shape == M.shape]
        if prior:
            dist.append(int(np.sum((min(prior, key=lambda p: p[0])[1] > 0) != (w > 0))))
    return {**tot, "max_rel_dev": dev, "support_diff": dist}


def lag_check(everett) -> list:
    """Wrap everett._walk: each lag search's walked grid against the whole grid (argmin, solves)."""
    out, walk = [], everett._walk

    def both(cost, grid, starts):
        c = walk(cost, grid, starts)
        full = {(g, st): cost(g, st) for st in starts for g in grid}
        out.append((min(c, key=c.get) == min(full, key=full.get), len(c), len(full)))
        return c

    everett._walk = both
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lag", action="store_true")
    ap.add_argument("--quick", action="store_true", help="counts and CPU only, not the alternatives")
    ap.add_argument("cases", nargs="+")
    a = ap.parse_args(argv)
    from mrhyst.diagnose import everett

    diagnose(a.cases[0])
    if a.lag:
        searches = lag_check(everett)
    systems = record(everett)
    for case in a.cases:
        n0 = len(systems)
        t, _ = cpu(diagnose, case)
        mine = systems[n0:]
        widths = sorted({M.shape[1] for M, *_ in mine})
        by = {k: (sum(1 for M, *_ in mine if M.shape[1] == k), sum(s[3] for s in mine if s[0].shape[1] == k))
              for k in widths}
        print(f"{Path(case).name}: {t:.3f} CPU s, nnls {sum(s[3] for s in mine):.3f} s in {len(mine)} solves; "
              + ", ".join(f"{k} columns {n} ({s:.3f} s)" for k, (n, s) in by.items()), flush=True)
        if mine and not (a.lag or a.quick):
            r = alternatives(mine)
            d = r["support_diff"]
            print(f"  same systems: scipy nnls {r['scipy']:.3f} s; square system {r['square']:.3f} s + its QR "
                  f"{r['qr']:.3f} s; BVLS {r['bvls']:.3f} s (largest relative difference of a solution "
                  f"{r['max_rel_dev']:.1e}); support vs the nearest earlier system: median "
                  f"{np.median(d) if d else float('nan'):.0f} columns, {sum(x == 0 for x in d)} of {len(d)} equal",
                  flush=True)
    if a.lag:
        print(f"lag searches {len(searches)}: walked argmin differs in {sum(not s[0] for s in searches)}; solves "
              f"{sum(s[1] for s in searches)} walked against {sum(s[2] for s in searches)} on the whole grid")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
