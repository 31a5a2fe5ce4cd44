"""Which measurement effects the layered rule can judge on which protocol (issue 23): a declared table, read
without fitting (like :mod:`.confounds`).

On a single unipolar sweep (0 -> max -> 0, the paper's protocol and data/raw's) the flexible, rate-independent
base (:mod:`.everett`) can absorb much of a measurement effect: its congruency ties the virgin curve to the
descending branch, a real core (J-A, two-phase, anything else) does not obey that, and an eddy lag or a drift
on top of the base makes up the difference (measured: lags named on the blind benchmark's open-world sweeps,
a second phase and a drifting Hall gain). There an effect is judged only when the sweep shows a model-free
signature no rate-independent material makes (:mod:`.signatures`); without it the layer says which material
explanation it cannot tell the effect from and which measurement separates them, instead of guessing.

=====================  ===================  ===========================  ==============  =======================
effect                 protocol class       judged when the sweep shows  else confounded  separated by
=====================  ===================  ===========================  ==============  =======================
eddy_lag               unipolar_*           against_field, held_current  model_form      long_dwell (a lag
                                                                                         scales with the rate, a
                                                                                         material shape does not)
thermal_drift          unipolar_single      held_current                 model_form      repeat (a drift goes on
                                                                                         growing, a shape repeats;
                                                                                         without repeats nor held
                                                                                         currents its signature
                                                                                         cannot show: that failure
                                                                                         is this confound too)
thermal_drift          bipolar_single       always; one that fails only  model_form      repeat
                                            its signature is this
                                            confound
hall_offset            unipolar_*           never                        remanent_start  bipolar (a reversal
                                                                                         wipes a remanent start;
                                                                                         the base holds no
                                                                                         partial remanence)
hall_offset            bipolar_single       first_zero                   model_form      repeat (a core's first
                                                                                         cycle may sit off
                                                                                         centre, an offset stays)
eddy_lag               bipolar_*            always; but an increment     model_form      long_dwell
                                            whose size follows the
                                            base's flexibility (fails
                                            only *stable* and/or
                                            *substantial*) is this
                                            confound, not a rejection
sensor_saturation      any                  always (a clip is flat: no base makes it)
any other (bipolar,    -                    always
B(H) loops)
=====================  ===================  ===========================  ==============  =======================

On a unipolar sweep with repeated cycles a drift is judged as on a bipolar one (its own signature: B at the same
current differs cycle to cycle). On one bipolar cycle (0 -> +max -> -max -> +max) the odd base, a Preisach model, is
centred after the first reversal, and a core that is not (a non-Preisach core in its first cycle: measured on
bench/heldout_openworld.py, Stoner-Wohlfarth and Preisach-Lorentz cores 0.4-3.9 mT off centre named hall_offset 3
of 42 times) is offset-like to it; there an offset is judged only when B at the first 0 A reading shows it. A
protocol missing from the table (a bipolar loop with repeats, a third-party B(H) loop) is judged for every
effect, as before.

On a bipolar sweep a lag is judged, but a few steps per branch of a steep loop leave it one reading of delay at the
switching field: the flexible base reads that as a wider loop, and the lag's size then follows the base's
flexibility (measured: Hiperco 50 through a Hall chain, 8 steps per half, lag 0.15: 0.126 on the judged base,
0.05 on the stiffest; a lag earns 35 BIC there). Such an increment, one that fails the stability check alone, is
the declared confound "a lag or a wider loop" (``confounded_when``), separated by a longer dwell (a lag scales with
the sweep rate, a material shape does not), not a rejection that leaves the verdict silent about it. So is one that
earns nothing on the flexible base where J-A + the lag earns on its own: the base took the whole lag as a wider loop
(measured: bench/heldout_realcores.py, a Hiperco 50 loop through a Hall chain, 12 steps per quarter, a per-step lag
of 0.40 at 71 sigma: J-A + the lag 16 BIC better than J-A, the flexible base + the lag 2.5 worse than the base).
The same holds for a lag that earns, predicts and keeps its size but removes less than ``min_share`` of what a base
fine enough for the sweep leaves (:mod:`.baseres`): that base follows most of the lag as a wider loop (measured: a
0.2 lag on a soft tanh core, 27 levels per branch, 16 fields: size 0.201, BIC gain 52, base 0.30 mT against a
0.25 mT noise).
"""

from __future__ import annotations

from dataclasses import dataclass

UNIPOLAR = ("unipolar_single", "unipolar_repeated")
BIPOLAR = ("bipolar_single", "bipolar_repeated")


@dataclass(frozen=True)
class Reach:
    effect: str
    protocols: tuple  # protocol classes (mrhyst.diagnose.confounds.protocol_class) this row covers
    requires: tuple | None  # signature kinds of which one must show for the effect to be judged (empty: never
    #                        judged; None: always judged)
    partner: str  # the explanation it is confounded with otherwise (vocabulary name; model_form = a shape)
    separated_by: str  # the protocol variant (mrhyst.diagnose.protocols.VARIANTS) that separates them
    why: str
    confounded_when: tuple = ("separable",)  # the checks (mrhyst.diagnose.layered.checks_of) whose failure, with
    #                                          every other check passed, makes the increment this confound


DRIFT_WHY = ("a slow drift and a branch-shape distortion bend one pass alike; on a repeat a drift goes on growing, a "
             "shape repeats")

TABLE = (
    Reach("eddy_lag", UNIPOLAR, ("against_field", "held_current"), "model_form", "long_dwell",
                      "on one unipolar sweep a flexible rate-independent base absorbs an eddy lag as a wider loop "
                      "and a virgin curve off its congruency; a lag scales with the sweep rate, a material shape "
                      "does not"),
    # a loop turned clockwise is no material shape's either (signatures.clockwise): the drift is judged then too
    Reach("thermal_drift", ("unipolar_single",), ("held_current", "clockwise"), "model_form", "repeat", DRIFT_WHY,
          confounded_when=("separable", "signature")),
    # one bipolar cycle: judged (a declared start from a tip repeats part of its path: the drift's own signature),
    # but a drift that fails only its signature (a sweep from 0 A repeats nothing) is this confound
    Reach("thermal_drift", ("bipolar_single",), None, "model_form", "repeat", DRIFT_WHY,
          confounded_when=("signature",)),
    Reach("hall_offset", UNIPOLAR, (), "remanent_start", "bipolar",
          "a constant offset and a remanent start both move B at the 0 A start of a unipolar sweep "
          "(the flexible base holds no partial remanence); a full reversal to -I_max wipes a "
          "remanent start and keeps an offset"),
    Reach("hall_offset", ("bipolar_single",), ("first_zero",), "model_form", "repeat",
          "on one bipolar cycle a core that is not yet symmetric (its first cycle off centre) looks offset to the "
          "odd flexible base; on a repeated cycle a core's loop settles, an offset stays"),
    Reach("eddy_lag", BIPOLAR, None, "model_form", "long_dwell",
          "with a few steps per branch of a steep loop a lag and a wider loop look alike to every base (the lag's "
          "size follows the base's flexibility); a lag scales with the sweep rate, a material shape does not",
          confounded_when=("stable", "substantial", "earns")),
)


# what J-A's own gap can pass for (a clip is flat: not here), and the sweep that tells each from a material shape J-A
# lacks on a protocol no row of TABLE limits (:func:`shape_separator`; the veto of mrhyst.diagnose.layerfit reads it)
SHAPE_SEPARATORS = {
    "hall_offset": ("bipolar", "a material's loop is centred on B = 0 after a full reversal, an offset moves it"),
    "thermal_drift": ("repeat", "on a repeat a drift goes on growing, a shape repeats"),
    "eddy_lag": ("long_dwell", "a lag scales with the sweep rate, a material shape does not"),
}


# what separates a clip from a material knee: not in SHAPE_SEPARATORS, whose members the material veto may withdraw
# (a clip is flat, no material makes it); read by :func:`separator` for a clip beyond its size bound
CLIP_SEPARATOR = ("half_amplitude", "a clip cuts B at one level whatever the drive: at half the current amplitude B "
                  "stays below it and the flat top goes, while a material's knee scales with the drive")


def separator(effect: str, protocol: str | None, table=TABLE) -> tuple[str, str]:
    """(the protocol variant that separates ``effect`` from a material shape, why) for any vocabulary effect: the
    table's row or :data:`SHAPE_SEPARATORS` (:func:`shape_separator`), a clip's :data:`CLIP_SEPARATOR`, else a
    repeat of the sweep (mrhyst.diagnose.layered.beyond_bound: an increment beyond its size bound)."""
    if effect == "sensor_saturation":
        return CLIP_SEPARATOR
    return shape_separator(effect, protocol, table) or ("repeat", "a repeat of the sweep")


def shape_separator(effect: str, protocol: str | None, table=TABLE) -> tuple[str, str] | None:
    """(the protocol variant that separates ``effect`` from a material shape, why) on ``protocol``: the row of
    ``table`` whose partner is ``model_form`` there, else :data:`SHAPE_SEPARATORS` (None: not an effect J-A's gap
    passes for)."""
    r = next((r for r in table if r.effect == effect and protocol in r.protocols and r.partner == "model_form"), None)
    return (r.separated_by, r.why) if r is not None else SHAPE_SEPARATORS.get(effect)


def reach(effect: str, protocol: str, table=TABLE) -> Reach | None:
    """The row that limits ``effect`` on ``protocol``, or None (judged as on a bipolar loop)."""
    return next((r for r in table if r.effect == effect and protocol in r.protocols), None)


def separable(effect: str, protocol: str, sigs, table=TABLE) -> bool:
    """Can the layer judge ``effect`` on this protocol, given the sweep's model-free signatures (``sigs``: the
    contract's records; a record counts when its kind is one the row requires)? Pure: no fitting."""
    r = reach(effect, protocol, table)
    if r is None or r.requires is None:
        return True
    kinds = {str(s.get("kind")) for s in (sigs or [])}
    return bool(kinds & set(r.requires))


def confounded(effect: str, protocol: str, failed, table=TABLE) -> Reach | None:
    """The row whose confound an increment is when exactly the checks ``failed`` (names of the checks that came
    out False) failed: some failed, and every one of them is one of the row's ``confounded_when``; else None."""
    r = reach(effect, protocol, table)
    failed = set(failed)
    return r if r is not None and failed and failed <= set(r.confounded_when) else None
