"""The selection policy: a pure function from the candidates' fitted statistics (the ``evidence`` block
of a diagnosis) to a verdict. No fitting here: a saved diagnosis can be decided again with other
thresholds (the blind benchmark's trade-off curve does exactly that).

``decide(evidence, thresholds) -> verdict``. The rule (issues 6 and 12):

1. **Earns its parameters**: BIC = n ln(RSS/n) + p ln n drops by more than ``bic_margin`` against plain J-A
   AND the interleaved K-fold CV error is below plain J-A's (a candidate without a CV figure was not
   among the leaders cross-validated and does not earn). The earner with the lowest BIC leads; earners
   within ``tie_margin`` of it are ``ambiguous_with`` it.
2. **A second effect** on top of the leader (or of a tied one) is taken from ``evidence["pairs"]`` when
   the leader leaves more than ``secondary_factor`` x the noise floor and the pair's BIC beats the
   leader's by ``bic_margin``; it is *accepted* when the pair's interleaved CV beats its primary's. A pair
   of two other effects replaces the leader when it beats every pair on top of the leader by more than
   ``tie_margin`` (:func:`secondary`); pairs within ``tie_margin`` of the chosen one are its
   ``ambiguous_with``.
3. **The evidence rule for naming a measurement-chain effect** (issue 12). The leader (with an accepted
   second effect) is named only if it also
   (a) *closes the gap*: RMS after <= ``close_factor`` x the noise floor;
   (b) *predicts out of sample no worse than plain J-A* (the named effect with its accepted second effect,
       or on its own): contiguous-block CV <= ``blocks_factor`` x plain's (or, with ``blocks_majority``, most
       blocks predicted better than plain J-A's, each on its own: :func:`blocks_won`)
       and the branch hold-out <= ``heldout_factor`` x plain's (a scheme does not judge an effect the registry
       marks as not identifiable by it: a drift rate over time cannot be told from J-A's shape on one branch,
       ``branch_identifiable``; a remanent start shows only in the first samples, which one contiguous block
       holds whole, ``block_identifiable``);
   (c) *has a plausible size* for that sweep and sensor (``require_plausible``): the sizes the verdict reports,
       both of the pair as it fitted them when a second effect is accepted (the named effect fitted alone may
       have bent to absorb the second), else the effect's own;
   (e) on repeated cycles (``evidence["repeat"]``), a *time-bound* effect (a drift) must show in the plain
       fit's residual growing from one cycle to the next at the same (current, direction) by at least
       ``time_bound_min_sigma`` standard errors; a gap that repeats cycle after cycle is field-bound;
   (d) *beats model-form physics*: its BIC is lower than every model-form candidate's by at least
       ``model_form_margin`` (a measurement fault is blamed only when physics J-A leaves out cannot explain
       the loop about as well: on the calibration set the true effect beat the best model-form candidate by
       >= 11 in BIC on every closed-world case, most false attributions of an open-world gap by < 5).
4. Otherwise, or with no earner: a **model-form** candidate that earns (BIC margin) and passes (a) and (b)
   is named as ``model_form`` (lowest BIC); else ``none`` when plain J-A is within ``unexplained_factor``
   of the noise floor, else ``unexplained``. When a leader or a model-form candidate failed the rule,
   ``partial`` says what explains how much of the excess over the noise floor.
"""

from __future__ import annotations

import math

from mrhyst.model import effects as fx

THRESHOLD_KEYS = ("bic_margin", "tie_margin", "unexplained_factor", "secondary_factor", "close_factor",
                  "heldout_factor", "blocks_factor", "blocks_majority", "require_plausible", "model_form_margin",
                  "time_bound_min_sigma")


def thresholds_from(cfg: dict) -> dict:
    """The policy's thresholds out of a diagnose config (or its defaults)."""
    return {k: cfg[k] for k in THRESHOLD_KEYS}


def _default_thresholds() -> dict:
    from mrhyst.diagnose.settings import defaults

    return thresholds_from(defaults())


DEFAULT_THRESHOLDS = _default_thresholds()


def _v(x, missing=math.inf) -> float:
    return missing if x is None else float(x)


def excess(rms, sigma: float):
    if rms is None or not math.isfinite(rms):
        return None
    return math.sqrt(max(rms * rms - sigma * sigma, 0.0))


def removed_frac(ex0, ex1):
    return (ex0 - ex1) / ex0 if ex0 is not None and ex1 is not None and ex0 > 0 else None


def earners(ev: dict, th: dict) -> tuple[list, dict]:
    """(earners sorted by BIC, reason per candidate)."""
    cv0 = _v(ev["none"].get("cv_interleaved_T"))
    out, why = [], {}
    for e, c in ev["candidates"].items():
        if not c["delta_bic"] > th["bic_margin"]:
            why[e] = f"does not earn its parameters (delta BIC {c['delta_bic']:.1f} <= margin {th['bic_margin']:g})"
        elif c.get("cv_interleaved_T") is None:
            why[e] = "earns its parameters by BIC but is not among the leading ones cross-validated"
        elif not c["cv_interleaved_T"] < cv0:
            why[e] = (f"earns its parameters by BIC but does not predict held-out samples better (interleaved CV "
                      f"RMS {c['cv_interleaved_T'] * 1e3:.4f} mT vs {cv0 * 1e3:.4f} mT plain)")
        else:
            why[e] = "earns its parameters (BIC margin and interleaved cross-validation)"
            out.append(e)
    return sorted(out, key=lambda e: ev["candidates"][e]["bic"]), why


def ambiguity_reason(C: dict, effect: str, amb: list, tie: float) -> str:
    """Why the effects in ``amb`` cannot be told apart from ``effect``."""
    why = "; ".join(
        f"{e} fits almost as well (BIC {C[e]['bic'] - C[effect]['bic']:+.1f} vs {effect}, within the tie "
        f"margin {tie:g}; block CV RMS {_v(C[e].get('cv_blocks_T'), math.nan) * 1e3:.4f} vs "
        f"{_v(C[effect].get('cv_blocks_T'), math.nan) * 1e3:.4f} mT)" for e in amb)
    for text in fx.confusions({*amb, effect}) if amb else ():  # the registry's confused_with
        why += "; " + text
    return why


def secondary(ev: dict, th: dict, effect: str, amb: list) -> dict | None:
    """The second effect: the best pair (J-A + two effects), when it beats the leader by ``bic_margin``.

    Pairs on top of the leader (or a tied one) are preferred; a pair of two other effects is taken instead
    only when it beats every such pair by more than ``tie_margin`` (two effects that each explain part of the
    loop, while the leader alone mimics their sum: a creeping zero plus a remanent start look like a constant
    offset at high drive). The lowest BIC in that pool is chosen; every fitted pair within ``tie_margin``
    of it is ``ambiguous_with`` it (a Hall offset and a remanent start stay confounded on one 0 -> max -> 0
    sweep, with a second effect as alone)."""
    sig, C = ev["noise_floor_T"], ev["candidates"]
    if not _v(C[effect]["rms_T"]) > th["secondary_factor"] * sig:
        return None
    pairs = [p for p in ev.get("pairs", []) if p.get("bic") is not None and math.isfinite(p["bic"])]
    if not pairs:
        return None
    b1 = C[effect]["bic"]
    prim = [effect, *amb]
    own = [p for p in pairs if p["effects"][0] in prim]
    other = [p for p in pairs if p["effects"][0] not in prim]
    b_own = min((p["bic"] for p in own), default=math.inf)
    b_other = min((p["bic"] for p in other), default=math.inf)
    pool = other if b_other < b_own - th["tie_margin"] else own
    bbest = min(p["bic"] for p in pool)
    if not b1 - bbest > th["bic_margin"]:
        return None
    p = min((q for q in pool if q["bic"] == bbest), key=lambda q: tuple(q["effects"]))
    tied = sorted((q for q in pairs if q is not p and q["bic"] - bbest < th["tie_margin"]),
                  key=lambda q: (q["bic"], tuple(q["effects"])))
    first = p["effects"][0]
    accepted = _v(p.get("cv_interleaved_T")) < _v(C[first].get("cv_interleaved_T"))
    return {"pair": p, "primary": first, "effect": p["effects"][1], "accepted": bool(accepted),
            "delta_bic_over_primary": C[first]["bic"] - p["bic"], "gain_over_leader": b1 - p["bic"],
            "ambiguous_with": [q["effects"] for q in tied], "swapped": pool is other}


def blocks_won(st: dict, none: dict) -> bool | None:
    """Does the model predict most contiguous blocks better than plain J-A (each block's own RMS, a sign test over
    the folds)? None when the evidence has no per-block errors (saved before they were recorded)."""
    f1, f0 = st.get("cv_blocks_folds_T"), none.get("cv_blocks_folds_T")
    if not f1 or not f0 or len(f1) != len(f0):
        return None
    return 2 * sum(_v(a) < _v(b) for a, b in zip(f1, f0)) > len(f0)


def _predicts(th: dict, none: dict, st: dict) -> dict:
    """(b) for one model's statistics: branch hold-out and contiguous-block CV against plain J-A's. The pooled
    block RMS is ruled by its worst block, and one block of a sweep is an extrapolation the others do not pin (the
    end of the descending branch, its remanence; the virgin start) where any added parameter may swing; with
    ``blocks_majority`` a model that predicts most blocks better passes too (a mimic of a shape wins only the
    stretch it was bent to fit)."""
    pooled = _v(st.get("cv_blocks_T")) <= th["blocks_factor"] * _v(none.get("cv_blocks_T"))
    return {"predicts_branch": (not st.get("branch_identifiable", True)
                                or _v(st.get("heldout_T")) <= th["heldout_factor"] * _v(none.get("heldout_T"))),
            "predicts_blocks": (not st.get("block_identifiable", True) or pooled
                                or bool(th.get("blocks_majority") and blocks_won(st, none)))}


def rule_checks(ev: dict, th: dict, stats: dict, plausible: bool, alone: dict | None = None) -> dict:
    """(a) closes, (b) predicts, (c) plausible, (d) beats model form: {check: bool, ...}. ``stats``: the named
    model (with an accepted second effect); ``alone``: the named effect on its own. (b) passes when either
    predicts no worse than plain J-A (5-fold block CV on 53 samples is noisy for a 7-parameter pair)."""
    sig, none = ev["noise_floor_T"], ev["none"]
    mf = ev.get("model_form") or {}
    best_mf = min((m["bic"] for m in mf.values()), default=math.inf)
    pa, pb = _predicts(th, none, stats), _predicts(th, none, alone or stats)
    pred = pa if all(pa.values()) else pb
    return {
        "closes": _v(stats.get("rms_T")) <= th["close_factor"] * sig,
        **pred,
        "plausible": bool(plausible) or not th["require_plausible"],
        "beats_model_form": stats["bic"] <= best_mf - th["model_form_margin"],
    }


def best_model_form(ev: dict, th: dict) -> tuple[str | None, dict]:
    """(name of the model-form candidate that passes, checks per candidate)."""
    sig, none = ev["noise_floor_T"], ev["none"]
    checks = {}
    held0, blocks0 = _v(none.get("heldout_T")), _v(none.get("cv_blocks_T"))
    for name, m in (ev.get("model_form") or {}).items():
        checks[name] = {"earns": m["delta_bic"] > th["bic_margin"],
                        "closes": _v(m.get("rms_T")) <= th["close_factor"] * sig,
                        "predicts_branch": _v(m.get("heldout_T")) <= th["heldout_factor"] * held0,
                        "predicts_blocks": _v(m.get("cv_blocks_T")) <= th["blocks_factor"] * blocks0}
        if "heldout_T" not in m:  # not cross-validated: it cannot earn (modelform.needs_holdout), not judged
            checks[name].update(predicts_branch=None, predicts_blocks=None)
    ok = [n for n, c in checks.items() if all(c.values())]
    return (min(ok, key=lambda n: ev["model_form"][n]["bic"]) if ok else None), checks


def _partial(ev: dict, lead: str | None, stats: dict | None, checks: dict | None, sec: dict | None) -> dict:
    sig = ev["noise_floor_T"]
    ex0 = excess(ev["none"]["rms_T"], sig)
    out = {}
    if lead is not None:
        out = {"effect": lead, "rms_after_T": stats["rms_T"],
               "excess_removed_frac": removed_frac(ex0, excess(stats["rms_T"], sig)),
               "failed": sorted(k for k, v in (checks or {}).items() if not v),
               "secondary": sec["effect"] if sec and sec["accepted"] else None}
    mf = ev.get("model_form") or {}
    if mf:
        name = min(mf, key=lambda n: mf[n]["bic"])
        out["model_form"] = {"best": name, "rms_after_T": mf[name]["rms_T"],
                             "excess_removed_frac": removed_frac(ex0, excess(mf[name]["rms_T"], sig))}
    return out or None


def decide(evidence: dict, thresholds: dict | None = None) -> dict:
    """The verdict from the evidence block (see the module docstring)."""
    from mrhyst.diagnose.asrun import as_run  # the part of complete evidence a verdict at th weighs

    th = dict(DEFAULT_THRESHOLDS, **(thresholds or {}))
    ev, sig = as_run(evidence, th), evidence["noise_floor_T"]
    C = ev["candidates"]
    passed, reasons = earners(ev, th)
    out = {"effect": "none", "ambiguous_with": [], "ambiguity_reason": "", "secondary": None, "model_form": None,
           "partial": None, "checks": None, "reasons": reasons, "leader": None}
    lead_stats = checks = sec = None
    lead = passed[0] if passed else None
    if lead is not None:
        amb = [e for e in passed[1:] if C[e]["bic"] - C[lead]["bic"] < th["tie_margin"]]
        sec = secondary(ev, th, lead, amb)
        if sec is not None and sec["swapped"]:  # two other effects explain the loop: the leader mimicked them
            lead = sec["primary"]
            amb = [e for e in passed if e != lead and abs(C[e]["bic"] - C[lead]["bic"]) < th["tie_margin"]]
        elif sec is not None and sec["primary"] != lead:  # a tied effect's pair: the fuller model decides
            amb = [lead] + [e for e in amb if e != sec["primary"]]
            lead = sec["primary"]
        use_pair = sec is not None and sec["accepted"]
        lead_stats = sec["pair"] if use_pair else C[lead]
        # the sizes the verdict reports: the pair's (both members as the pair fitted them) when it is accepted; the
        # leader fitted alone may have bent to absorb the second effect (a hotter core's Ms x0.18 against an offset)
        plaus = sec["pair"].get("plausible", True) if use_pair else C[lead]["plausible"]
        checks = rule_checks(ev, th, lead_stats, plaus, C[lead])
        rep = ev.get("repeat")
        if rep is not None and C[lead].get("time_bound"):
            checks["grows_with_time"] = rep["time_bound_sigma"] >= th["time_bound_min_sigma"]
        out.update(leader=lead, checks=checks)
        if all(checks.values()):
            out.update(effect=lead, ambiguous_with=amb, ambiguity_reason=ambiguity_reason(C, lead, amb,
                                                                                          th["tie_margin"]),
                       secondary=sec)
            return out
    mf_name, mf_checks = best_model_form(ev, th)
    out["model_form_checks"] = mf_checks
    if mf_name is not None:
        out.update(effect="model_form", model_form=mf_name)
    elif _v(ev["none"]["rms_T"]) > th["unexplained_factor"] * sig:
        out["effect"] = "unexplained"
    if lead is not None or (out["effect"] == "unexplained" and mf_checks):
        out["partial"] = _partial(ev, lead, lead_stats, checks, sec)
    return out
