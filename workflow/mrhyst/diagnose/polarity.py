"""A reversed sign (a Hall sensor facing the other way, a coil or a fluxmeter connected the other way round): the
verdict when the sweep's own ``reversed_sign`` signature shows it (:func:`mrhyst.diagnose.signatures.reversed_sign`).

B that runs against the current over whole rising AND falling branches is no material's (B rises with H along
every branch) and no time effect's (a drift moves B one way in time, so it cannot turn both a rise and a fall).
Every fit of such a sweep fits an upside-down loop: whatever effect it would name (measured on the rig's paper
sweep with B negated: "unexplained, ambiguous with hall_offset, remanent_start", next measurement "bipolar", a
sweep that cannot help) is withdrawn; the verdict says what to fix, and the next measurement is that fix. The
fits and the layers stay in the JSON as computed, on B as declared. A pure function of the diagnosis dict: testable
without fitting.
"""

from __future__ import annotations

PROTOCOL = "reversed_sign"
FIX = ("turn the Hall sensor over (or swap the coil's leads; for a B(H) loop, the pick-up coil's or the fluxmeter's) "
       "and repeat this sweep; a sensor that stays mounted the other way round is declared with a negative "
       "sensitivity_V_per_T in the sidecar, which gives B its sign")


def reversed_signature(out: dict) -> dict | None:
    """The diagnosis's ``reversed_sign`` signature record, or None."""
    return next((s for s in out.get("signatures") or [] if s.get("kind") == "reversed_sign"), None)


def apply(out: dict) -> dict:
    """``out`` unchanged without a ``reversed_sign`` signature; else the effect ``unexplained`` with nothing
    ambiguous, ``sign`` ({"reversed", "effect_withdrawn", "size_T", "sigma"}), the fix as ``next_measurement``
    (the measured signature's sigma as its separation) and the verdict led by it."""
    sig = reversed_signature(out)
    if sig is None:
        return out
    was = out.get("effect")
    out["sign"] = {"reversed": True, "effect_withdrawn": was, "size_T": sig["size_T"], "sigma": sig["sigma"]}
    out.update(effect="unexplained", ambiguous_with=[], ambiguity_reason="", effect_size=None)
    out["next_measurement"] = {"protocol": PROTOCOL, "separation_sigma": float(sig["sigma"]), "why": FIX}
    lead = (f"sign reversed: B runs against the current over whole rising and falling branches (net "
            f"{sig['size_T'] * 1e3:+.3g} mT per branch, {sig['sigma']:.1f} sigma); no material or measurement "
            f"effect does this, so the verdict of the fits below ({was}) is withdrawn: {FIX}. As declared: ")
    out["verdict"] = lead + (out.get("verdict") or "")
    return out
