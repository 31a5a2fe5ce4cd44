"""The evidence a verdict at given thresholds weighs, out of the complete evidence (issue 22, point 4).

A diagnosis gathers its evidence without reading the policy's thresholds (``policy.THRESHOLD_KEYS``): the
held-out errors of every candidate, every pair of effects (with its held-out errors), every model-form
candidate, and the repeat statistics of every field-bound explanation. So a saved diagnosis re-decided at
other thresholds (:func:`mrhyst.diagnose.policy.decide`, the blind benchmark's trade-off curve) gets exactly
the verdict a fresh diagnosis at those thresholds gives: the replay is exact.

The policy's rules were made on the evidence the diagnosis gathered before, when those thresholds also chose
what to compute. :func:`as_run` selects that part again, now as part of the rule rather than of the search:

- held-out errors count for the ``cv_max_candidates`` candidates with the largest delta BIC past
  ``bic_margin`` (the others are "not among the leading ones cross-validated");
- the pairs weighed are those on top of the leader or a tied one (primary first), the leader with each tied
  one, and the pairs of the next earners without them (one earner when a pair on top of the leader closes
  the gap, ``close_factor``; else ``cv_max_candidates``), and only when the leader leaves more than
  ``secondary_factor`` x the noise floor; held-out errors count for the ``cv_max_candidates`` best by BIC;
- model-form candidates count when there is a leader or plain J-A leaves more than ``close_factor`` x the floor;
- the repeat statistic is that of the lowest-RSS field-bound explanation, leaving out a model-form fit that
  itself grows by ``time_bound_min_sigma`` standard errors from cycle to cycle.

Evidence saved before this (no ``cv_max_candidates``) is returned as it is: it holds what was gathered.
"""

from __future__ import annotations

import math

CV_KEYS = ("cv_interleaved_T", "cv_blocks_T", "cv_blocks_folds_T", "heldout_T")


def _v(x, missing=math.inf) -> float:
    return missing if x is None else float(x)


def without_cv(stats: dict) -> dict:
    return {k: v for k, v in stats.items() if k not in CV_KEYS}


def cross_validated(ev: dict, bic_margin: float) -> list:
    """The candidates whose held-out errors a verdict weighs (see the module text)."""
    C = ev["candidates"]
    past = [e for e in C if _v(C[e]["delta_bic"], -math.inf) > bic_margin]
    return sorted(past, key=lambda e: -C[e]["delta_bic"])[: int(ev["cv_max_candidates"])]


def other_pairs(C: dict, prim: list, n: int, bic_margin: float) -> list:
    """Pairs without the leader (and the tied ones), oriented better single first: each of the ``n`` next best
    effects that earn alone, with every other effect (the leader may only mimic the sum of two others)."""
    bic = lambda e: _v(C[e]["bic"])  # noqa: E731
    earn = sorted((e for e in C if e not in prim and _v(C[e]["delta_bic"], -math.inf) > bic_margin), key=bic)
    return list(dict.fromkeys(tuple(sorted((a, b), key=bic)) for a in earn[:n] for b in C if b not in prim and b != a))


def pair_pool(ev: dict, th: dict, C: dict, lead: str, amb: list) -> list:
    """The pairs a verdict weighs (see the module text), each oriented (primary first)."""
    by = {frozenset(p["effects"]): p for p in ev["pairs"]}
    prim = [lead, *amb]
    models = [(p, e2) for p in prim for e2 in C if e2 not in prim] + [(lead, e2) for e2 in amb]
    models = [m for m in models if frozenset(m) in by]
    if not models:
        return []
    closed = min(_v(by[frozenset(m)]["rms_T"]) for m in models) <= th["close_factor"] * ev["noise_floor_T"]
    models += other_pairs(C, prim, 1 if closed else int(ev["cv_max_candidates"]), th["bic_margin"])
    pool = [dict(by[frozenset(m)], effects=list(m)) for m in models if frozenset(m) in by]
    top = sorted(range(len(pool)), key=lambda i: _v(pool[i]["bic"]))[: int(ev["cv_max_candidates"])]
    return [p if i in top else without_cv(p) for i, p in enumerate(pool)]


def possible_leaders(ev: dict) -> dict:
    """{effect: BIC} of the candidates that lead at some thresholds: delta BIC > 0 (bic_margin >= 0) and interleaved
    CV below plain J-A's (:func:`.policy.earners`). No bound on secondary_factor is used (the schema wants it > 1, but
    the blind trade-off curve replays it at 0.5x). The pairs are weighed only on top of such a leader, and a pair's
    held-out errors only when its BIC is below the leader's (:func:`.policy.secondary`); so the search fits no pair
    when this is empty and cross-validates only the pairs below its largest BIC, and a replay at any thresholds is
    still exact (tests/test_pair_screen.py)."""
    cv0 = _v(ev["none"].get("cv_interleaved_T"))
    return {e: float(c["bic"]) for e, c in ev["candidates"].items()
            if _v(c.get("delta_bic"), -math.inf) > 0 and _v(c.get("cv_interleaved_T")) < cv0}


def repeat_of(ev: dict, min_sigma: float) -> dict | None:
    """The repeat statistic of the lowest-RSS field-bound explanation that does not itself grow with time."""
    rows = [r for r in ev["repeat_rows"] if r.get("own_time_bound_sigma") is None
            or r["own_time_bound_sigma"] < min_sigma]
    if not rows:
        return None
    return min(enumerate(rows), key=lambda ir: (_v(ir[1]["rss_T2"]), ir[0]))[1]["repeat"]


def as_run(evidence: dict, th: dict) -> dict:
    """The evidence a verdict at thresholds ``th`` weighs (see the module text); old evidence as it is."""
    from mrhyst.diagnose.policy import earners

    if evidence.get("cv_max_candidates") is None:
        return evidence
    sig = evidence["noise_floor_T"]
    cv = set(cross_validated(evidence, th["bic_margin"]))
    C = {e: (c if e in cv else without_cv(c)) for e, c in evidence["candidates"].items()}
    ev = dict(evidence, candidates=C, pairs=[])
    passed, _ = earners(ev, th)
    lead = passed[0] if passed else None
    if lead is not None and _v(C[lead]["rms_T"]) > th["secondary_factor"] * sig:
        amb = [e for e in passed[1:] if C[e]["bic"] - C[lead]["bic"] < th["tie_margin"]]
        ev["pairs"] = pair_pool(evidence, th, C, lead, amb)
    if lead is None and not _v(ev["none"]["rms_T"]) > th["close_factor"] * sig:
        ev["model_form"] = {}
    if "repeat_rows" in evidence:
        ev["repeat"] = repeat_of(evidence, th["time_bound_min_sigma"])
    return ev
