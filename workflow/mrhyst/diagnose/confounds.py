"""Confounds in the verdict (issue 23, item 3): which explanations a protocol cannot separate, declared.

Some pairs of explanations fit one protocol alike whatever the data: the evidence rule's BIC tie
(``tie_margin``) finds them only when the two fits happen to land close. Here they are a table, read
without fitting: when the verdict (or the best candidate of a ``partial``) is one member of a pair that the
sweep's protocol cannot separate, the other is named in ``ambiguous_with``, ALWAYS, with the protocol that
separates them (its separation in noise sigmas comes from the candidates' fitted models, :mod:`.nextmeas`).

Protocol classes (:func:`protocol_class`, from the current path alone):

* ``unipolar_single`` - one sign of current, no repeated (current, direction) after the first branch
  (the paper's 0 -> max -> 0);
* ``unipolar_repeated`` - one sign, repeated cycles;
* ``bipolar_single`` - both signs, no repeat after the first branch (0 -> +max -> -max -> +max);
* ``bipolar_repeated`` - both signs, repeated cycles;
* ``no_time`` - a third-party B(H) loop without sample times (no drift, no remanent start to judge).

=================================  ======================================  ============  ======================
pair                               protocols that cannot separate it       separated by  why
=================================  ======================================  ============  ======================
hall_offset / remanent_start       unipolar_single, unipolar_repeated      bipolar       both move the 0 A
                                                                                         start; a full reversal
                                                                                         wipes a remanent
                                                                                         start, an offset stays
thermal_drift / model_form         unipolar_single, bipolar_single         repeat        a slow drift and a
                                                                                         branch-shape
                                                                                         distortion (a Hall
                                                                                         gain rising with |B|)
                                                                                         bend one pass alike; a
                                                                                         drift goes on in time,
                                                                                         a shape repeats
hall_offset / remanent_start       unipolar_single, unipolar_repeated,     saturating    a bipolar sweep wipes
                                   when the loop is open at its turning                  a J-A-like remanence
                                   point (:mod:`.unswitched`)                            only; a part of the
                                                                                         core that switches
                                                                                         beyond this amplitude
                                                                                         keeps its remanence
                                                                                         through a reversal
hall_offset (named) /              bipolar_single, bipolar_repeated, when  saturating    a part of the core
remanent_start                     the loop is open at its turning points                whose switching fields
                                   (:mod:`.unswitched`)                                  lie beyond the sweep
                                                                                         keeps its remanence: a
                                                                                         constant B, an offset
                                                                                         on any sweep up to
                                                                                         that amplitude
thermal_drift (named) /            unipolar_single, bipolar_single,        zero_field    a Hall warmed by the
model_form                         unipolar_repeated (B of one sign: a                   coil drifts in
                                   sensitivity drift grows cycle to cycle                sensitivity: it grows
                                   as an offset drift does; on a bipolar                 with time as a drift
                                   repeat it scales the loop, an offset                  does; at zero field an
                                   drift shifts it)                                      offset drift shows, a
                                                                                         sensitivity drift not
hall_offset / remanent_start       bipolar_single, when B at the first 0   repeat        the reversal wipes a
                                   A reading is left to no named effect                  remanent start, but
                                   (a material verdict; :func:`.layerfit.                the centre that shows
                                   start_rows`)                                          an offset is no proof
                                                                                         on one cycle of a core
                                                                                         the models do not
                                                                                         follow (its first
                                                                                         cycle off centre)
=================================  ======================================  ============  ======================

Both unipolar rows apply to a sweep still open at its turning point: the verdict's ``next_measurement`` is then the
saturating sweep (it separates either kind of start), and ``next_measurement.also`` the bipolar one (it separates a
J-A-like remanence only). A unipolar sweep closed at its turn (a saturated core: no part left unswitched) keeps
``bipolar``.

A row with ``named`` applies only to those verdicts (a remanent start named on a bipolar sweep was seen wiped: the
loop's centre moved back, so no offset); a row with ``when`` only to a sweep with that fact (``facts`` of
:func:`apply`, e.g. ``open_at_tips``). Its separator may be a declared measurement that the J-A candidates'
models cannot simulate (:data:`mrhyst.diagnose.protocols.DECLARED`); a `saturating` one replaces the simulated
``next_measurement`` (``DECLARED_LEADS``), the others join ``next_measurement.also`` beside it: the zero-field reading
that tells a drifting offset from a drifting sensitivity leaves the simulated sweep that tells the drift from a shape
(bench/heldout_openworld.py's self-heated Hall gains named thermal_drift on one bipolar cycle had only a repeat and a
long dwell, where a sensitivity grows as a drift does).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mrhyst.data.shape import PathShape, path_shape
from mrhyst.diagnose.protocols import DECLARED, DECLARED_LEADS


@dataclass(frozen=True)
class Confound:
    effects: tuple  # the two explanations (vocabulary names; model_form = a branch-shape distortion)
    protocols: tuple  # protocol classes that cannot separate them
    separated_by: str  # the protocol variant (mrhyst.diagnose.protocols.VARIANTS or DECLARED) that does
    why: str
    named: tuple = ()  # the verdicts it applies to (empty: either member)
    when: str = ""  # a fact of the sweep it needs (empty: always)
    adds: bool = True  # False: its separator is carried (next_measurement.also), its partner never added to
    #                    ambiguous_with (the partner stands for something the vocabulary has no name for)


TABLE = (
    Confound(("hall_offset", "remanent_start"), ("unipolar_single", "unipolar_repeated"), "bipolar",
             "a constant offset and a remanent start both move B at the 0 A start of a unipolar sweep; a full "
             "reversal to -I_max wipes a J-A-like remanent start and keeps an offset (the loop's centre moves)"),
    Confound(("hall_offset", "remanent_start"), ("unipolar_single", "unipolar_repeated"), "saturating",
             "the loop is still open at its turning point, so parts of the core may switch only beyond this "
             "amplitude; a bipolar sweep to the same amplitude wipes a J-A-like remanence but not theirs, which stays "
             "a constant B, an offset on any sweep up to that amplitude",
             when="open_at_tips"),
    Confound(("thermal_drift", "model_form"), ("unipolar_single", "bipolar_single"), "repeat",
             "a slow drift and a branch-shape distortion (e.g. a Hall gain that rises with |B|) bend one pass "
             "alike; on a repeat (or a zero-current hold after the sweep) a drift goes on growing, a shape repeats"),
    Confound(("hall_offset", "remanent_start"), ("bipolar_single", "bipolar_repeated"), "saturating",
             "the loop is still open at its turning points, so parts of the core may switch only beyond the sweep's "
             "amplitude; their remanence from before the sweep stays, a constant B that is a Hall offset on any sweep "
             "up to that amplitude (a J-A core has no such part, a Preisach or two-phase core does)",
             named=("hall_offset",), when="open_at_tips"),
    Confound(("hall_offset", "remanent_start"), ("bipolar_single",), "repeat",
             "the reversal wipes a J-A-like remanent start and an offset stays in the loop's centre, but on one "
             "bipolar cycle of a core whose loop the models do not follow that is no proof: its first cycle may be "
             "off centre itself; on a repeated cycle the loop settles, an offset stays in its centre, a remanent "
             "start is gone",
             when="first_reading"),
    # unipolar_repeated: measured (bench/heldout_openworld.py's self-heated Hall gains on 0 -> 2 -> 0 -> 2 -> 0 A,
    # seed 7): named thermal_drift on 2 of 9 with nothing beside it; on two bipolar cycles on none of 7
    Confound(("thermal_drift", "model_form"), ("unipolar_single", "bipolar_single", "unipolar_repeated"), "zero_field",
             "a Hall element warmed by the coil may drift in sensitivity rather than in offset: that too grows with "
             "time, on a repeat or a longer dwell as a drift does; at zero field a drifting offset reads its drift, a "
             "drifting sensitivity reads nothing",
             named=("thermal_drift",), adds=False),
)


def protocol_class(current, has_time: bool = True) -> str:
    """The protocol class of a current path (module docstring): its values or its
    :class:`~mrhyst.data.shape.PathShape` (a diagnosis hands the sweep's, derived once)."""
    if not has_time:
        return "no_time"
    sh = current if isinstance(current, PathShape) else path_shape(current)
    cur = np.asarray(sh.path, dtype=float)
    bip = bool(np.min(cur) < 0 < np.max(cur))
    return f"{'bipolar' if bip else 'unipolar'}_{'repeated' if _repeats(sh) else 'single'}"


def _repeats(sh: PathShape) -> bool:
    """True when some (current, direction) after the first branch is met again one cycle later."""
    cur, cyc, dirs = sh.path, sh.cycle, sh.directions
    after = np.arange(cur.size) > sh.segments[0].stop
    for c in range(1, int(cyc.max()) + 1):
        prev = {(round(float(cur[j]), 12), int(dirs[j])) for j in np.flatnonzero((cyc == c - 1) & after)}
        if any((round(float(cur[j]), 12), int(dirs[j])) in prev for j in np.flatnonzero((cyc == c) & after)):
            return True
    return False


def for_effect(effect: str | None, protocol: str, table=TABLE, facts=()) -> list[Confound]:
    """The declared confounds of ``effect`` under ``protocol`` on a sweep with ``facts``."""
    return [c for c in table if effect in c.effects and protocol in c.protocols
            and (not c.named or effect in c.named) and (not c.when or c.when in facts)]


def of_fact(pair, protocol: str, facts=(), table=TABLE) -> list[Confound]:
    """The rows of ``pair`` (two vocabulary names) on ``protocol`` that a fact of this sweep brings in (a row with
    ``when``): their separator is what is true of this sweep beside a static table's (:mod:`.layertable`)."""
    return [c for c in table if set(c.effects) == set(pair) and protocol in c.protocols and c.when and c.when in facts]


def facts_of(out: dict) -> set:
    """The sweep facts a diagnosis recorded (``unswitched``: :mod:`.unswitched`)."""
    return {"open_at_tips"} if (out.get("unswitched") or {}).get("open") else set()


def apply(verdict: dict, protocol: str, skipped=(), table=TABLE, facts=(), aliases=None) -> dict:
    """A copy of ``verdict`` (:func:`mrhyst.diagnose.policy.decide`) with the declared confounds of its effect
    added to ``ambiguous_with`` (and to ``ambiguity_reason``) and of its partial leader to
    ``partial["ambiguous_with"]``; ``confounds`` lists them all (``added``: the partner was not already
    ambiguous by the BIC tie), those of an accepted secondary effect too (``of``: "secondary", never added: the
    verdict's own set is the primary's). A partner the sweep cannot judge (``skipped``: no sample times, a B(H)
    loop's start) is not added. ``aliases``: {a mode's name: the table's} (reference mode's ``material_changed``, a
    refit of the core's shape, is the table's ``model_form``); partners are named back in the mode's words. Pure."""
    alias = dict(aliases or {})
    back = {v: k for k, v in alias.items()}
    out = dict(verdict)
    found = []
    targets = [("verdict", out["effect"])]
    part = dict(out.get("partial") or {})
    if part.get("effect"):
        targets.append(("partial", part["effect"]))
    sec = out.get("secondary")
    if isinstance(sec, dict) and sec.get("accepted") and sec.get("effect"):
        targets.append(("secondary", sec["effect"]))
    for where, eff in targets:
        me = alias.get(eff, eff)
        for c in for_effect(me, protocol, table, facts):
            other = next(e for e in c.effects if e != me)
            other = back.get(other, other)
            if other in skipped or eff in skipped or (where != "verdict" and other == out["effect"]):
                continue  # a partner the sweep cannot judge; a partial leader confounded with the verdict itself
            added = where == "verdict" and c.adds and other not in out["ambiguous_with"]
            found.append({"effects": [back.get(e, e) for e in c.effects], "of": where, "protocol": protocol,
                          "separated_by": c.separated_by, "why": c.why, "added": added})
            if added:
                out["ambiguous_with"] = [*out["ambiguous_with"], other]
                reason = f"{eff} and {other} are not separable on this protocol ({protocol}): {c.why}"
                out["ambiguity_reason"] = "; ".join(x for x in (out.get("ambiguity_reason"), reason) if x)
            elif where == "partial" and c.adds:
                part["ambiguous_with"] = sorted({*part.get("ambiguous_with", []), other})
    if part:
        out["partial"] = part
    out["confounds"] = found
    return out


def on_sweep(verdict: dict, sweep, tips: dict, skipped=(), aliases=None) -> dict:
    """:func:`apply` with the sweep's protocol class and facts (``tips``: :func:`mrhyst.diagnose.unswitched.of_sweep`):
    one call for the plain diagnosis and reference mode."""
    return apply(verdict, protocol_class(sweep.measured_shape, sweep.has_time), skipped,
                 facts=facts_of({"unswitched": tips}), aliases=aliases)


def attach(out: dict, verdict: dict, nm: dict | None) -> None:
    """Into the diagnosis ``out``: ``confounds`` (each with the simulated separation of its protocol, from the
    ``next_measurement`` variants when computed, else null), and a ``next_measurement`` from the table when
    the candidates' models could not be simulated (``separation_sigma`` null: not computed)."""
    rows = []
    for c in verdict.get("confounds") or []:
        sep = ((nm or {}).get("variants") or {}).get(c["separated_by"])
        rows.append(dict(c, separation_sigma=sep))
    out["confounds"] = rows
    first = next((c for c in rows if c["of"] == "verdict"), None) or next(
        (c for c in rows if c["of"] == "secondary"), None)  # the secondary's when the verdict's own has none
    if not declared_next(out, rows, nm) and nm is None and first is not None:
        out["next_measurement"] = {"protocol": first["separated_by"], "separation_sigma": None,
                                   "why": f"{first['why']} (declared confound; the candidates' models were not "
                                          f"simulated, so no separation is given)"}


def declared_next(out: dict, rows: list, nm: dict | None) -> bool:
    """A verdict's confound whose separator no candidate model can simulate (:data:`DECLARED`) sets
    ``next_measurement``: the simulated variants test the J-A candidates, not that confound. True when set."""
    row = next((c for c in rows if c["of"] == "verdict" and c["separated_by"] in DECLARED_LEADS), None)
    if row is None:
        return False
    sim = f"; the simulated candidates' best variant was {nm['protocol']}" if (nm or {}).get("protocol") else ""
    kept = {k: nm[k] for k in ("variants", "measured_sigma") if k in (nm or {})}  # the simulated figures stay
    out["next_measurement"] = {**kept, "protocol": row["separated_by"], "separation_sigma": None,
                               "why": f"{DECLARED[row['separated_by']]}: {row['why']} (declared confound, not "
                                      f"simulated: the fitted J-A models hold no unswitched part{sim})"}
    return True
