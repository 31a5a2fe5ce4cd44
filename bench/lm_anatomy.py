"""Where the diagnosis's batched LM spends its iterations, and what pruning or a looser stop would save (issue 23).

`NUMBA_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=TREE/workflow python bench/lm_anatomy.py run OUT.pkl CASE...`
`python bench/lm_anatomy.py report OUT.pkl [OUT2.pkl ...]`

``run`` diagnoses each CASE (a Hall sweep's CSV with its sidecar, else a B(H) loop) as the workflow's rules do
(config.yaml's ``diagnose``; a B(H) loop's material fit from its ja/pso/lsm/external sections) and records every
``least_squares_batch`` call: its caller, its groups (rows that fit one problem and of which only the best is
kept: one model and one weight row in :meth:`Problem.lm`, one seed in the plain fit; a model-form fit's starts),
each row's cost after every iteration, the process CPU in the LM and in the model. ``report`` prints, replayed on
those histories (rows are independent: a row gives the same bytes in any batch, so a replay is exact):

1. per caller: calls, lock-step iterations, CPU in the LM and in the model;
2. start pruning: a row whose cost is above (1 + f) x its group's best after t0 iterations stops; the iterations
   and row-iterations left, the rows pruned and how many of them would have been their group's best at the end
   (by more than 1e-6 / 1e-3 relative: not a tie of two starts on one optimum);
3. tails: the iterations left if each row stopped as soon as it is within 1e-6 (1e-4) of its final cost (an oracle:
   no stopping rule can do better);
4. model calls if each row ran its own Jacobian -> probe -> trial cycle (rows that need no Jacobian skip a call)
   instead of the lock-step's three calls whenever one row needs a Jacobian;
5. the live rows per iteration (a model call costs about the same up to 16 of them).
"""

from __future__ import annotations

import argparse
import collections
import importlib
import inspect
import pickle
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def _record(cases) -> dict:
    import yaml
    from mrhyst import diagnose as dg
    from mrhyst.data import io
    from mrhyst.diagnose import modelform, problem
    from mrhyst.fit import lm
    from mrhyst.materials.extsettings import loop_fit_settings

    candidates = importlib.import_module("mrhyst.diagnose.candidates")  # the package exports a function of that name
    conf = yaml.safe_load((ROOT / "config.yaml").read_text())
    cfg = dg.resolve_config(conf.get("diagnose"))
    material = loop_fit_settings({k: conf[k] for k in ("external", "ja", "pso", "lsm") if k in conf})

    def one(c):
        if io.sidecar_path(c).exists():
            return dg.diagnose_file(c, "hall1", config=cfg)
        return dg.diagnose_bh_file(c, None, config=cfg, material=material)

    dg.diagnose_file(ROOT / "data/raw/li_gong_rig.csv", "hall1", config=cfg)  # warm-up: numba's cache
    calls, cur = [], {"groups": None, "hist": None, "seeds": []}
    lsb, accept, plm, mfit, rstarts = (lm.least_squares_batch, lm._accept, problem.Problem.lm, modelform._fit_batch,
                                       candidates.random_starts)

    def accept_(live, k, Xn, rn, cn, X, r, cost, *a):
        accept(live, k, Xn, rn, cn, X, r, cost, *a)
        if cur["hist"] is not None:
            cur["hist"].append((live.copy(), cost.copy(), a[3].copy(), a[2].copy()))  # live, cost, nit, done

    def lsb_(fun, x0, *a, **kw):
        t = [0.0, 0]

        def f(X, rows):
            t0 = time.process_time()
            out = fun(X, rows)
            t[0] += time.process_time() - t0
            t[1] += 1
            return out
        tag = "/".join(fr.function for fr in inspect.stack()[1:6] if "mrhyst" in fr.filename
                       and fr.function not in ("lm", "_fit_batch", "lm_", "mfit_"))
        c = {"tag": tag, "groups": cur["groups"], "hist": [], "ftol": kw.get("ftol"), "max_iter": kw.get("max_iter")}
        cur["groups"], cur["hist"] = None, c["hist"]
        t0 = time.process_time()
        res = lsb(f, x0, *a, **kw)
        c.update(cpu=time.process_time() - t0, cpu_model=t[0], model_calls=t[1], final=res.cost.copy(), N=len(res.cost))
        cur["hist"] = None
        calls.append(c)
        return res

    def random_starts_(prob, mask, seed):
        out = rstarts(prob, mask, seed)
        cur["seeds"].append(len(out))
        return out

    def lm_(self, U0, effects_rows, W, max_iter=None, ftol=problem.LM_FTOL):
        U0a = np.atleast_2d(np.asarray(U0, dtype=float))
        Wb = np.broadcast_to(np.asarray(W, dtype=float), (U0a.shape[0], self.sw.n))
        keys = {}
        g = [keys.setdefault((tuple(e), Wb[i].tobytes()), len(keys)) for i, e in enumerate(effects_rows)]
        if cur["seeds"] and sum(cur["seeds"]) == len(g):  # the plain fit: the best start per seed is kept
            g = np.repeat(np.arange(len(cur["seeds"])), cur["seeds"]).tolist()
        cur["seeds"] = []
        cur["groups"] = np.array(g)
        return plm(self, U0, effects_rows, W, max_iter=max_iter, ftol=ftol)

    def mfit_(jobs, max_iter, ftol):
        keys = {}
        W = np.vstack([w for _, _, w in jobs])
        cur["groups"] = np.array([keys.setdefault(W[i].tobytes(), len(keys)) for i in range(W.shape[0])])
        out = mfit(jobs, max_iter, ftol)
        calls[-1]["tag"] = f"modelform {'+'.join(m.name for m, _, _ in jobs)}: " + calls[-1]["tag"]
        return out

    lm._accept, problem.least_squares_batch, modelform.least_squares_batch = accept_, lsb_, lsb_
    problem.Problem.lm, modelform._fit_batch, candidates.random_starts = lm_, mfit_, random_starts_
    out = {}
    for c in cases:
        calls.clear()
        t0 = time.process_time()
        d = one(Path(c))
        out[str(c)] = {"cpu": time.process_time() - t0, "effect": d["effect"], "calls": list(calls)}
        print(f"{c}: {d['effect']} {out[str(c)]['cpu']:.2f} CPU s", flush=True)
    return out


def _calls(data):
    return [(c, call) for d in data for c, v in d.items() for call in v["calls"] if call["hist"]]


def _kind(call) -> str:
    return call["tag"].split("/")[0]


def per_caller(calls) -> None:
    agg = collections.defaultdict(lambda: np.zeros(6))
    for _, c in calls:
        agg[_kind(c)] += [1, len(c["hist"]), c["cpu"], c["cpu_model"], c["model_calls"], c["N"]]
    print(f"{'caller':44s} {'calls':>5s} {'iters':>6s} {'LM s':>6s} {'model s':>7s} {'model calls':>11s} {'rows':>6s}")
    for k, a in sorted(agg.items(), key=lambda x: -x[1][2]):
        print(f"{k[:44]:44s} {a[0]:5.0f} {a[1]:6.0f} {a[2]:6.2f} {a[3]:7.2f} {a[4]:11.0f} {a[5]:6.0f}")


def prune(calls, t0: int, f: float) -> tuple:
    """(iterations, kept, row-iterations, kept, pruned, would have won, ... by > 1e-6, ... by > 1e-3)."""
    it0 = it1 = r0 = r1 = pruned = 0
    won = np.zeros(3, dtype=int)
    for _, c in calls:
        g, fin = c["groups"], np.where(np.isfinite(c["final"]), c["final"], np.inf)
        if g is None or len(np.unique(g)) == len(g):
            continue
        alive, last = np.ones(c["N"], dtype=bool), 0
        for t, (live, cost, _, done) in enumerate(c["hist"]):
            lv = live[alive[live]]
            r0, r1 = r0 + live.size, r1 + lv.size
            last = t + 1 if lv.size else last
            if t + 1 < t0:
                continue
            cf = np.where(np.isfinite(cost), cost, np.inf)
            for i in lv:
                grp = np.flatnonzero(g == g[i])
                if done[i] or not cf[i] > (1 + f) * cf[grp][alive[grp]].min():
                    continue
                alive[i], pruned = False, pruned + 1
                others = fin[grp[grp != i]].min()
                if fin[i] <= others:
                    gain = (others - fin[i]) / max(fin[i], 1e-300)
                    won += [1, gain > 1e-6, gain > 1e-3]
        it0, it1 = it0 + len(c["hist"]), it1 + last
    return it0, it1, r0, r1, pruned, *won


def tails(calls, tol: float) -> tuple:
    it0 = it1 = 0
    for _, c in calls:
        fin, N, H = c["final"], c["N"], c["hist"]
        stop = np.full(N, len(H))
        for t, (live, cost, _, _) in enumerate(H):
            ok = np.zeros(N, dtype=bool)
            ok[live] = (cost[live] - fin[live]) <= tol * np.abs(fin[live])
            stop[ok & (stop == len(H))] = t + 1
        last = np.zeros(N, dtype=int)
        for t, (live, *_) in enumerate(H):
            last[live] = t + 1
        it0, it1 = it0 + len(H), it1 + int(np.minimum(stop, last).max())
    return it0, it1


def own_cycles(calls) -> tuple:
    now = own = 0
    for _, c in calls:
        need, prev, per = np.ones(c["N"], dtype=bool), None, np.zeros(c["N"])
        for live, cost, _, _ in c["hist"]:
            if prev is not None:
                need = cost < prev
            now += 2 + int(need[live].any())
            per[live] += 2 + need[live]
            prev = cost
        own += per.max()
    return now, own


def report(paths) -> None:
    data = [pickle.load(open(p, "rb")) for p in paths]
    calls = _calls(data)
    cpu = sum(v["cpu"] for d in data for v in d.values())
    lm_cpu, model = sum(c["cpu"] for _, c in calls), sum(c["cpu_model"] for _, c in calls)
    print(f"{sum(len(d) for d in data)} diagnoses, {cpu:.1f} CPU s; in the LM {lm_cpu:.1f} s, of which the model "
          f"{model:.1f} s; {len(calls)} LM calls\n")
    per_caller(calls)
    print("\nstart pruning (rows above (1 + f) x their group's best after t0 iterations stop):")
    for t0 in (5, 10, 20, 30):
        for f in (1.0, 10.0, 100.0):
            it0, it1, r0, r1, p, w, w6, w3 = prune(calls, t0, f)
            print(f"  t0 {t0:2d} f {f:5.0f}: iterations x{it1 / it0:.3f}, row-iterations x{r1 / r0:.3f}; pruned {p}, "
                  f"of which would have won {w} (by > 1e-6: {w6}, > 1e-3: {w3})")
    for tol in (1e-6, 1e-4):
        it0, it1 = tails(calls, tol)
        print(f"tails: each row stopped within {tol:g} of its final cost (oracle): iterations {it0} -> {it1} "
              f"(x{it1 / it0:.3f})")
    now, own = own_cycles(calls)
    print(f"model calls, lock-step {now} vs each row its own cycle {own:.0f} (x{own / now:.3f})")
    hist = collections.Counter()
    for _, c in calls:
        for live, *_ in c["hist"]:
            n = live.size
            hist["1" if n == 1 else "2-4" if n <= 4 else "5-16" if n <= 16 else "17-64" if n <= 64 else ">64"] += 1
    tot = sum(hist.values())
    print("live rows per iteration: " + ", ".join(f"{k}: {hist[k] / tot:.3f}" for k in
                                                   ("1", "2-4", "5-16", "17-64", ">64")))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("out")
    r.add_argument("cases", nargs="+")
    p = sub.add_parser("report")
    p.add_argument("pickles", nargs="+")
    a = ap.parse_args(argv)
    if a.cmd == "run":
        with open(a.out, "wb") as fh:
            pickle.dump(_record(a.cases), fh)
    else:
        report(a.pickles)
    return 0


if __name__ == "__main__":
    sys.exit(main())
