"""Protocol variants of a measured sweep, and the measurement that would best settle an ambiguity.

When two candidate explanations fit one sweep about equally well (a Hall offset and a remanent start both
shift B on a 0 -> max -> 0 loop), the lab's next question is which measurement tells them apart. This
module answers it by computation, not by a canned text: each candidate's *fitted* model predicts the
sweep under a few protocol variants, and the variant whose predictions differ most, in units of the noise
floor, is named (the contract's ``"next_measurement": {"protocol", "separation_sigma", "why"}``).

A candidate is a callable ``predict(current_A, time_s, dwell_s) -> B_T`` (the diagnosis builds one per
fitted candidate from the one forward model, so the dwell enters an eddy lag and the time a drift).

Variants of a measured path (current, time, dwell):

- ``repeat``: the measured path run twice, the second run continuing in time from the state the first
  left (a drift grows, a field-bound gap repeats);
- ``bipolar``: the virgin curve to +I_max, then -I_max and back to +I_max at the measured step (a remanent
  start is wiped out by the first full reversal; a Hall offset stays);
- ``long_dwell``: the measured path with ``dwell_factor`` times the dwell (an eddy lag decays, a drift per
  sample grows);
- ``half_amplitude``: the measured path with every current halved (a second amplitude: saturation and
  model-form gaps scale differently from offsets).

The separation of two predictions is sqrt(sum d^2) / sigma over the variant's samples: the number of noise
standard deviations by which the whole sweep tells them apart (for white noise of sd sigma the log-likelihood
ratio of the two is half its square).
"""

from __future__ import annotations

from collections.abc import Callable
from itertools import combinations

import numpy as np

VARIANTS = ("repeat", "bipolar", "long_dwell", "half_amplitude")
# Measurements a declared confound names that the candidates' J-A models cannot simulate (not in VARIANTS): the
# separation is not computed (mrhyst.diagnose.confounds)
DECLARED = {
    "saturating": "sweep once to an amplitude that saturates the core (the branches meeting before the turn), or "
                  "demagnetise it from there with a decaying alternating current, then repeat this sweep",
    "zero_field": "right after the sweep, still warm, read the sensor with no field on it (the probe out of the gap, "
                  "or the core demagnetised by a decaying alternating current) against its reading before the sweep",
}
# Declared separators that replace the simulated next measurement (the simulated variants test the J-A candidates,
# which hold no unswitched part of the core); the others join next_measurement.also beside it
DECLARED_LEADS = ("saturating",)
DESCRIPTION = {
    "repeat": "repeat the same sweep once more, right after the first",
    "bipolar": "sweep 0 -> +I_max -> -I_max -> +I_max (a full bipolar loop) at the same step",
    "long_dwell": "the same sweep with a {f:g}x longer dwell per current step",
    "half_amplitude": "the same sweep at half the current amplitude",
}


def step_of(current: np.ndarray) -> float:
    """The sweep's own current step (the median non-zero change; 1 for a path that never moves)."""
    return _step(np.asarray(current, dtype=float))


def _step(current: np.ndarray) -> float:
    d = np.abs(np.diff(current))
    d = d[d > 0]
    return float(np.median(d)) if d.size else 1.0


def _ramp(a: float, b: float, di: float) -> np.ndarray:
    n = max(int(round(abs(b - a) / di)), 1)
    return np.linspace(a, b, n + 1)


def variant_paths(current, time_s, dwell_s: float, dwell_factor: float = 5.0) -> dict:
    """{name: (current_A, time_s, dwell_s)} for every variant of VARIANTS."""
    cur = np.asarray(current, dtype=float)
    t = np.asarray(time_s, dtype=float)
    dt = float(np.median(np.diff(t))) if t.size > 1 else float(dwell_s)
    imax = float(np.max(np.abs(cur)))
    di = _step(cur)
    up = _ramp(0.0, imax, di)
    bip = np.concatenate([up, _ramp(imax, -imax, di)[1:], _ramp(-imax, imax, di)[1:]])
    back = _ramp(float(cur[-1]), float(cur[0]), di)[1:-1]  # back to the first current at the sweep's own step
    rep = np.concatenate([cur, back, cur])
    t_rep = np.concatenate([t, t[-1] + dt * np.arange(1, back.size + 1), t + (t[-1] - t[0]) + dt * (back.size + 1)])
    return {
        "repeat": (rep, t_rep, float(dwell_s)),
        "bipolar": (bip, t[0] + dt * np.arange(bip.size), float(dwell_s)),
        "long_dwell": (cur, t[0] + (t - t[0]) * dwell_factor, float(dwell_s) * dwell_factor),
        "half_amplitude": (0.5 * cur, t.copy(), float(dwell_s)),
    }


def separation(pred_a, pred_b, sigma: float) -> float | None:
    """How far apart two predicted sweeps are, in noise sigmas (root of the summed squared difference / sigma);
    None when either prediction failed (a model that cannot be integrated along that path): not a separation
    of 0, which would read as "measured, and no better"."""
    d = np.asarray(pred_a, dtype=float) - np.asarray(pred_b, dtype=float)
    if not np.all(np.isfinite(d)):
        return None
    return float(np.sqrt(np.sum(d * d)) / max(float(sigma), 1e-12))


def _weakest(pred: dict, names: list, sigma: float):
    """(the weakest pair, its separation) of the candidates' predictions on one path; (None, None) when a pair
    cannot be computed (a prediction failed)."""
    pairs = {(a, b): separation(pred[a], pred[b], sigma) for a, b in combinations(names, 2)}
    if any(v is None for v in pairs.values()):
        return None, None
    pair = min(pairs, key=pairs.get)
    return pair, pairs[pair]


def next_measurement(models: dict[str, Callable], current, time_s, dwell_s: float, sigma: float,
                     dwell_factor: float = 5.0) -> dict | None:
    """The variant that best separates the candidates in ``models`` ({name: predict}, at least two).

    With more than two candidates a variant is worth its weakest pair (the smallest pairwise
    separation): the measurement must tell every pair apart. Returns the contract's
    ``{"protocol", "separation_sigma", "why"}`` plus ``"variants"`` ({name: separation, None where a candidate
    could not be simulated along it, also listed under ``"failed"``}) and ``"measured_sigma"`` (the separation on
    the measured path itself, for comparison; None when it cannot be computed); None when no variant can be
    simulated for every candidate."""
    if len(models) < 2:
        raise ValueError("next_measurement needs at least two candidate models")
    names = list(models)
    cur = np.asarray(current, dtype=float)
    t = np.asarray(time_s, dtype=float)
    _, base = _weakest({n: models[n](cur, t, dwell_s) for n in names}, names, sigma)
    seps, worst_pair = {}, {}
    for v, (c, tv, dw) in variant_paths(cur, t, dwell_s, dwell_factor).items():
        worst_pair[v], seps[v] = _weakest({n: models[n](c, tv, dw) for n in names}, names, sigma)
    ran = [v for v in VARIANTS if seps[v] is not None]
    if not ran:
        return None
    best = max(ran, key=lambda v: (seps[v], -VARIANTS.index(v)))
    a, b = worst_pair[best]
    text = DESCRIPTION[best].format(f=dwell_factor)
    why = (f"{text}: the fitted {a} and {b} models predict sweeps {seps[best]:.1f} noise sigma apart there, "
           + (f"against {base:.1f} sigma on the measured sweep" if base is not None else
              "the measured sweep's own separation not computable")
           + ("" if len(names) == 2 else f" (weakest of the {len(names)} candidates' pairs)"))
    failed = [v for v in VARIANTS if seps[v] is None]
    return {"protocol": best, "separation_sigma": float(seps[best]), "why": why, "variants": dict(seps),
            "measured_sigma": base, **({"failed": failed} if failed else {})}
