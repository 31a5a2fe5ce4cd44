"""The trade-off curve of a selection policy: closed-world top-1 against open-world false attribution.

A diagnosis that names an effect readily scores well on the closed world and attributes out-of-vocabulary
gaps to a measurement-chain effect; a strict one does the reverse (issue 12, point 1). With the selection
as a pure function ``decide(evidence, thresholds) -> verdict`` and the ``evidence`` block of every
diagnosis JSON, the curve is recomputed without refitting anything: :func:`curve` replays ``decide`` over a
grid of thresholds and judges each verdict with the rules it is given (the score's, :func:`.scoring.judge`:
the score calls this module, never the other way round).

The replay is exact: a diagnosis's evidence reads none of the policy's thresholds (every candidate's and
every pair's held-out errors, every model-form fit; issue 22, point 4, :mod:`mrhyst.diagnose.asrun`), so each
point of the curve is the verdict a fresh diagnosis at those thresholds gives, not one biased towards the
thresholds the evidence was gathered with. The curve says so (``replay_exact``): true when every evidence
block is complete (it carries ``cv_max_candidates``); evidence saved before holds only what the thresholds
of its run had computed.

A verdict may be a name, a mapping with ``effect`` (and optionally ``ambiguous_with``, ``secondary``), or
an object with those attributes. :func:`load_policy` gives the diagnosis's policy (:mod:`mrhyst.diagnose.policy`).
"""

from __future__ import annotations

import itertools


def _as_verdict(v) -> dict:
    if isinstance(v, str):
        return {"effect": v}
    if isinstance(v, dict):
        return v
    return {f: getattr(v, f) for f in ("effect", "ambiguous_with", "secondary") if hasattr(v, f)}


def grid_product(axes: dict) -> list[dict]:
    """Every combination of the threshold values in ``axes`` ({name: [values]}), in a stated order."""
    names = sorted(axes)
    return [dict(zip(names, vals)) for vals in itertools.product(*(list(axes[n]) for n in names))]


def one_at_a_time(base: dict, factors) -> list[dict]:
    """``base`` itself, then each numeric threshold scaled by each factor with the others at ``base``."""
    out = [dict(base)]
    for name in sorted(base):
        v = base[name]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            continue
        for f in factors:
            if f != 1:
                out.append(dict(base, **{name: v * f}))
    return out


def _pareto(points: list) -> None:
    """Mark the points no other point beats on both axes (higher top-1, lower false attribution)."""
    for p in points:
        a, b = p["closed_top1"], p["false_attribution"]
        p["pareto"] = a is not None and b is not None and not any(
            q is not p and q["closed_top1"] is not None and q["false_attribution"] is not None
            and q["closed_top1"] >= a and q["false_attribution"] <= b
            and (q["closed_top1"] > a or q["false_attribution"] < b) for q in points)


def replay_exact(keys: list, evidence: dict) -> bool:
    """True when every case's evidence block is complete (see the module text), so the replay is exact."""
    have = [evidence[k["id"]] for k in keys if evidence.get(k["id"]) is not None]
    return bool(have) and all(e.get("cv_max_candidates") is not None for e in have)


def curve(keys: list, evidence: dict, decide, grid, base: dict | None = None, *, judge) -> dict:
    """Replay ``decide(evidence, thresholds)`` over ``grid`` (a list of threshold dicts).

    ``keys``: the key entries (with ``id``) of the scored cases; ``evidence``: {case id: evidence block or
    None}; ``judge(key entry, verdict)``: the score's rules (:func:`mrhyst.blind.scoring.judge`). Returns
    ``{"points": [{thresholds, closed_top1, false_attribution, model_form_recall, one_of_pair, both_named,
    n_closed, n_open_gap, pareto, chosen}], "n_without_evidence": int, "replay_exact": bool}``;
    ``chosen`` marks the point equal to ``base`` (the thresholds in use), if given."""
    have = [k for k in keys if evidence.get(k["id"]) is not None]
    points = []
    for th in grid:
        res = [(k, judge(k, _as_verdict(decide(evidence[k["id"]], th)))) for k in have]
        closed = [j for k, j in res if j["kind"] == "closed"]
        gap = [j for k, j in res if j["kind"] == "openworld" and j["detectable"]]
        comp = [j for k, j in res if j["kind"] == "compound"]

        def rate(sel, f):
            return sum(bool(j[f]) for j in sel) / len(sel) if sel else None

        points.append({"thresholds": dict(th), "closed_top1": rate(closed, "fair"),
                       "false_attribution": rate(gap, "false_attribution"),
                       "model_form_recall": rate(gap, "model_form"), "one_of_pair": rate(comp, "one_of_pair"),
                       "both_named": rate(comp, "both_named"), "n_closed": len(closed), "n_open_gap": len(gap),
                       "chosen": base is not None and dict(th) == dict(base)})
    _pareto(points)
    return {"points": points, "n_without_evidence": len(keys) - len(have), "replay_exact": replay_exact(keys, evidence)}


def load_policy():
    """(decide, default thresholds) of the diagnosis's selection policy (:mod:`mrhyst.diagnose.policy`)."""
    from mrhyst.diagnose import policy

    return policy.decide, dict(policy.DEFAULT_THRESHOLDS)


def policy_grid(cfg: dict, base: dict) -> list[dict]:
    """The thresholds to replay: config ``blind.tradeoff.grid`` ({name: [values]}) if given, else each of the
    policy's numeric defaults scaled by ``blind.tradeoff.factors`` one at a time."""
    t = cfg.get("tradeoff") or {}
    if t.get("grid"):
        return [dict(base, **p) for p in grid_product(t["grid"])]
    return one_at_a_time(base, t.get("factors", [0.5, 1.0, 2.0])) if base else []
