"""The diagnosis of one channel: fit (plain J-A, every effect, pairs, model form), gather the evidence,
let the policy decide, write the contract. See the package docstring."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mrhyst.data.io import write_json
from mrhyst.diagnose import candidates as cd
from mrhyst.diagnose import contract, modelform, nextmeas, policy
from mrhyst.diagnose.problem import Fit, Problem, best, candidates, n_params
from mrhyst.diagnose.settings import resolve_config
from mrhyst.diagnose.sweep import Sweep, load_sweep, noise_floor, sweep_from_bh
from mrhyst.model import effects as fx
from mrhyst.model import ja


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
    skip = skipped_effects(prob.sw)
    cands_e = [e for e in candidates() if e not in skip and not (e == "thermal_drift" and not prob.dt > 0)]
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


def other_pairs(ev: dict, fits: dict, prim: list, n: int, bic_margin: float) -> list:
    """Pairs without the leader (and the tied ones): the leader may only mimic the sum of two others (a
    creeping zero and a remanent start at high drive look like one constant offset). Each of the ``n`` next
    best effects that earn alone, with every other effect; the better single first."""
    C = ev["candidates"]
    earn = sorted((e for e in fits if e not in prim and C[e]["delta_bic"] > bic_margin), key=lambda e: C[e]["bic"])
    return list(dict.fromkeys(tuple(sorted((a, b), key=lambda e: C[e]["bic"]))
                              for a in earn[:n] for b in fits if b not in prim and b != a))


def pair_stage(prob: Problem, ev: dict, fits: dict, lead: str, amb: list) -> dict:
    """J-A + two effects on top of the leader (and the tied ones), and :func:`other_pairs` of the runner-up
    (an effect confounded with the leader, a Hall offset with a remanent start, gets its own pair: a tie is
    then reported, not hidden); of the next ``cv_max_candidates`` earners when no pair on top of the leader
    closes the gap (``close_factor`` x the floor). {pair: Fit}; statistics into ``ev``."""
    cfg, v = prob.cfg, prob.sw.valid
    nv, floor = int(v.sum()), float(cfg["rss_floor_T"])
    prim = [lead, *amb]
    models = [(p, e2) for p in prim for e2 in fits if e2 not in prim] + [(lead, e2) for e2 in amb]
    f2s = cd.fit_augmented(prob, models, [[fits[m[0]], fits[m[1]]] for m in models])
    closed = min(f.rms for f in f2s.values()) <= float(cfg["close_factor"]) * ev["noise_floor_T"]
    more = other_pairs(ev, fits, prim, 1 if closed else int(cfg["cv_max_candidates"]), float(cfg["bic_margin"]))
    if more:
        f2s.update(cd.fit_augmented(prob, more, [[fits[m[0]], fits[m[1]]] for m in more]))
        models += more
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


def diagnose(sweep: Sweep, config=None, *, form: str | None = None, seed: int | None = None,
             ja_fit: dict | None = None) -> dict:
    """The diagnosis of one channel (a JSON-ready dict; see the package docstring).

    ``config``: the ``diagnose:`` section or its resolved :class:`DiagnoseSettings`; ``form``, ``seed``: given
    (not None), they override it (:func:`resolve_config`); the settings that ran are what the JSON records.
    ``ja_fit``: optional J-A parameters {Ms, a, alpha, c, k} of a fit made elsewhere (e.g. by
    ``mrhyst fit``); it is then "this fit" of the gap budget, the one whose optimizer shortfall is
    measured. Without it, this fit is the multi-start fit of ``seed``.
    """
    cfg = resolve_config(config, form=form, seed=seed)
    form, seed = cfg.form, cfg.seed
    prob = Problem(sweep, cfg)
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
        ev["model_form"] = {k: {kk: vv for kk, vv in m.items() if kk not in ("B_T", "x")} for k, m in mf_fits.items()}
    bound = best_field_bound(prob, base, fits, mf_fits, sigma, float(th["time_bound_min_sigma"]))
    ev["repeat"] = repeat_evidence(sweep, sweep.B - bound, sigma)
    verdict = policy.decide(ev, th)
    out = contract.build(prob, cfg, form, seed, plain, base, fits, pair_fits, mf_fits, ev, verdict, escalated)
    out["input"].update(protocol=protocol_text(sweep), kind=sweep.kind)
    out["skipped"] = skipped_effects(sweep)
    nm = nextmeas.next_measurement(prob, verdict, ev, base, fits, mf_fits)
    if nm is not None:
        out["next_measurement"] = contract.clean(nm)
    return out


def skipped_effects(sweep: Sweep) -> dict:
    """{effect: why} for the effects this sweep cannot judge: without sample times an eddy lag per step and a
    drift per second have no time axis; a third-party B(H) loop is simulated from a cyclic start (its path
    run before it), so its start state is part of the baseline, not a remanent start to name."""
    out = {}
    if not sweep.has_time:
        out["eddy_lag"] = "no sample times in the file: an eddy lag per current step needs them"
        out["thermal_drift"] = "no sample times in the file: a drift per second needs them"
    if sweep.kind == "bh":
        out["remanent_start"] = ("third-party B(H) loop: simulated in cyclic steady state (the path run twice "
                                 "before it), so its start state is not a free effect")
    return out


def protocol_text(sweep: Sweep) -> str:
    from mrhyst.data import loops

    cur = sweep.current[sweep.start:]
    n_rev, n_cyc = loops.reversals(cur), int(loops.cycle_index(cur).max()) + 1
    bip = bool(np.min(cur) < 0 < np.max(cur))
    if n_rev == 1 and not bip:
        return "0 -> max -> 0 (one ascent, one descent)"
    return f"{'bipolar' if bip else 'unipolar'} path, {n_rev} reversals, {n_cyc} cycle(s)"


def best_field_bound(prob: Problem, base: Fit, fits: dict, mf_fits: dict, sigma: float | None = None,
                     min_sigma: float | None = None) -> np.ndarray:
    """B of the best explanation that does not grow with time (plain J-A, a field-bound effect, a model-form
    candidate): lowest RSS over the fitted samples. A model-form fit whose own B changes from one cycle to the
    next by >= ``min_sigma`` standard errors (:func:`repeat_evidence` of its B, noise ``sigma``) is left out: a
    second phase far from its cyclic steady state follows a slow drift's growth over two cycles (measured on
    the bipolar blind variant: physical-rate drifts named model_form two_phase), so it is no field-bound
    explanation of that sweep."""
    v = prob.sw.valid
    rows = [base.B] + [f.B for e, f in fits.items() if f.ok and not fx.REGISTRY[e].time_bound]
    for m in mf_fits.values():
        own = None if sigma is None or min_sigma is None else repeat_evidence(prob.sw, np.asarray(m["B_T"]), sigma)
        if own is None or own["time_bound_sigma"] < min_sigma:
            rows.append(m["B_T"])
    rss = [float(np.sum((prob.sw.B[v] - np.asarray(b)[v]) ** 2)) for b in rows]
    return np.asarray(rows[int(np.argmin(rss))])


def repeat_evidence(sweep: Sweep, resid, sigma: float) -> dict | None:
    """Repeated cycles separate time from field (issue 13): the residual of the best field-bound explanation
    (:func:`best_field_bound`) at the same (current, direction) one cycle later, the first branch (a virgin
    curve) left out. A gap that is bound to the field repeats (difference ~ noise); a drift grows with time
    (the difference has a mean of drift x cycle period, which no field-bound model can follow). Returns the
    mean difference in units of its standard error (``time_bound_sigma``) and the RMS difference over the
    noise expected of a difference, or None without repeated cycles."""
    from mrhyst.data import loops

    cyc = loops.cycle_index(sweep.current)
    dirs = loops.directions(sweep.current)
    v = sweep.valid.copy()
    v[: loops.segments(sweep.current)[0].stop + 1] = False  # the first branch (a virgin curve) never repeats
    d = []
    for c in range(1, int(cyc.max()) + 1):
        prev = {(round(float(sweep.current[j]), 12), int(dirs[j])): j for j in np.flatnonzero((cyc == c - 1) & v)}
        for j in np.flatnonzero((cyc == c) & v):
            k = prev.get((round(float(sweep.current[j]), 12), int(dirs[j])))
            if k is not None:
                d.append(float(resid[j] - resid[k]))
    if len(d) < 4 or not sigma > 0:
        return None
    d = np.asarray(d)
    se = math.sqrt(2.0) * sigma / math.sqrt(d.size)
    return {"n_pairs": int(d.size), "mean_diff_T": float(np.mean(d)), "rms_diff_T": float(np.sqrt(np.mean(d * d))),
            "time_bound_sigma": float(abs(np.mean(d)) / se),
            "repeat_ratio": float(np.sqrt(np.mean(d * d)) / (math.sqrt(2.0) * sigma))}


def diagnose_file(raw_path, sensor: str, out=None, form: str | None = None, seed: int | None = None,
                  config=None, ja_fit: dict | None = None) -> dict:
    """``mrhyst diagnose RAW.csv --sensor S --out DIAG.json``: read, diagnose, write (atomic). ``form``,
    ``seed``: None = the config's (:func:`resolve_config`)."""
    cfg = resolve_config(config, form=form, seed=seed)
    sweep = load_sweep(raw_path, sensor, cfg)
    d = diagnose(sweep, cfg, ja_fit=ja_fit)
    if out is not None:
        write_json(d, Path(out))
    return d


def bh_config(cfg, sweep: Sweep):
    """The diagnosis settings for a third-party B(H) loop: J-A's random starts scaled to the loop (soft
    ferrites have a, k of a few A/m, the start box of the Hall sweeps 1e2-1e5 A/m)."""
    v = sweep.valid
    hmax = float(np.max(np.abs(sweep.current[v])))
    ms = float(np.max(np.abs(sweep.B[v]))) / float(ja.MU0)
    sb = dict(cfg["start_box"])
    sb.update(Ms=[0.5 * ms, 3.0 * ms], a=[0.01 * hmax, 2.0 * hmax], k=[0.01 * hmax, 2.0 * hmax])
    box = dict(cfg["box"])
    box.update(a=[min(box["a"][0], 1e-3 * hmax), box["a"][1]], k=[min(box["k"][0], 1e-3 * hmax), box["k"][1]])
    return cfg.replace(start_box=sb, box=box)


def diagnose_bh_file(path, loop_index: int | None = None, out=None, form: str | None = None,
                     seed: int | None = None, config=None) -> dict:
    """``mrhyst diagnose BH.csv [--loop-index N] --out DIAG.json``: a third-party B(H) loop. The project's
    materials fit (:func:`mrhyst.materials.external.fit_path`, cyclic start) gives plain J-A one more start: a soft
    material's optimum lies far from the random starts made for Hall sweeps."""
    from mrhyst.materials import external

    cfg = resolve_config(config, form=form, seed=seed)
    sweep = sweep_from_bh(path, loop_index, cfg)
    m = sweep.valid
    ext = external.fit_path(sweep.current[m], sweep.B[m], start="cyclic")
    d = diagnose(sweep, bh_config(cfg, sweep), ja_fit=ext["params"])
    d["input"].update(loop_index=loop_index, n_file_samples=None, decimated_to=int(m.sum()),
                      conditioning_passes=int(cfg["bh"]["conditioning_passes"]))
    if out is not None:
        write_json(d, Path(out))
    return d


def summary_row(d: dict) -> dict:
    """One table row of a diagnosis: the verdict and its figures (the report's appendix, ``external_diagnose``)."""
    mf = d.get("model_form") or {}
    nm = d.get("next_measurement") or {}
    return {"effect": d["effect"], "ambiguous_with": ",".join(d.get("ambiguous_with") or []),
            "model_form_best": mf.get("best"), "model_form_rms_T": mf.get("rms_after_T"),
            "rms_before_T": d["rms_before_T"], "rms_after_T": d["rms_after_T"], "noise_floor_T": d["noise_floor_T"],
            "largest_share_before": d["where"].get("largest_share_before"),
            "next_measurement": nm.get("protocol"), "separation_sigma": nm.get("separation_sigma"),
            "skipped": ",".join(sorted(d.get("skipped") or {})), "verdict": d["verdict"]}


def diagnose_bh_source(path, config=None, seed: int | None = None, log=print) -> list[dict]:
    """Every loop of a third-party B(H) file diagnosed: [{"loop_index", "n_samples", **summary_row}]. The wall
    clock of each diagnosis (the issue's goal: <= 30 s per loop) goes to ``log``, not into the rows, so that
    the rows stay the same bytes from run to run."""
    import time

    from mrhyst.data.io import loop_indices, read_loops

    rows = []
    for idx in loop_indices(read_loops(path)):
        t0 = time.perf_counter()
        d = diagnose_bh_file(path, idx, seed=seed, config=config)
        log(f"{path} loop_index {idx}: {d['effect']} in {time.perf_counter() - t0:.1f} s")
        rows.append({"loop_index": idx, "n_samples": d["input"]["decimated_to"], **summary_row(d)})
    return rows
