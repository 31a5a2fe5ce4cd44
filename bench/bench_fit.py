"""Speed of one PSO fit at the paper's settings, and what it is made of.

    NUMBA_NUM_THREADS=1 python bench/bench_fit.py [--repeats 5]

Prints: one PSO fit (100 particles x 100 iterations, w = 1, c1 = c2 = 2) in seconds on one core; model
evaluations per second of the batched kernel and of the straightforward scalar J-A (ja.simulate_scalar),
measured in the same run, and their ratio; the same 10^4 evaluations done by a plain compiled scalar J-A
(numba, one parameter set at a time, ``scalar_compiled`` below) against the fit; pyswarms' own per-iteration
overhead; one LSM fit; the integration error at the default step (config ja.substeps) against a 128x finer
step. Goals: issue 3: <= 0.3 s per fit, >= 300x the plain-Python scalar model, error <= 1e-6 T; issue 15: a fit
>= 5x faster than the compiled scalar J-A doing its evaluations, and <= 0.05 s.
Timings on a shared machine are noisy: medians (and minima) of --repeats runs are printed; compare ratios
from one run.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")  # one core, before numba is imported

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402
import yaml  # noqa: E402
from mrhyst.data.io import read_loop  # noqa: E402
from mrhyst.fit import identify  # noqa: E402
from mrhyst.model import ja  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


# --------------------------------------------------------------------------
# baseline: a plain compiled scalar J-A (numba, one parameter set at a time, 1/tanh Langevin, if-branches),
# the same equations and RK4 as ja.simulate_h, written the obvious way. issue 15 measures against this.
# --------------------------------------------------------------------------
@numba.njit(cache=True)
def _scalar_rhs(h, m, Ms, a, alpha, c, k, delta, physical, total):
    x = (h + alpha * m) / a
    if abs(x) < 1e-2:
        L = x / 3.0 - x ** 3 / 45.0 + 2.0 * x ** 5 / 945.0
        dL = 1.0 / 3.0 - x * x / 15.0 + 2.0 * x ** 4 / 189.0
    else:
        L = 1.0 / math.tanh(x) - 1.0 / x
        dL = 1.0 / (x * x) - (1.0 / math.sinh(x) ** 2 if abs(x) < 350.0 else 0.0)
    man = Ms * L
    dman = Ms / a * dL
    diff = (man - m) / (1.0 - c)
    ok = True
    irr = 0.0
    if not (physical and delta * diff <= 0.0):
        den = k * delta - alpha * diff
        if delta * den <= 0.0:
            ok = False
        else:
            irr = (1.0 - c) * diff / den
    num = irr + c * dman
    if total:
        num /= 1.0 - alpha * c * dman
    return num, ok


@numba.njit(cache=True)
def scalar_compiled(p, H, substeps, physical, total):
    """B along H for one parameter set; NaN from a failed step on."""
    Ms, a, alpha, c, k = p[0], p[1], p[2], p[3], p[4]
    out = np.full(H.shape[0], np.nan)
    M = 0.0
    out[0] = ja.MU0 * H[0]
    for j in range(H.shape[0] - 1):
        dH = H[j + 1] - H[j]
        delta = 1.0 if dH > 0.0 else -1.0
        h = dH / substeps
        for s in range(substeps):
            h0 = H[j] + s * h
            k1, o1 = _scalar_rhs(h0, M, Ms, a, alpha, c, k, delta, physical, total)
            k2, o2 = _scalar_rhs(h0 + 0.5 * h, M + 0.5 * h * k1, Ms, a, alpha, c, k, delta, physical, total)
            k3, o3 = _scalar_rhs(h0 + 0.5 * h, M + 0.5 * h * k2, Ms, a, alpha, c, k, delta, physical, total)
            k4, o4 = _scalar_rhs(h0 + h, M + h * k3, Ms, a, alpha, c, k, delta, physical, total)
            M += h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
            if not (o1 and o2 and o3 and o4 and abs(M) <= 10.0 * Ms):
                return out
        out[j + 1] = ja.MU0 * (H[j + 1] + M)
    return out


def scalar_compiled_batch(X, H, substeps, physical, total):
    return [scalar_compiled(x, H, substeps, physical, total) for x in X]


def _timeit(fn, repeats):
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts), min(ts)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    cfg = yaml.safe_load((ROOT / "config.yaml").read_text())
    rc = identify.resolve_config(cfg)
    nle_path = ROOT / "results" / "sim" / "n_over_le.json"
    nle = json.loads(nle_path.read_text())["n_over_le"] if nle_path.is_file() else 3026.4
    substeps = int(cfg["ja"]["substeps"])
    p_true = ja.as_param_array(cfg["paper"]["table1"]["group1"]["pso"])
    I = ja.paper_current_path()
    H = nle * I

    with tempfile.TemporaryDirectory() as td:
        identify.synthetic_loop(p_true, n_over_le=nle, sigma_T=1.5e-4, seed=1, path=Path(td) / "g1.csv")
        loop = read_loop(Path(td) / "g1.csv")
    prob, _ = identify.problem_from_loop(loop, n_over_le=nle, form=cfg["ja"]["form"], substeps=substeps)
    box = identify.table_box(p_true)
    s = rc["pso"]["settings"]["paper"]
    kw = dict(n_particles=rc["pso"]["n_particles"], iterations=rc["pso"]["iterations"], w=s["w"], c1=s["c1"],
              c2=s["c2"], v_max_frac=rc["pso"]["v_max_frac"], bh_strategy=rc["pso"]["bh_strategy"])

    print(f"numba threads: {os.environ.get('NUMBA_NUM_THREADS')}; path: {I.size} samples, N/Le {nle:.1f} /m, "
          f"form {cfg['ja']['form']}, substeps {substeps}")
    identify.run_pso(prob, box, seed=0, **kw)  # warm-up: JIT cache load, pyswarms import

    # 1. one PSO fit at the paper's settings
    seeds = iter(range(1000))
    t_med, t_min = _timeit(lambda: identify.run_pso(prob, box, seed=next(seeds), **kw), args.repeats)
    n_eval = kw["n_particles"] * kw["iterations"] + 1
    print(f"PSO fit (paper: {kw['n_particles']} x {kw['iterations']}, w={kw['w']}, c1=c2={kw['c1']}): "
          f"median {t_med:.3f} s, min {t_min:.3f} s  [goal <= 0.3 s: {'met' if t_med <= 0.3 else 'MISSED'}]")

    # 2. model evaluations per second: batched kernel (one 100-particle swarm) vs scalar reference
    rng = np.random.default_rng(0)
    X = box.to_x(rng.uniform(size=(kw["n_particles"], 5)))
    Bb, ok = ja.simulate_h(X, H, form=cfg["ja"]["form"], substeps=substeps)
    reps = 200
    tb_med, _ = _timeit(lambda: [prob.cost(X) for _ in range(reps)], 3)
    rate_b = reps * X.shape[0] / tb_med
    good = X[ok][:20]
    ts_med, _ = _timeit(lambda: [ja.simulate_scalar(x, H, form=cfg["ja"]["form"], substeps=substeps)
                                 for x in good], 3)
    rate_s = good.shape[0] / ts_med
    print(f"model evaluations/s: batched {rate_b:,.0f} (incl. objective), scalar {rate_s:,.0f}; "
          f"ratio {rate_b / rate_s:,.0f}x  [goal >= 300x: {'met' if rate_b / rate_s >= 300 else 'MISSED'}]")
    n_rhs = (I.size - 1) * substeps * 4  # RK4: 4 right-hand sides per step
    print(f"  -> per right-hand side of Eq. (10): batched {1e9 / (rate_b * n_rhs):.0f} ns, scalar "
          f"{1e9 / (rate_s * n_rhs):.0f} ns ({n_rhs} per evaluation); 300x would need "
          f"{1e9 / (300 * rate_s * n_rhs):.1f} ns per right-hand side")
    print(f"  -> model time per fit {n_eval / rate_b:.3f} s of the {t_med:.3f} s")

    # 2b. the issue-15 baseline: a plain compiled scalar J-A doing the fit's 10^4 evaluations, one set at a time
    phys, tot = cfg["ja"]["form"] == "physical", cfg["ja"].get("dman", "total") == "total"
    Bc = np.array(scalar_compiled_batch(X, H, substeps, phys, tot))
    dev = float(np.nanmax(np.abs(Bc[ok] - Bb[ok])))
    n_rep = -(-n_eval // X.shape[0])  # repeat the swarm so that the baseline does >= n_eval evaluations
    tc_med, tc_min = _timeit(lambda: [scalar_compiled_batch(X, H, substeps, phys, tot) for _ in range(n_rep)],
                             args.repeats)
    tc_med *= n_eval / (n_rep * X.shape[0])
    tc_min *= n_eval / (n_rep * X.shape[0])
    rate_c = n_eval / tc_med
    print(f"compiled scalar J-A (numba, one set at a time), the fit's {n_eval} evaluations: median {tc_med:.3f} s, "
          f"min {tc_min:.3f} s (agrees with the kernel to {dev:.1e} T); PSO fit / compiled scalar: "
          f"{tc_med / t_med:.2f}x faster  [goal >= 5x: {'met' if tc_med / t_med >= 5 else 'MISSED'}]; "
          f"[fit goal <= 0.05 s: {'met' if t_med <= 0.05 else 'MISSED'}]")
    print(f"  -> per right-hand side: batched kernel {1e9 / (rate_b * n_rhs):.1f} ns, compiled scalar "
          f"{1e9 / (rate_c * n_rhs):.1f} ns; kernel / compiled scalar {rate_b / rate_c:.2f}x")

    # 3. pyswarms' own overhead: the same optimizer on a trivial objective
    GB = identify._global_best_pso()

    def bare():
        np.random.seed(0)
        with identify._quiet_pyswarms():
            opt = GB(kw["n_particles"], 5, {"c1": kw["c1"], "c2": kw["c2"], "w": kw["w"]},
                     bounds=(np.zeros(5), np.ones(5)), bh_strategy=kw["bh_strategy"],
                     velocity_clamp=(-kw["v_max_frac"], kw["v_max_frac"]))
        opt.optimize(lambda U: np.einsum("ij,ij->i", U - 0.3, U - 0.3), iters=kw["iterations"], verbose=False)

    to_med, _ = _timeit(bare, args.repeats)
    print(f"pyswarms overhead (construct + {kw['iterations']} iterations, trivial objective, verbose=False): "
          f"{to_med * 1e3:.1f} ms per fit = {to_med / kw['iterations'] * 1e6:.0f} us per iteration "
          f"({100 * to_med / t_med:.1f} % of a fit)")

    # 4. LSM fit from the box centre of the LSM Table 1 set
    lbox = identify.table_box(cfg["paper"]["table1"]["group1"]["lsm"])
    res = {}
    tl_med, _ = _timeit(lambda: res.update(identify.run_lsm(prob, lbox, max_iterations=100)), args.repeats)
    print(f"LSM fit: median {tl_med:.3f} s ({res['n_iterations']} iterations, {res['n_evals']} model evaluations)")

    # 5. integration error at the default step vs a 128x finer one
    sets = [ja.as_param_array(cfg["paper"]["table1"][g][m]) for g in ("group1", "group2") for m in ("lsm", "pso")]
    errs = []
    for x in sets:
        B1, _ = ja.simulate_h(x, H, form=cfg["ja"]["form"], substeps=substeps)
        B2, _ = ja.simulate_h(x, H, form=cfg["ja"]["form"], substeps=128 * substeps)
        errs.append(float(np.max(np.abs(B1 - B2))))
    r = identify.run_pso(prob, box, seed=0, **kw)
    e_opt = identify.integration_error(prob, r["x"], factor=128)
    print(f"integration error at substeps={substeps} vs {128 * substeps}: Table 1 sets max {max(errs):.2e} T, "
          f"PSO optimum {e_opt:.2e} T  [goal <= 1e-6 T: {'met' if max(max(errs), e_opt) <= 1e-6 else 'MISSED'}]")

    # 6. the model variants (issue 17): kernel time per right-hand side and parameter set, 100 sets on this path
    extra = {"anisotropic": [2000.0, 0.0, 0.5], "amplitude": [0.1, 0.1, 0.1]}  # K_an (J/m^3), psi, t; n_a, ...
    for model, spec in ja.MODELS.items():
        P = np.array([list(x) + extra.get(model, []) for x in good[:1]] * X.shape[0])
        P[:, :5] *= rng.uniform(0.95, 1.05, size=(P.shape[0], 5))
        ja.simulate_h(P, H, form=cfg["ja"]["form"], substeps=substeps, model=model)
        tv, _ = _timeit(lambda P=P, model=model: ja.simulate_h(P, H, form=cfg["ja"]["form"], substeps=substeps,
                                                               model=model),
                        args.repeats)
        print(f"variant {model:13s}: {1e9 * tv / (P.shape[0] * n_rhs):6.1f} ns per right-hand side and set "
              f"({len(spec.names)} parameters)")


if __name__ == "__main__":
    main()
