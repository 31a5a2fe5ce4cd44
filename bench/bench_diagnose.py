"""Why the diagnosis has its own batched Levenberg-Marquardt instead of scipy.optimize.least_squares.

`NUMBA_NUM_THREADS=1 python bench/bench_diagnose.py [--repeats 3]`

The diagnosis refits J-A (5 parameters) and J-A + each effect (6-7) from several starts, on every sweep and
on every blind case. On the rig sweep of data/raw (hall1), from the same starts (the n_starts best of n_random,
as `mrhyst.diagnose.random_starts` picks them), this prints wall time, J-A model evaluations and the best RMS
for

- `Problem.lm` (`mrhyst.fit.lm.least_squares_batch`): all starts in lock-step, each Jacobian one batched
  kernel call (rows x (free + 1) loops);
- `scipy.optimize.least_squares` (trf, 2-point Jacobian, same bounds and coordinates, xtol = ftol = 1e-10),
  one start after another: each Jacobian is (free + 1) single-loop kernel calls.

Printed, not asserted (the machine is shared and noisy): medians over --repeats runs.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
from mrhyst import diagnose as dg
from scipy.optimize import least_squares

ROOT = Path(__file__).resolve().parent.parent


def _scipy_fit(prob: dg.Problem, U0: np.ndarray, effects: tuple, W: np.ndarray, max_nfev: int):
    act, lo, hi = prob.spec(effects)
    best_rms, evals = np.inf, 0
    for u0 in U0:
        base = prob.embed(u0, effects)

        def fun(x, base=base):
            u = base.copy()
            u[act] = x
            r = prob.resid(u[None, :], W[None, :])
            return r[0] if np.all(np.isfinite(r[0])) else np.full(W.size, 1e3)

        n0 = prob.n_evals
        res = least_squares(fun, base[act], bounds=(lo[act], hi[act]), method="trf", xtol=1e-10, ftol=1e-10,
                            gtol=1e-10, max_nfev=max_nfev)
        evals += prob.n_evals - n0
        best_rms = min(best_rms, float(np.sqrt(np.sum(res.fun**2) / W.sum())) * 1e-3)
    return best_rms, evals


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--raw", default=str(ROOT / "data/raw/li_gong_rig.csv"))
    ap.add_argument("--sensor", default="hall1")
    args = ap.parse_args(argv)

    cfg = dg.resolve_config()
    sw = dg.load_sweep(args.raw, args.sensor, cfg)
    prob = dg.Problem(sw, cfg, cfg["form"])
    W = sw.valid.astype(float)
    starts = dg.random_starts(prob, sw.valid, 0)
    prob.lm(starts[:1], [()], W, max_iter=3)  # compile the kernel outside the timing
    print(f"sweep {args.raw} ({args.sensor}), {sw.n} samples, {len(starts)} starts, "
          f"LM max_iter {cfg['max_iter']}, substeps {cfg['substeps']}")
    print(f"{'model':<32}{'method':<16}{'wall s':>10}{'evals':>10}{'best RMS mT':>14}")
    for effects in ((), ("hall_offset",), ("hall_offset", "eddy_lag")):
        U0 = np.array([prob.embed(u, effects) for u in starts])
        rows = {}
        for name in ("batched LM", "scipy trf"):
            times, evals, rms = [], 0, np.inf
            for _ in range(args.repeats):
                n0 = prob.n_evals
                t0 = time.perf_counter()
                if name == "batched LM":
                    fits = prob.lm(U0, [effects] * len(U0), W)
                    rms = min(f.rms for f in fits)
                    evals = prob.n_evals - n0
                else:
                    rms, evals = _scipy_fit(prob, U0, effects, W, max_nfev=int(cfg["max_iter"]) * 10)
                times.append(time.perf_counter() - t0)
            rows[name] = statistics.median(times)
            label = "J-A + " + " + ".join(effects) if effects else "J-A"
            print(f"{label:<32}{name:<16}{rows[name]:>10.3f}{evals:>10d}{rms * 1e3:>14.4f}")
        print(f"{'':<32}{'ratio scipy/LM':<16}{rows['scipy trf'] / rows['batched LM']:>10.1f}")


if __name__ == "__main__":
    main()
