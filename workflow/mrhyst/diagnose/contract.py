"""The diagnosis JSON (the ``mrhyst diagnose`` contract, ARCHITECTURE 4) from the fits, the evidence and
the policy's verdict. Adds ``evidence`` (the statistics the policy read, re-decidable with
:func:`.policy.decide`), ``policy`` (thresholds and checks) and ``model_form``."""

from __future__ import annotations

import math

import numpy as np

from mrhyst.diagnose.budget import finite, gap_budget, shrink, where
from mrhyst.diagnose.candidates import std_errors, stderr_widening
from mrhyst.diagnose.policy import excess, removed_frac, thresholds_from
from mrhyst.diagnose.problem import Problem
from mrhyst.model import effects as fx

EVIDENCE_KEYS = ("effect", "effects", "name", "n_params", "rms_T", "bic", "delta_bic", "cv_interleaved_T",
                 "cv_blocks_T", "cv_blocks_folds_T", "heldout_T", "plausible", "plausible_why", "branch_identifiable",
                 "block_identifiable", "time_bound", "params")


def clean(x):
    """JSON-ready: non-finite floats -> None, numpy scalars -> Python."""
    if isinstance(x, dict):
        return {k: clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [clean(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def evidence_block(ev: dict) -> dict:
    """The statistics :func:`.policy.decide` reads. A diagnosis's evidence is complete (every candidate's and
    every pair's held-out errors, every model-form fit, ``repeat_rows``: :mod:`.asrun`), so a replay at other
    thresholds is exact; ``cv_max_candidates`` marks it (evidence saved before holds what was gathered)."""
    pick = lambda d: {k: d[k] for k in EVIDENCE_KEYS if k in d}  # noqa: E731
    out = {"n": ev["n"], "noise_floor_T": ev["noise_floor_T"], "none": ev["none"],
           "candidates": {e: pick(c) for e, c in ev["candidates"].items()},
           "pairs": [pick(p) for p in ev["pairs"]],
           "model_form": {k: pick(m) for k, m in ev["model_form"].items()},
           "repeat": ev.get("repeat")}
    for k in ("cv_max_candidates", "repeat_rows"):  # a complete evidence block (issue 22, point 4)
        if k in ev:
            out[k] = ev[k]
    out["signatures"] = ev.get("signatures", [])  # issue 23: what a policy may read as a signature present
    return clean(out)


def size_of(prob: Problem, fit, e: str) -> dict:
    se = std_errors(prob, fit, prob.sw.valid)  # widened for residuals correlated along the path
    out = {"param": _param(e), "value": prob.to_contract(e, fit.u),
           "stderr": finite(abs(prob.contract_slope(e, fit.u)) * float(se[prob.col[e]])),
           "stderr_widening": stderr_widening(prob, fit, prob.sw.valid)}
    sh = fx.REGISTRY[e].shared
    if sh is not None and sh.note is not None:  # the air gap: the Nd reported of the fitted alpha' (registry)
        out["note"] = sh.note(float(fit.u[sh.col]))
    return out


def _param(e: str) -> str:
    return fx.REGISTRY[e].param


def secondary_block(prob: Problem, ev: dict, sec: dict | None, pair_fits: dict) -> tuple[dict | None, object]:
    if sec is None:
        return None, None
    p, first, e2 = sec["pair"], sec["primary"], sec["effect"]
    out = {"effect": e2, "delta_bic_over_primary": sec["delta_bic_over_primary"], "rms_after_T": p["rms_T"],
           "cv_interleaved_T": finite(p.get("cv_interleaved_T")), "heldout_rms_T": finite(p.get("heldout_T")),
           "params": p["params"][e2], "primary_params": p["params"][first], "accepted": sec["accepted"],
           "plausible": p.get("plausible"), "ambiguous_with": ["+".join(q) for q in sec.get("ambiguous_with", [])]}
    pf = pair_fits[tuple(p["effects"])] if sec["accepted"] else None
    if pf is not None:
        out["size"] = size_of(prob, pf, e2)
    return out, pf


def model_form_block(ev: dict, verdict: dict) -> dict | None:
    mf = ev["model_form"]
    if not mf:
        return None
    name = verdict["model_form"] or min(mf, key=lambda n: mf[n]["bic"])
    return clean({"best": name, "named": verdict["effect"] == "model_form", "rms_after_T": mf[name]["rms_T"],
                  "heldout_T": mf[name].get("heldout_T"), "cv_blocks_T": mf[name].get("cv_blocks_T"),
                  "candidates": [{k: m[k] for k in EVIDENCE_KEYS + ("doc",) if k in m} for m in mf.values()]})


def verdict_text(effect, verdict, ev, rms_before, rms_after, sigma, worst, sec) -> tuple[str, str]:
    """(verdict line, note)."""
    note = ""
    part = verdict["partial"] or {}
    if part.get("effect"):
        pair = f" (with {part['secondary']}, the pair judged)" if part.get("secondary") else ""
        note = (f"the best measurement-chain candidate, {part['effect']}{pair}, is not named: it fails "
                f"{', '.join(part['failed']) or 'nothing'} (RMS after {part['rms_after_T'] * 1e3:.3f} mT, "
                f"{100 * (part['excess_removed_frac'] or 0):.0f} % of the excess removed)")
    if part.get("model_form") and effect != "model_form":
        m = part["model_form"]
        note += ("; " if note else "") + (f"best model-form candidate {m['best']} leaves "
                                          f"{m['rms_after_T'] * 1e3:.3f} mT")
    if effect == "none":
        return (f"none: plain J-A fits to {rms_before * 1e3:.3f} mT, {rms_before / sigma:.2f}x the noise floor "
                f"({sigma * 1e3:.3f} mT); no candidate effect is named" + (f"; {note}" if note else "")), note
    if effect == "unexplained":
        return (f"unexplained: plain J-A leaves {rms_before / sigma:.1f}x the noise floor and nothing closes the "
                f"gap" + (f"; {note}" if note else "") + f"; the largest share of the gap is in {worst}"), note
    if effect == "model_form":
        return (f"model_form ({verdict['model_form']}): RMS {rms_before * 1e3:.3f} -> {rms_after * 1e3:.3f} mT "
                f"(noise floor {sigma * 1e3:.3f} mT); physics J-A leaves out, not a measurement fault"
                + (f"; {note}" if note else "")), note
    C = ev["candidates"]
    text = (f"{effect}: RMS {rms_before * 1e3:.3f} -> {rms_after * 1e3:.3f} mT (noise floor {sigma * 1e3:.3f} mT), "
            f"delta BIC {C[effect]['delta_bic']:.1f}; the largest share of the gap before is in {worst}")
    if verdict["ambiguous_with"]:
        text += f"; ambiguous with {', '.join(verdict['ambiguous_with'])}"
    if sec and sec["accepted"]:
        text += f"; plus {sec['effect']} (RMS -> {sec['rms_after_T'] * 1e3:.3f} mT)"
        if sec.get("ambiguous_with"):
            text += f"; the pair fits as well as {', '.join(sec['ambiguous_with'])}"
    return text, note


def partial_curves(verdict: dict, fits: dict, mf_fits: dict) -> dict:
    """The curves of the best candidates not named (the figure's "best partial", issue 26): the leading
    measurement-chain effect and the best model form of ``partial``, when the verdict did not name them."""
    part, out = verdict["partial"] or {}, {}
    if part.get("effect") in fits and part["effect"] != verdict["effect"]:
        out["B_partial_T"] = fits[part["effect"]].B
    mf = (part.get("model_form") or {}).get("best")
    if mf in mf_fits and verdict["effect"] != "model_form":
        out["B_model_form_T"] = mf_fits[mf]["B_T"]
    return out


def build(prob: Problem, cfg: dict, form: str, seed: int, plain: dict, base, fits: dict, pair_fits: dict,
          mf_fits: dict, ev: dict, verdict: dict, escalated: bool) -> dict:
    sw, sigma = prob.sw, ev["noise_floor_T"]
    effect = verdict["effect"]
    after_stats = ev["candidates"].get(effect) or (ev["model_form"].get(verdict["model_form"] or "") or ev["none"])
    if effect in fits:
        after, B_after, rms_after = fits[effect], fits[effect].B, fits[effect].rms
    elif effect == "model_form":
        after, B_after, rms_after = base, mf_fits[verdict["model_form"]]["B_T"], after_stats["rms_T"]
    else:
        after, B_after, rms_after = base, base.B, base.rms
    sec, pair_fit = secondary_block(prob, ev, verdict["secondary"], pair_fits)
    final_rms = sec["rms_after_T"] if sec and sec["accepted"] else rms_after
    size = size_alone = None
    if effect in fits:
        size = size_alone = size_of(prob, after, effect)
        if pair_fit is not None:
            size = dict(size_of(prob, pair_fit, effect), fitted_with=sec["effect"])
    sh = shrink(cfg, sigma, ev["none"], after_stats, base.rms, rms_after)
    if pair_fit is not None:
        sh["with_secondary"] = {
            "effects": list(pair_fit.effects), "rms_after_T": pair_fit.rms,
            "excess_removed_frac": removed_frac(excess(base.rms, sigma), excess(pair_fit.rms, sigma)),
            "heldout_rms_after_T": sec["heldout_rms_T"],
            "heldout_excess_removed_frac": removed_frac(excess(finite(ev["none"].get("heldout_T")), sigma),
                                                        excess(sec["heldout_rms_T"], sigma))}
    budget = gap_budget(prob, plain["this"], plain["this_src"], base, plain["seeds"], sigma, rms_after)
    wh = where(prob, base.B, B_after, budget)
    text, note = verdict_text(effect, verdict, ev, base.rms, rms_after, sigma, wh["largest_share_before"], sec)
    cand_list = [{"effect": "none", "n_params": 5, "rss_T2": base.rss, "rms_T": base.rms, "bic": ev["none"]["bic"],
                  "delta_bic": 0.0, "ja_params": prob.physical(base.u, ())[0], "params": {}, "ok": base.ok,
                  "verdict": "plain J-A (the reference)", **ev["none"]}]
    for e in sorted(ev["candidates"], key=lambda e: ev["candidates"][e]["bic"]):
        cand_list.append(dict(ev["candidates"][e], verdict=verdict["reasons"][e]))
    ja_after, eff_after = prob.physical(after.u, after.effects)
    out = {
        "effect": effect, "ambiguous_with": verdict["ambiguous_with"], "ambiguity_reason": verdict["ambiguity_reason"],
        "rms_before_T": base.rms, "rms_after_T": rms_after, "noise_floor_T": sigma,
        "effect_size": size, "effect_size_alone": size_alone, "secondary": sec, "partial": verdict["partial"],
        "model_form": model_form_block(ev, verdict),
        "structure_remains": bool(final_rms > float(cfg["unexplained_factor"]) * sigma),
        "note": note, "verdict": text, "shrink": sh, "where": wh, "candidates": cand_list,
        "fit_before": {"ja_params": prob.physical(base.u, ())[0]},
        "fit_after": {"ja_params": ja_after, "effect_params": eff_after},
        "evidence": evidence_block(ev),
        "policy": {"thresholds": thresholds_from(cfg),
                   "leader": verdict["leader"], "checks": verdict["checks"],
                   "model_form_checks": verdict.get("model_form_checks")},
        "search": {"escalated": escalated, "model_evaluations": int(prob.n_evals)},
        "input": {"raw": sw.source, "sensor": sw.sensor, "n_samples": sw.n, "n_valid": int(sw.valid.sum()),
                  "n_over_le": sw.n_over_le, "form": form, "seed": int(seed),
                  "protocol": "0 -> max -> 0 (one ascent, one descent)"},
        "settings": {k: v for k, v in sorted(cfg.as_dict().items()) if k not in ("series", "seed")},
    }
    if cfg["series"]:
        out["series"] = {
            "current_A": sw.current, "time_s": sw.time, "B_T": sw.B, "valid": sw.valid.astype(int),
            "region": [str(x) for x in sw.region], "B_before_T": base.B, "B_after_T": B_after,
            "B_with_secondary_T": pair_fit.B if pair_fit is not None else None,
            **partial_curves(verdict, fits, mf_fits),
        }
    return clean(out)
