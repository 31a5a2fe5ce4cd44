"""The words of a reference-mode verdict (issue 24; :mod:`.refdiag` fits and decides): its one-line text, what is
ambiguous with an accepted pair, the protocol's declared confounds, a core change that did not move. Pure but
:func:`with_confounds` (the sweep's unswitched tips, model-free)."""

from __future__ import annotations

import numpy as np

from mrhyst.diagnose import confounds, unswitched


def verdict_text(effect: str, ev: dict, size: dict | None, src: str, alone: float | None = None,
                 verdict: dict | None = None) -> str:
    """The one-line verdict; ``alone``: the named change's RMS as its accepted pair sized it."""
    r0 = ev["none"]["rms_T"] * 1e3
    if effect == "none":
        return f"none: {src} predicts this sweep within its floor (RMS {r0:.3f} mT)"
    if effect == "unexplained":
        return (f"unexplained: {src} misses by {r0:.3f} mT and no single change (measurement, air gap, core "
                f"temperature, a refit of the material) brings it to the floor {ev['noise_floor_T'] * 1e3:.3f} mT"
                + _closes_but(ev, verdict))
    r1 = (alone if alone is not None else ev["candidates"][effect]["rms_T"]) * 1e3
    what = ""
    if size and size.get("value") is not None:
        se = size.get("stderr")
        what = f" ({size['param']} = {size['value']:.4g}" + (f" +- {se:.2g})" if se is not None else ")")
    elif size and size.get("moved") is not None:
        what = f" (moved: {', '.join(size['moved']) or _unidentified(size.get('moves') or {})})"
    return f"{effect}{what}: RMS {r0:.3f} -> {r1:.3f} mT from {src}"


def core_unmoved(verdict: dict, size: dict | None, effect: str) -> dict:
    """A core change named with Ms (or the temperature) within two standard errors of the reference's, a and k moved
    (the variant that frees them): no evidence of a hotter or colder core, a change of the material's a and k, so the
    refit is named beside it (a probe: a and k changed, Ms held, read as a core at Ms 0.76 +- 0.27)."""
    if effect != "core_temperature" or not size or not size.get("also") or size.get("stderr") is None:
        return verdict
    ref = float(size.get("reference_temperature_C", 1.0)) if size["param"] == "temperature_C" else 1.0
    if abs(float(size["value"]) - ref) >= 2.0 * float(size["stderr"]) or "material_changed" in verdict[
            "ambiguous_with"]:
        return verdict
    why = (f"core_temperature's {size['param']} {size['value']:.4g} is within two standard errors of the reference's "
           f"{ref:g}: a and k moved, not the core's temperature, a change of the material")
    return dict(verdict, ambiguous_with=[*verdict["ambiguous_with"], "material_changed"],
                ambiguity_reason="; ".join(x for x in (verdict.get("ambiguity_reason"), why) if x))


def _closes_but(ev: dict, verdict: dict | None) -> str:
    """An unexplained verdict whose leader did reach the floor but failed a check: said, not denied (a probe: "no
    single change ... a refit of the material brings it to the floor" while the refit left 0.155 mT and failed on
    its branch hold-out)."""
    lead = (verdict or {}).get("leader")
    failed = [k for k, ok in ((verdict or {}).get("checks") or {}).items() if not ok]
    if lead is None or not failed or "closes" in failed:
        return ""
    return (f", except {lead}, which leaves {ev['candidates'][lead]['rms_T'] * 1e3:.3f} mT but fails "
            f"{', '.join(failed)}")


def _unidentified(moves: dict) -> str:
    """What a refit that moved no parameter significantly did: it is not identified on this sweep (its standard
    errors as large as the moves), and its largest moves by ratio (a probe: a hall2 sweep against a hall1 fit read
    "moved: none significantly" while the refit explained 28 mT with k x15 and Ms x1.72)."""
    big = sorted(((abs(np.log(m["ratio"])), n, m["ratio"]) for n, m in moves.items()
                  if m.get("ratio") and m["ratio"] > 0), reverse=True)[:2]
    top = ", ".join(f"{n} x{r:.3g}" for _, n, r in big if abs(np.log(r)) > 0.01)
    return "none significantly: the refit is not identified on this sweep" + (f"; largest moves {top}" if top else "")


def pair_ambiguity(verdict: dict, th: dict) -> dict:
    """With an accepted second change, what is ambiguous is read from the pairs, not from the single changes: a
    single change fitted alone may have bent to absorb the second (a hotter core's Ms x0.29 against an offset tied
    with the refit, while the pairs differ by 16 in BIC), and the secondary itself was listed as the primary's rival
    (a probe: "core_temperature + eddy_lag (ambiguous with eddy_lag)"). A pair within ``tie_margin`` of the one
    taken names its other member as a rival of the primary (it shares the secondary) or of the secondary (it shares
    the primary), both members where it shares neither. Pure."""
    sec = verdict.get("secondary")
    if not (isinstance(sec, dict) and sec.get("accepted")):
        return verdict
    lead, e2 = verdict["effect"], sec["effect"]
    prim, other = set(), set()
    for q in sec.get("ambiguous_with") or []:
        rest = [x for x in q if x not in (lead, e2)]
        (other if lead in q else prim).update(rest)
    out = dict(verdict, ambiguous_with=sorted(prim), secondary=dict(sec, rivals=sorted(other)))
    out["ambiguity_reason"] = "; ".join(
        f"the pair {'+'.join(q)} fits almost as well (within the tie margin {th['tie_margin']:g} of "
        f"{lead}+{e2})" for q in sec.get("ambiguous_with") or [])
    return out


def with_confounds(verdict: dict, sweep, noise: float, cfg) -> dict:
    """The declared confounds of the protocol (:mod:`.confounds`, as a diagnosis applies them): a change the sweep
    cannot tell from another is named with it, and with the measurement that separates them; the refit of the
    material (``material_changed``) stands for the table's branch-shape distortion (``model_form``). A probe: a
    hotter core with a 1 mT offset on 0 -> max -> 0 named the offset beside it with no word of a remanent start."""
    from mrhyst.diagnose.core import skipped_effects

    tips = unswitched.of_sweep(sweep, noise, cfg["signatures"])
    return confounds.on_sweep(verdict, sweep, tips, skipped_effects(sweep), aliases={"material_changed": "model_form"})
