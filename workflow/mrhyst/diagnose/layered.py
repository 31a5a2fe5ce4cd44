"""The layered decision (issue 23): the material first, then the measurement chain. A pure function from the
statistics of the material bases and of each measurement effect's increment on the flexible base
(:mod:`.everett`; the ``layers`` block of a diagnosis's evidence) to a verdict and the budget. No fitting here.

``decide(layers, thresholds) -> {"effect", "ambiguous_with", "checks", "budget", "base", "reasons"}``:

1. **The material layer**: the base with the lowest BIC among plain J-A, the model-form candidates and the
   flexible Everett base (its BIC counts its effective degrees of freedom). ``material_T`` is what it removes
   of plain J-A's RMS, in quadrature.
2. **The measurement layer**: an effect's increment on the flexible base (which can follow any rate-independent
   odd loop, but cannot make an offset, a drift, a lag or a clip) is named when it
   (a) *earns*: BIC with the effective degrees of freedom drops by more than ``bic_margin``;
   (b) *predicts*: its interleaved CV RMS is below the base's;
   (c) is *plausible* in size (the registry's checks for this sweep and sensor);
   (d) is *stable across bases*: J-A plus the same effect also gains over plain J-A, and the two fitted sizes
       agree in sign and within a factor ``stable_ratio`` (not judged where the sweep's own evidence is a
       declared output limit, or a flat kink no material makes (``kink``): the samples there are a clip's
       level, whatever the base);
   (e) shows its *signature*: one of the sweep's model-free ``signatures`` of its kind (:data:`SIGNATURE_OF`),
       else the increment's own (``signature``: an offset moves a symmetric loop's centre, a drift makes B at
       the same current differ cycle to cycle; None where the sweep cannot show it: not judged). A reported
       signature of another kind does not veto: a sweep without held currents cannot show a lag's.
   The one with the largest BIC gain is named; others that pass within ``tie_margin`` are ``ambiguous_with``, and
   so is an ``unseparated`` increment (f) that gains as much or more (within ``tie_margin``; ``rivals``): a drift
   that explains more of a sweep without repeats than the offset named on it cannot be ruled out by that sweep
   (measured: bench/heldout_realcores.py, exponential drifts on 0 -> +max -> -max -> +max sweeps from 0 A, named
   hall_offset, eddy_lag or remanent_start with no word of a drift on 6 of 6). So is an increment that fails (c)
   alone (or with the checks its protocol's row reads as its confound) and gains as much: a size bound is a
   physical maximum, a size fitted on an inexact base is biased, and the better fit is not ruled out by this
   sweep (:func:`beyond_bound`; its rival row carries the bound's reason).
   (f) is *separable* on this protocol (:mod:`.layertable`, declared): on a 0 -> max -> 0 sweep the Preisach
       base's own congruency ties the virgin curve to the descending branch, a J-A or two-phase core does not
       obey it, and a lag or a drift on top makes up the difference (measured on the blind benchmark's
       open-world sweeps: lags named on a second phase and on a drifting Hall gain). There a lag or a drift is
       judged only when the sweep shows a signature no material makes, an offset never (it is a remanent start
       the base cannot hold); otherwise an increment that passes every other check is ``unseparated``: the
       layer names it with the explanation it cannot tell it from and the measurement that separates them.
       A clip is judged on any sweep.
   The judging base is the better material base *under the effect*: the flexible base, or J-A where J-A + the
   effect has the lower BIC (:func:`judged`; then (d) compares J-A's size with the flexible base's). The bare
   bases are not compared for this: fitted to a faulted loop, a J-A or two-phase start state mimics an offset
   that the odd flexible base cannot.
3. ``budget``: ``material_T`` (plain J-A -> the base), ``measurement_T`` (the base -> base + the named effect),
   ``left_T`` (what remains, noise included); material^2 + measurement^2 + left^2 = plain J-A's RMS^2 (a clip at
   a declared limit: plain J-A's RMS on all samples, the flagged ones included, :func:`clip_budget`).
"""

from __future__ import annotations

import math

from mrhyst.diagnose import layertable

LAYER_KEYS = ("bic_margin", "tie_margin", "stable_ratio", "min_share")
SIGNATURE_OF = {"hall_offset": ("offset", "off_centre", "zero_current", "b_at_zero"),
                "thermal_drift": ("held_current", "time", "not_closed", "drift", "clockwise"),
                "eddy_lag": ("held_current", "time", "lag"), "sensor_saturation": ("flat", "clip", "kink")}


def _q(a: float, b: float) -> float:
    """sqrt(a^2 - b^2), 0 when b >= a."""
    return math.sqrt(max(a * a - b * b, 0.0))


def material_base(layers: dict) -> str:
    B = layers["bases"]
    return min((k for k in B if B[k].get("bic") is not None), key=lambda k: B[k]["bic"])


def _stable(inc: dict, ratio: float):
    """(d): the sizes on the other bases (``sizes_other_bases``) agree with this one in sign and within a factor
    ``ratio``; None when not judged (a declared limit, or no other base)."""
    others = inc.get("sizes_other_bases") or []
    if inc.get("declared") or inc.get("kink") or not others:
        return None
    a = float(inc["size"])
    return all(a * b > 0 and max(abs(a), abs(b)) <= ratio * min(abs(a), abs(b)) for b in map(float, others))


def _signature(e: str, sigs) -> bool | None:
    if sigs is None:
        return None
    kinds = SIGNATURE_OF.get(e, ())
    return any(any(k in str(s.get("kind", "")) for k in kinds) for s in sigs)


def judged(inc: dict) -> dict:
    """The increment as judged: on the flexible base, or on J-A where J-A + the effect has the lower BIC (a loop J-A
    follows better than the flexible base does; the effect is then J-A's candidate, its sizes on the flexible bases
    the other bases of (d)). The J-A statistics are the plain rule's evidence (``ja``: bic, delta_bic, size, rms_T,
    cv_T, plausible, none_rms_T, none_cv_T)."""
    ja = inc.get("ja") or {}
    if inc.get("declared") or inc.get("kink") or ja.get("bic") is None or inc["bic"] <= ja["bic"]:
        return dict(inc, judged_on="everett")
    miss = lambda k, bad: bad if ja.get(k) is None else ja[k]  # noqa: E731  (a missing statistic fails safe)
    return dict(inc, judged_on="ja", bic=ja["bic"], rms_T=miss("rms_T", math.inf), cv_T=miss("cv_T", math.inf),
                size=miss("size", 0.0), plausible=ja.get("plausible", True),
                **({"sizes_other_bases": [inc["size"], *inc["sizes_other_bases"]]}
                   if "sizes_other_bases" in inc else {}),  # not computed where (d) cannot be read (layerfit)
                base={"bic": ja["bic"] + miss("delta_bic", -math.inf), "rms_T": miss("none_rms_T", 0.0),
                      "cv_T": miss("none_cv_T", -math.inf)})


def protocol_of(layers: dict) -> str:
    """The sweep's protocol class; evidence written before it was recorded has ``major_loop`` only (a major
    loop was judged for every effect, any other sweep for none but a declared clip)."""
    if layers.get("protocol"):
        return str(layers["protocol"])
    return "bipolar_repeated" if layers.get("major_loop", True) else "unjudged"


def checks_of(e: str, inc: dict, th: dict, sigs, protocol: str = "bipolar_repeated") -> dict:
    """(a)-(f) of one increment (as :func:`judged`): {check: bool or None (not judged)}. ``protocol``: the
    sweep's protocol class (:func:`mrhyst.diagnose.confounds.protocol_class`)."""
    b0 = inc["base"]
    if inc.get("declared"):  # samples at a declared output limit: a clip, whatever a base makes of them
        return {"at_declared_limit": bool(inc.get("n_at_clip")), "plausible": bool(inc.get("plausible", True))}
    share = 1.0 - (inc["rms_T"] / b0["rms_T"]) ** 2 if b0["rms_T"] > 0 else 0.0
    sep = protocol != "unjudged" and layertable.separable(e, protocol, sigs)
    return {"separable": sep,
            "earns": b0["bic"] - inc["bic"] > th["bic_margin"],
            "predicts": inc["cv_T"] < b0["cv_T"],
            "substantial": share >= th["min_share"],
            "plausible": bool(inc.get("plausible", True)),
            "stable": _stable(inc, th["stable_ratio"]),
            "signature": True if _signature(e, sigs) else _own(inc)}


def _own(inc: dict):
    """The increment's own signature; a time-bound effect (a drift) must show it: on one sweep without repeated
    cycles or held currents a drift and a branch-shape distortion are the same thing (docs/diagnosis.md)."""
    own = inc.get("signature")
    return False if own is None and inc.get("time_bound") else own


def unseparated(checks: dict, incs: dict, protocol: str, margin: float = math.inf) -> list:
    """The increments that pass every check but (f), or but the checks the table reads as its confound on this
    protocol (a lag on a bipolar sweep that fails (d) alone): [{"effect", "partner", "separated_by", "why", "size",
    "param", "protocol"}] (:mod:`.layertable`), the largest BIC gain first. A failed (a), *earns*, is read so only
    where J-A + the effect earns by more than ``margin`` on its own (the plain rule's ``delta_bic``): the flexible
    base then took the whole effect as material shape (a lag as a wider loop), and J-A's view of it stands."""
    out = []
    for e, c in checks.items():
        failed = [k for k, v in c.items() if v is False]
        r = layertable.confounded(e, protocol, failed)
        if r is None or ("earns" in failed and not (incs[e].get("ja") or {}).get("delta_bic", -math.inf) > margin):
            continue
        out.append({"effect": e, "partner": r.partner, "separated_by": r.separated_by, "why": r.why,
                    "size": incs[e]["size"], "param": incs[e].get("param"), "protocol": protocol,
                    "bic_gain": incs[e]["base"]["bic"] - incs[e]["bic"]})
    return sorted(out, key=lambda u: -u["bic_gain"])


def beyond_bound(checks: dict, incs: dict, protocol: str) -> list:
    """The increments whose one decisive failure is their size: they fail (c) *plausible*, and every other check
    they fail is one its protocol's row reads as its confound (:func:`unseparated`): [{"effect", "partner",
    "separated_by", "why", "size", "param", "protocol", "bic_gain", "beyond_bound"}], the largest BIC gain first
    (``beyond_bound``: the registry's reason, the bound and the fitted size). A bound is a physical maximum for a
    known sensor; a fit's size on a base that is itself not exact is biased (measured: bench/heldout_openworld.py, a
    linear drift of 0.17 mT/s on a Stoner-Wohlfarth core fitted at 0.22 mT/s against the 0.20 mT/s bound, the offset
    named instead with no word of the drift that gained 50 BIC more). Such an increment is no verdict, but one
    that gains as much as the effect named cannot be ruled out by this sweep: :func:`decide` makes it a rival."""
    out = []
    for e, c in checks.items():
        failed = {k for k, v in c.items() if v is False}
        if "plausible" not in failed:
            continue
        rest = failed - {"plausible"}
        r = layertable.confounded(e, protocol, rest) if rest else None
        if rest and r is None:
            continue
        sep, why = (r.separated_by, r.why) if r is not None else layertable.separator(e, protocol)
        out.append({"effect": e, "partner": r.partner if r is not None else None, "separated_by": sep, "why": why,
                    "size": incs[e]["size"], "param": incs[e].get("param"), "protocol": protocol,
                    "bic_gain": incs[e]["base"]["bic"] - incs[e]["bic"],
                    "beyond_bound": str(incs[e].get("plausible_why") or "beyond the registry's physical bound")})
    return sorted(out, key=lambda u: -u["bic_gain"])


def budget(ja_rms: float, base_rms: float, after_rms: float, base: str) -> dict:
    return {"material_T": _q(ja_rms, base_rms), "measurement_T": _q(base_rms, after_rms), "left_T": after_rms,
            "base": base}


def clip_budget(ja_rms: float, bare: dict, inc: dict) -> dict:
    """The budget of a clip at a declared limit, compared on all ``inc["n"]`` samples (the flagged ones included):
    the total is plain J-A's RMS there (``ja_rms_T``, its unclipped B), the material part what the bare base
    removes of plain J-A's gap on the samples inside the limit (``ja_rms`` and ``bare``'s RMS there, spread over
    all samples), left what the base + the clip leaves, the measurement part the rest: the samples the clip holds
    at the limit, which no material model without it follows. The parts add up to the total in quadrature (the
    total is the material and left parts' when they exceed it)."""
    n_in = float(bare.get("n") or inc["n"])
    mat = math.sqrt(max(ja_rms ** 2 - float(bare["rms_T"]) ** 2, 0.0) * n_in / float(inc["n"]))
    left = float(inc["rms_T"])
    total = max(float(inc["ja_rms_T"]), math.hypot(mat, left))
    return {"material_T": mat, "measurement_T": _q(total, math.hypot(mat, left)), "left_T": left,
            "base": inc["judged_on"]}


def decide(layers: dict, thresholds: dict) -> dict:
    """The layered verdict (see the module docstring)."""
    th = {k: thresholds[k] for k in LAYER_KEYS}
    B, sigs = layers["bases"], layers.get("signatures")
    incs = {e: judged(i) for e, i in (layers.get("increments") or {}).items()}
    ja_rms = B["ja"]["rms_T"]
    proto = protocol_of(layers)
    checks = {e: checks_of(e, inc, th, sigs, proto) for e, inc in incs.items()}
    mb = material_base(layers)
    ok = [e for e, c in checks.items() if all(v is not False for v in c.values())]
    gain = {e: math.inf if incs[e].get("declared") else incs[e]["base"]["bic"] - incs[e]["bic"] for e in incs}
    out = {"effect": None, "ambiguous_with": [], "checks": checks, "reasons": {}, "size": None,
           "unseparated": unseparated(checks, incs, proto, th["bic_margin"]), "rivals": [], "beyond_bound": []}
    for e, c in checks.items():
        failed = [k for k, v in c.items() if v is False]
        out["reasons"][e] = (f"increment on {incs[e]['judged_on']}: BIC gain {gain[e]:.1f}; "
                             + (f"fails {', '.join(failed)}" if failed else "passes every check"))
    if ok:
        e = max(ok, key=lambda x: gain[x])
        out.update(effect=e, ambiguous_with=sorted(x for x in ok if x != e and gain[e] - gain[x] < th["tie_margin"]))
        out["rivals"] = [u for u in [*out["unseparated"], *beyond_bound(checks, incs, proto)]
                         if u["effect"] != e and gain[e] - u["bic_gain"] < th["tie_margin"]]
        out["ambiguous_with"] += [u["effect"] for u in out["rivals"] if u["effect"] not in out["ambiguous_with"]]
        inc = incs[e]
        # a clip compared on all samples (flagged ones included) has its own base statistics; at a flat kink (the
        # samples plain J-A and the bare base were fitted to) the material part is the bare base's
        b0 = B["everett"]["rms_T"] if inc.get("kink") else inc["base"]["rms_T"]
        out["budget"] = (clip_budget(ja_rms, B["everett"], inc) if "ja_rms_T" in inc else
                         budget(max(ja_rms, b0), b0, min(inc["rms_T"], b0), inc["judged_on"]))
        out.update(base=inc["judged_on"], size=inc["size"])
        return out
    out["budget"] = budget(ja_rms, B[mb]["rms_T"], B[mb]["rms_T"], mb)
    out["base"] = mb
    # no effect named: one that earns and whose kind the sweep's model-free signatures show (a signature no material
    # makes, item 2 of the issue) but is beyond its size bound is still said (a flat top with a kink 28 sigma deep, a
    # clip at 4.04 V below the declared 4.8 V: a limit elsewhere in the chain, not the sensor's; bench: a Takacs core
    # through a 5 V Hall, 'unexplained' with no word of the clip). Not on the increment's own signature alone: a
    # two-phase core's accommodation from cycle to cycle passed for a drift's growth at 8x its rate bound (unipolar2)
    out["beyond_bound"] = [u for u in beyond_bound(checks, incs, proto)
                           if _signature(u["effect"], sigs) and checks[u["effect"]].get("earns")]
    return out
