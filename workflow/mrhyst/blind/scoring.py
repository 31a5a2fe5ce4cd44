"""Blind benchmark, step 3 (rule ``blind_score``): the only reader of the key.

Per case, :func:`judge` compares a verdict with the key; :func:`score` aggregates per class and per kind:

* **closed world** (one vocabulary effect or none): top-1 strict / fair (``none`` accepted on an absorbed
  effect; an equivalent effect accepted when the truth is in ``ambiguous_with``), *named or settled* (issue
  23: the truth named, or in ``ambiguous_with`` with a ``next_measurement`` that separates it), on detectable cases,
  false alarms on ``none``, recovered size, residual left against the noise floor;
* **compound** (``A+B``): *one of pair* (the named effect is A or B) and *both named* (A and B among the
  named effect and the ``secondary`` one(s): an accepted ``secondary`` dict, or a list of them or of names,
  or a future ``effects`` list);
* **open world** (out-of-vocabulary mechanism): *false attribution* (a measurement-chain effect named for
  an out-of-vocabulary gap: the worst error, ARCHITECTURE 6), *model-form recall* (``model_form`` named),
  and *right* (``model_form`` or ``unexplained`` on a gap; also ``none`` where the reference says there
  is no gap).

A diagnosis that failed (``"effect": "failed"``, written by the blind_diagnose job when the diagnosis
refused the sweep) is scored as a miss and counted.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mrhyst.blind import tradeoff
from mrhyst.blind.cases import closed_classes
from mrhyst.blind.settings import blind_settings
from mrhyst.data import io
from mrhyst.model import effects as fx

OPEN_RIGHT = ("model_form", "unexplained")
FAILED = "failed"
_DIAG_FIELDS = ("effect", "rms_before_T", "rms_after_T", "noise_floor_T")  # what score reads of a diagnosis
GOALS = {"top1": 0.95, "false_alarm_none": 0.05, "residual_within_factor": 0.90, "false_attribution": 0.10,
         "one_of_pair": 0.90, "both_named": 0.75}  # issues 5 and 12


def _rate(hits, n):
    return hits / n if n else None


def named_effects(d: dict) -> list[str]:
    """The effect a verdict names first, then its secondary one(s): ``secondary`` as an accepted dict
    (``{"effect": E, "accepted": true}``), a list of such dicts or of names, or an ``effects`` list."""
    out = [d.get("effect")]
    sec = d.get("secondary")
    items = sec if isinstance(sec, list) else ([sec] if sec else [])
    for it in items:
        if isinstance(it, str):
            out.append(it)
        elif isinstance(it, dict) and it.get("effect") and it.get("accepted", True):
            out.append(it["effect"])
    for e in d.get("effects") or []:
        if isinstance(e, str):
            out.append(e)
    return list(dict.fromkeys(x for x in out if x))


def judge(k: dict, d: dict) -> dict:
    """The verdict ``d`` (``effect``, ``ambiguous_with``, ``secondary``) against the key entry ``k``."""
    kind = k.get("kind", "closed")
    truth, pred = k["class"], d.get("effect")
    amb = list(d.get("ambiguous_with") or [])
    named = named_effects(d)
    rec = {"kind": kind, "predicted": pred, "named": named, "ambiguous_with": amb, "detectable": k["detectable"],
           "failed": pred == FAILED}
    if kind == "closed":
        strict = pred == truth
        stand_in = pred in k.get("equivalent_to", []) and truth in amb
        if truth == "none":
            fair = pred == "none"
        elif k["detectable"]:
            fair = strict or stand_in
        else:
            fair = pred in (truth, "none") or stand_in
        # issue 23: the truth named, or in the named ambiguous set with a next measurement that separates it
        settled = pred == truth or (truth in amb and bool((d.get("next_measurement") or {}).get("protocol")))
        rec.update(strict=strict, fair=fair, in_ambiguous=pred == truth or truth in amb, named_or_settled=settled)
    elif kind == "compound":
        pair = list(k["members"])
        rec.update(one_of_pair=pred in pair, both_named=set(pair) <= set(named), strict=pred in pair,
                   fair=pred in pair, in_ambiguous=pred in pair or bool(set(pair) & set(amb)))
    else:
        gap = bool(k["detectable"])
        right = pred in OPEN_RIGHT if gap else pred in OPEN_RIGHT + ("none",)
        rec.update(false_attribution=gap and pred in fx.REGISTRY, mimicked=bool(k.get("vocab_closes")),
                   model_form=pred == "model_form",
                   unexplained=pred == "unexplained", none_on_gap=gap and pred == "none", strict=right, fair=right,
                   in_ambiguous=right)
    return rec


def _row(cid: str, k: dict, d: dict, cfg: dict) -> dict:
    default_sigma, factor = float(cfg["default_noise_sigma_T"]), float(cfg["residual_factor"])
    rec = dict(judge(k, d), id=cid, **{"class": k["class"]})
    floor, after = d.get("noise_floor_T"), d.get("rms_after_T")
    size = d.get("effect_size") or {}
    keep_size = rec["kind"] == "closed" and rec["strict"]
    rec.update({"noise_sigma_T": k["noise_sigma_T"], "sigma_eff_T": k["sigma_eff_T"],
                "default_noise": math.isclose(k["noise_sigma_T"], default_sigma, rel_tol=1e-9),
                "rms_before_T": d.get("rms_before_T"), "rms_after_T": after, "noise_floor_T": floor,
                "rms_left_T": k["rms_left_T"], "n_over_le": k["n_over_le"],
                "after_over_floor": after / floor if after is not None and floor else None,
                "after_over_sigma": after / k["sigma_eff_T"] if after is not None else None,
                "size_param": k.get("size_param"), "size_true": k.get("size_value"),
                "size_fit": size.get("value") if keep_size else None,
                "size_stderr": size.get("stderr") if keep_size else None})
    rec["residual_ok"] = rec["after_over_floor"] is not None and rec["after_over_floor"] <= factor
    if rec["size_fit"] is not None and rec["size_true"]:
        rec["size_ratio"] = rec["size_fit"] / rec["size_true"]
        se = rec["size_stderr"]
        rec["size_z"] = (rec["size_fit"] - rec["size_true"]) / se if se else None
    return rec


def _closed_summary(sel: list, factor: float) -> dict:
    n = len(sel)
    none_cases = [r for r in sel if r["class"] == "none"]
    det = [r for r in sel if r["class"] != "none" and r["detectable"]]
    sig = [r for r in sel if r["after_over_sigma"] is not None]
    return {
        "n": n,
        "top1_strict": _rate(sum(r["strict"] for r in sel), n),
        "top1_fair": _rate(sum(r["fair"] for r in sel), n),
        "top1_detectable": _rate(sum(r["strict"] for r in det), len(det)),
        "n_detectable": len(det),
        "top1_or_ambiguous": _rate(sum(r["in_ambiguous"] for r in sel), n),
        "named_or_settled": _rate(sum(r.get("named_or_settled", False) for r in sel), n),
        "false_alarm_none": _rate(sum(r["predicted"] != "none" for r in none_cases), len(none_cases)),
        "residual_within_factor": _rate(sum(r["residual_ok"] for r in sel), n),
        "residual_within_factor_of_true_sigma": _rate(sum(r["after_over_sigma"] <= factor for r in sig), n),
        "failed": sum(r["failed"] for r in sel),
    }


def _compound_summary(sel: list) -> dict:
    n = len(sel)
    return {"n": n, "one_of_pair": _rate(sum(r["one_of_pair"] for r in sel), n),
            "both_named": _rate(sum(r["both_named"] for r in sel), n),
            "named_none": _rate(sum(r["predicted"] == "none" for r in sel), n),
            "failed": sum(r["failed"] for r in sel)}


def _open_summary(sel: list) -> dict:
    gap = [r for r in sel if r["detectable"]]
    n = len(gap)
    named = {}
    for r in gap:
        if r["false_attribution"]:
            named[r["predicted"]] = named.get(r["predicted"], 0) + 1
    pure = [r for r in gap if not r["mimicked"]]  # gaps that no single vocabulary effect closes (reference)
    return {"n": len(sel), "n_gap": n, "false_attribution": _rate(sum(r["false_attribution"] for r in gap), n),
            "n_unmimicked": len(pure),
            "false_attribution_unmimicked": _rate(sum(r["false_attribution"] for r in pure), len(pure)),
            "model_form_recall": _rate(sum(r["model_form"] for r in gap), n),
            "unexplained": _rate(sum(r["unexplained"] for r in gap), n),
            "none_on_gap": _rate(sum(r["none_on_gap"] for r in gap), n),
            "right": _rate(sum(r["fair"] for r in sel), len(sel)),
            "falsely_named": dict(sorted(named.items())), "failed": sum(r["failed"] for r in sel)}


def summary(sel: list, kind: str, factor: float) -> dict:
    if kind == "compound":
        return _compound_summary(sel)
    if kind == "openworld":
        return _open_summary(sel)
    return _closed_summary(sel, factor)


def _size_stats(sel: list) -> dict:
    sizes = [r for r in sel if r.get("size_ratio") is not None]
    if not sizes:
        return {}
    ratios = np.array([r["size_ratio"] for r in sizes])
    zs = np.array([r["size_z"] for r in sizes if r.get("size_z") is not None])
    return {"size_ratio_median": float(np.median(ratios)),
            "size_ratio_iqr": [float(np.percentile(ratios, 25)), float(np.percentile(ratios, 75))],
            "size_z_rms": float(np.sqrt(np.mean(zs**2))) if zs.size else None}


def _strict_misses(rows: list) -> dict:
    """Every closed-world strict miss in one of four kinds (the report explains the score with them)."""
    kinds = {"none_on_undetectable": 0, "none_on_detectable": 0, "other_flagged_ambiguous": 0, "other_unflagged": 0,
             "pairs": {}}
    for r in rows:
        if r["strict"]:
            continue
        if r["predicted"] == "none":
            kinds["none_on_detectable" if r["detectable"] else "none_on_undetectable"] += 1
        else:
            kinds["other_flagged_ambiguous" if r["class"] in r["ambiguous_with"] else "other_unflagged"] += 1
            pair = f"{r['class']} -> {r['predicted']}"
            kinds["pairs"][pair] = kinds["pairs"].get(pair, 0) + 1
    kinds["pairs"] = dict(sorted(kinds["pairs"].items()))
    return kinds


def read_cases(diag_paths, key_path) -> tuple[dict, list]:
    """(key cases, [(case id, diagnosis dict)]) with one-line errors for a file that is not what it should be."""
    key = io.read_json(key_path)
    if not (isinstance(key, dict) and isinstance(key.get("cases"), dict)):
        raise io.InputError(f"{key_path}: not a blind key (expected an object with 'cases', as blind generate writes)")
    out = []
    for p in diag_paths:
        cid = Path(p).stem
        if cid not in key["cases"]:
            raise io.InputError(f"{p}: case {cid!r} is not in the key {key_path}")
        d = io.read_json(p)
        missing = [f for f in _DIAG_FIELDS if not isinstance(d, dict) or f not in d]
        if missing:
            raise io.InputError(f"{p}: not a diagnosis (missing {', '.join(missing)}; expected mrhyst diagnose output)")
        out.append((cid, d))
    return key["cases"], out


def thresholds_in_use(diags) -> dict | None:
    """The policy thresholds the diagnoses were decided with (``policy.thresholds``), if they all agree."""
    found = [(d.get("policy") or {}).get("thresholds") for _, d in diags]
    found = [t for t in found if isinstance(t, dict)]
    return dict(found[0]) if found and all(t == found[0] for t in found) else None


def score(diag_paths, key_path, cfg: dict, policy=None) -> dict:
    """Score the diagnoses in ``diag_paths`` (one JSON per case, named <case id>.json) against the key.

    With ``policy = (decide, default thresholds)`` (a pure ``decide(evidence, thresholds)``, see
    :func:`mrhyst.blind.tradeoff.load_policy`), also the trade-off curve of :func:`.tradeoff.curve` on the
    ``evidence`` blocks the diagnoses carry, over :func:`.tradeoff.policy_grid` around the thresholds in use
    (those recorded in the diagnoses, else the policy's defaults), which are marked ``chosen``."""
    cfg = blind_settings(cfg)  # the blind section (or settings already resolved) over the schema's defaults
    key, diags = read_cases(diag_paths, key_path)
    decide = grid = base = None
    if policy is not None:
        decide, base = policy[0], thresholds_in_use(diags) or dict(policy[1])
        grid = tradeoff.policy_grid(cfg, base)
    factor = float(cfg["residual_factor"])
    rows = sorted((_row(cid, key[cid], d, cfg) for cid, d in diags), key=lambda r: r["id"])
    closed = [r for r in rows if r["kind"] == "closed"]
    per_class = {}
    for cls in cfg["classes"]:
        sel = [r for r in rows if r["class"] == cls]
        kind = sel[0]["kind"] if sel else "closed"
        s = dict(summary(sel, kind, factor), kind=kind, **_size_stats(sel))
        if kind == "closed":
            s["detectable_frac"] = _rate(sum(r["detectable"] for r in sel), len(sel)) if cls != "none" else None
        s["absorbed_draws"] = sum(int(key[r["id"]].get("absorbed_draws_before", 0)) for r in sel)
        per_class[cls] = s
    # columns in the rows' order (the closed classes as configured), so that right answers sit on the diagonal
    names = closed_classes()
    labels = [c for c in cfg["classes"] if c in names] + [c for c in names if c not in cfg["classes"]]
    labels += ["model_form", "unexplained"]
    labels += sorted({r["predicted"] for r in rows} - set(labels))
    confusion = {t: {p: 0 for p in labels} for t in cfg["classes"]}
    for r in rows:
        confusion[r["class"]][r["predicted"]] += 1
    misses = [{"truth": r["class"], "kind": r["kind"], "predicted": r["predicted"], "named": r["named"],
               "id": r["id"], "detectable": r["detectable"], "ambiguous_with": r["ambiguous_with"],
               "noise_sigma_T": r["noise_sigma_T"], "n_over_le": r["n_over_le"],
               "rms_left_over_sigma": r["rms_left_T"] / r["sigma_eff_T"] if r["rms_left_T"] is not None else None}
              for r in rows if not r["fair"]]
    evidence = {cid: d.get("evidence") for cid, d in diags}
    curve = tradeoff.curve([dict(key[cid], id=cid) for cid, _ in diags], evidence, decide, grid, base,
                           judge=judge) if decide is not None and grid else None
    return {
        "overall": _closed_summary(closed, factor),
        "compound": _compound_summary([r for r in rows if r["kind"] == "compound"]),
        "open_world": _open_summary([r for r in rows if r["kind"] == "openworld"]),
        "n_cases": len(rows),
        "failed": sum(r["failed"] for r in rows),
        "strict_misses": _strict_misses(closed),
        "detectable_factor": float(cfg["detectable_factor"]),
        "detectable_only": cfg.detectable_only, "protocol": cfg.protocol,
        "default_noise": _closed_summary([r for r in closed if r["default_noise"]], factor),
        "per_class": per_class,
        "confusion": confusion,
        "classes": list(cfg["classes"]),
        "labels": labels,
        "misses": misses,
        "cases": rows,
        "tradeoff": curve,
        "goals": dict(GOALS, factor=factor),
    }
