"""A reversed sign (a Hall sensor facing the other way, a coil or a fluxmeter connected the other way round): the
verdict when the sweep's own ``reversed_sign`` signature shows it (:func:`mrhyst.diagnose.signatures.reversed_sign`).

B that runs against the current over whole rising AND falling branches is no material's (B rises with H along
every branch) and no time effect's (a drift moves B one way in time, so it cannot turn both a rise and a fall).
Every fit of such a sweep fits an upside-down loop: whatever effect it would name (measured on the rig's paper
sweep with B negated: "unexplained, ambiguous with hall_offset, remanent_start", next measurement "bipolar", a
sweep that cannot help) is withdrawn; the verdict says what to fix, and the next measurement is that fix. The
fits and the layers stay in the JSON as computed, on B as declared. A pure function of the diagnosis dict: testable
without fitting.

A loop that runs clockwise (signature ``clockwise``: the integral of H dB along it is negative) is no material's at a
fixed temperature either, though B may rise with H along every branch (B read in reverse order, B leading the
current, or a drift larger than the loop's opening): a material verdict (``none``, ``model_form``) of such a sweep is
withdrawn the same way (:func:`orientation`); a measurement verdict stands, the signature in its verdict line.
"""

from __future__ import annotations

PROTOCOL = "reversed_sign"
FIX = ("turn the Hall sensor over (or swap the coil's leads; for a B(H) loop, the pick-up coil's or the fluxmeter's) "
       "and repeat this sweep; a sensor that stays mounted the other way round is declared with a negative "
       "sensitivity_V_per_T in the sidecar, which gives B its sign")


ORIENTATION_PROTOCOL = "long_dwell"
ORIENTATION_FIX = ("check that B and the current (or H) are read in step and in order (a B reading taken before "
                   "its current was set, one channel's samples shifted or reversed in time), then repeat the sweep "
                   "with the current held at its top for a while: B that moves while the current is held is a drift "
                   "(of the sensor, or the core warming), B that stays points at the channels' timing")
MATERIAL = ("none", "model_form")


def _signature(out: dict, kind: str) -> dict | None:
    return next((s for s in out.get("signatures") or [] if s.get("kind") == kind), None)


def reversed_signature(out: dict) -> dict | None:
    """The diagnosis's ``reversed_sign`` signature record, or None."""
    return _signature(out, "reversed_sign")


def apply(out: dict) -> dict:
    """``out`` as :func:`orientation` leaves it without a ``reversed_sign`` signature; else the effect
    ``unexplained`` with nothing ambiguous, ``sign`` ({"reversed", "effect_withdrawn", "size_T", "sigma"}), the fix
    as ``next_measurement`` (the measured signature's sigma as its separation) and the verdict led by it."""
    sig = reversed_signature(out)
    if sig is None:
        return orientation(out)
    was = out.get("effect")
    out["sign"] = {"reversed": True, "effect_withdrawn": was, "size_T": sig["size_T"], "sigma": sig["sigma"]}
    out.update(effect="unexplained", ambiguous_with=[], ambiguity_reason="", effect_size=None)
    out["next_measurement"] = {"protocol": PROTOCOL, "separation_sigma": float(sig["sigma"]), "why": FIX}
    lead = (f"sign reversed: B runs against the current over whole rising and falling branches (net "
            f"{sig['size_T'] * 1e3:+.3g} mT per branch, {sig['sigma']:.1f} sigma); no material or measurement "
            f"effect does this, so the verdict of the fits below ({was}) is withdrawn: {FIX}. As declared: ")
    out["verdict"] = lead + (out.get("verdict") or "")
    return out


def orientation(out: dict) -> dict:
    """``out`` unchanged without a ``clockwise`` signature or with a measurement verdict (the signature is in its
    line); else ``orientation`` ({"clockwise", "effect_withdrawn", "size_T", "sigma"}), the check of the channels and a
    held current as ``next_measurement`` (declared: no separation simulated; the fitted candidates it would compare
    all follow a loop no material makes) and the verdict led by it; a material verdict (:data:`MATERIAL`) is
    withdrawn (the effect ``unexplained`` with nothing ambiguous), an ``unexplained`` one stays (withdrawn: None)."""
    sig = _signature(out, "clockwise")
    was = out.get("effect")
    if sig is None or was not in (*MATERIAL, "unexplained"):
        return out
    gone = was if was in MATERIAL else None
    out["orientation"] = {"clockwise": True, "effect_withdrawn": gone, "size_T": sig["size_T"], "sigma": sig["sigma"]}
    out.update(effect="unexplained", ambiguous_with=[], ambiguity_reason="", effect_size=None)
    out["next_measurement"] = {"protocol": ORIENTATION_PROTOCOL, "separation_sigma": None, "why": ORIENTATION_FIX}
    lead = (f"loop runs clockwise: the integral of H dB along it is negative (mean opening "
            f"{sig['size_T'] * 1e3:+.3g} mT, {sig['sigma']:.1f} sigma); no material at a fixed temperature does this"
            + (f", so the verdict of the fits below ({gone}) is withdrawn" if gone else "")
            + f": {ORIENTATION_FIX}. As declared: ")
    out["verdict"] = lead + (out.get("verdict") or "")
    return out
