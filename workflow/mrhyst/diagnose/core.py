"""The diagnosis of one channel: fit (plain J-A, every effect, pairs, model form), gather the evidence,
let the policy decide, write the contract. See the package docstring."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import effects as fx
from .. import ja
from ..io import InputError, write_json
from . import candidates as cd
from . import contract, modelform, policy
from .problem import Fit, Problem, best, candidates, n_params
from .settings import resolve_config
from .sweep import Sweep, load_sweep, noise_floor


def plain_stage(prob: Problem, seed: int, ja_fit: dict | None) -> dict:
    """Plain J-A: this fit (seed or the given one), other seeds, the best."""
    cfg, v = prob.cfg, prob.sw.valid
    seeds = [int(seed) + s for s in range(max(int(cfg["budget_seeds"]), 1))]
    by_seed = cd.fit_plain(prob, seeds)
    this = by_seed.get(int(seed)) or best(list(by_seed.values()))
    src = f"multi-start least squares, seed {seed}"
    plain = list(by_seed.values())
    if ja_fit is not None:
        u = prob.null.copy()
        u[:5] = [math.log(ja_fit["Ms"]), math.log(ja_fit["a"]), ja_fit["alpha"], ja_fit["c"], math.log(ja_fit["k"])]
        c, Bt = prob.cost(u[None, :], v.astype(float))
        this = Fit((), u, float(c[0]) * 1e-6, int(v.sum()), bool(np.isfinite(c[0])), Bt[0])
        src = "given fit"
        plain += prob.lm(u[None, :], [()], v.astype(float))
    return {"this": this, "this_src": src, "base": best(plain), "seeds": seeds}


def polish(prob: Problem, base: Fit, fits: dict) -> Fit:
    """Plain J-A refitted from the leading candidates' J-A part: no candidate may win only because it found
    a better J-A optimum than the plain multi-start did (the worse candidates are then refitted from it)."""
    v = prob.sw.valid
    lead = sorted(fits, key=lambda e: fits[e].rss)[: int(prob.cfg["cv_max_candidates"])]
    pol = best(prob.lm(np.array([prob.embed(fits[e].u, ()) for e in lead]), [()] * len(lead), v.astype(float)))
    if pol.ok and pol.rss < base.rss * (1 - 1e-9):
        base = pol
        worse = [e for e in fits if fits[e].rss > base.rss]
        if worse:
            fits.update({e: f for (e,), f in cd.fit_augmented(prob, [(e,) for e in worse], base).items()})
    return base


def single_stage(prob: Problem, base: Fit) -> tuple[Fit, dict]:
    """Every candidate effect refitted from the plain fit; cross-seeded among the leaders when one earns."""
    cands_e = [e for e in candidates() if not (e == "thermal_drift" and not prob.dt > 0)]
    fits = {e: f for (e,), f in cd.fit_augmented(prob, [(e,) for e in cands_e], base).items()}
    base = polish(prob, base, fits)
    sc = cd.score(prob, base, fits)
    if max(c["delta_bic"] for c in sc.values()) > float(prob.cfg["bic_margin"]):
        # two effects that explain a loop alike (an offset and a remanent start) then reach the same quality
        lead = sorted(fits, key=lambda e: fits[e].rss)[: int(prob.cfg["cv_max_candidates"])]
        cross = cd.fit_augmented(prob, [(e,) for e in lead], [[fits[f] for f in lead if f != e] for e in lead])
        for (e,), f in cross.items():
            if f.ok and f.rss < fits[e].rss:
                fits[e] = f
    return base, fits


def evidence(prob: Problem, base: Fit, fits: dict, sigma: float) -> dict:
    """Statistics of plain J-A and every candidate: BIC, RMS, sizes, plausibility; held-out errors (all three
    schemes) of plain J-A and of the leading ``cv_max_candidates`` candidates that earn the BIC margin."""
    cfg = prob.cfg
    sc = cd.score(prob, base, fits)
    lead = sorted([e for e in sc if sc[e]["delta_bic"] > float(cfg["bic_margin"])],
                  key=lambda e: -sc[e]["delta_bic"])[: int(cfg["cv_max_candidates"])]
    ho = cd.holdout(prob, {"none": base, **{e: fits[e] for e in lead}})
    for e in lead:
        sc[e].update(ho[e])
    nv = int(prob.sw.valid.sum())
    none = {"rms_T": base.rms, "bic": cd.bic(base.rss, nv, 5, float(cfg["rss_floor_T"])), **ho["none"]}
    return {"n": nv, "noise_floor_T": sigma, "none": none, "candidates": sc, "pairs": [], "model_form": {}}


def pair_stage(prob: Problem, ev: dict, fits: dict, lead: str, amb: list) -> dict:
    """J-A + two effects on top of the leader (and the tied ones): {pair: Fit}; statistics into ``ev``."""
    cfg, v = prob.cfg, prob.sw.valid
    nv, floor = int(v.sum()), float(cfg["rss_floor_T"])
    prim = [lead, *amb]
    models = [(p, e2) for p in prim for e2 in fits if e2 not in prim] + [(lead, e2) for e2 in amb]
    f2s = cd.fit_augmented(prob, models, [[fits[m[0]], fits[m[1]]] for m in models])
    stats = {m: {"effects": list(m), "rms_T": f.rms, "bic": cd.bic(f.rss, nv, n_params(m), floor),
                 "branch_identifiable": all(fx.REGISTRY[e].branch_identifiable for e in m),
                 "block_identifiable": all(fx.REGISTRY[e].block_identifiable for e in m),
                 **cd.plausibility(prob, f, m), "params": prob.physical(f.u, m)[1]} for m, f in f2s.items()}
    top = sorted(stats, key=lambda m: stats[m]["bic"])[: int(cfg["cv_max_candidates"])]
    ho = cd.holdout(prob, {m: f2s[m] for m in top})
    for m in top:
        stats[m].update(ho[m])
    ev["pairs"] = [stats[m] for m in models]
    return f2s


def diagnose(sweep: Sweep, config: dict | None = None, *, form: str | None = None, seed: int = 0,
             ja_fit: dict | None = None) -> dict:
    """The diagnosis of one channel (a JSON-ready dict; see the package docstring).

    ``ja_fit``: optional J-A parameters {Ms, a, alpha, c, k} of a fit made elsewhere (e.g. by
    ``mrhyst fit``); it is then "this fit" of the gap budget, the one whose optimizer shortfall is
    measured. Without it, this fit is the multi-start fit of ``seed``.
    """
    cfg = resolve_config(config)
    form = form or cfg["form"]
    if form not in ja.FORMS:
        raise InputError(f"form must be one of {', '.join(ja.FORMS)}, got {form!r}")
    prob = Problem(sweep, cfg, form)
    th = policy.thresholds_from(cfg)
    plain = plain_stage(prob, seed, ja_fit)
    base, fits = single_stage(prob, plain["base"])
    sigma = noise_floor(sweep.B - base.B, sweep, float(cfg["noise_clip"]))
    ev = evidence(prob, base, fits, sigma)
    verdict = policy.decide(ev, th)
    lead = verdict["leader"]
    escalated = False
    if (fits[lead] if lead else base).rms > float(cfg["unexplained_factor"]) * sigma:
        escalated = True  # structure left: every candidate searched again from random J-A starts
        if cd.deep_search(prob, fits, seed):
            base = polish(prob, base, fits)
            sigma = noise_floor(sweep.B - base.B, sweep, float(cfg["noise_clip"]))
            ev = evidence(prob, base, fits, sigma)
            verdict = policy.decide(ev, th)
            lead = verdict["leader"]
    pair_fits = {}
    if lead and fits[lead].rms > float(cfg["secondary_factor"]) * sigma:
        amb = [e for e in policy.earners(ev, th)[0] if e != lead
               and ev["candidates"][e]["bic"] - ev["candidates"][lead]["bic"] < th["tie_margin"]]
        pair_fits = pair_stage(prob, ev, fits, lead, amb)
    mf_fits = {}
    if (lead or base.rms > float(cfg["close_factor"]) * sigma) and cfg["model_form"]["candidates"]:
        mf_fits = modelform.fit_all(prob, base, seed)
        ev["model_form"] = {k: {kk: vv for kk, vv in m.items() if kk != "B_T"} for k, m in mf_fits.items()}
    verdict = policy.decide(ev, th)
    return contract.build(prob, cfg, form, seed, plain, base, fits, pair_fits, mf_fits, ev, verdict, escalated)


def diagnose_file(raw_path, sensor: str, out=None, form: str = "physical", seed: int = 0,
                  config: dict | None = None, ja_fit: dict | None = None) -> dict:
    """``mrhyst diagnose RAW.csv --sensor S --out DIAG.json``: read, diagnose, write (atomic)."""
    cfg = resolve_config(config)
    sweep = load_sweep(raw_path, sensor, cfg)
    d = diagnose(sweep, cfg, form=form, seed=seed, ja_fit=ja_fit)
    if out is not None:
        write_json(d, Path(out))
    return d
