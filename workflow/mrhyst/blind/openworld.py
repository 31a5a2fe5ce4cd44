"""Out-of-vocabulary mechanisms for the blind benchmark's open world (issue 12, point 3).

Every real loop carries physics that J-A plus the effect vocabulary (ARCHITECTURE 4) does not describe.
The mechanisms here make such gaps for the blind benchmark. Their magnetics (and their sensor physics) is
computed in this module with its own code: nothing here calls the diagnosis, and none of the mechanisms
below goes through :mod:`mrhyst.model.effects` or a J-A variant of :mod:`mrhyst.model.ja`. Where a mechanism sits *on
top of* a J-A core (a second phase, a sensor law, a leakage path), the core is the rig's plain J-A truth
(``mrhyst.rig.observe`` with no effect): the same ground truth the closed-world cases use; only the added
mechanism is new. The sensor chain (A1304 transfer, white noise, output limits, 16-bit ADC) is the rig's
(:func:`sense`, built from :mod:`mrhyst.model.hall` and :func:`mrhyst.rig.quantise`).

==================  ===============================================================================
mechanism           what, and why it matters for an MR damper
==================  ===============================================================================
``preisach``        a hysteresis law other than J-A: a scalar Preisach model whose switching fields are
                    log-normal in coercivity hc and Gaussian in interaction field hu (the factorised
                    distribution of Bertotti's *Hysteresis in Magnetism*, ch. 13), plus a reversible
                    arctan part. The damper's steel is characterised by J-A only because the paper
                    chose it; a Preisach core has no molecular field and different minor loops.
``two_phase``       a second magnetic phase: the J-A steel core plus the MR fluid's carbonyl-iron
                    particle chains, a Preisach phase whose median switching field is 0.2-5 x the core's
                    pinning k (isolated particles are softer; field-aligned chains, with shape
                    anisotropy, harder) and whose saturation is 5-30 % of the core's (fluid volume
                    fraction x gap share of the flux). The Hall probe sits in the fluid gap.
``hall_nonlinear``  the Hall sensor's gain depends on |B|: S(B) = S0 (1 + beta |B|), a second-order
                    transfer error of 0.5-6 % at the case's peak (the A1304's linearity error is of the
                    order of 1 %; a probe in a gap with a field gradient, or a less linear part, more).
``hall_gain_drift`` the Hall gain drifts with temperature as the coil heats: S(t) = S0 (1 + g(t)), g
                    rising as 1 - exp(-t / tau) to 0.5-8 % at the sweep's end (sensitivity tempco of
                    ~0.1 %/K x 5-80 K of coil heating). Multiplicative, so it is 0 at B = 0: the
                    out-of-vocabulary twin of the additive ``thermal_drift``.
``leakage``         a parallel leakage path: part of the coil's MMF drives flux through the fluid/air
                    around the core, linear in H, and the probe picks up a share:
                    B_obs = B_core + mu0 kappa H, kappa 0.2-3 (the path's permeance relative to that of
                    the air the coil's field would see). As the core saturates the leakage share of the
                    gap flux grows; J-A's saturating M cannot follow a field that keeps rising.
==================  ===============================================================================

Parameter ranges are config (``blind.openworld``); :func:`draw` draws one case's parameters,
:func:`field` computes the field the sensor reports (in tesla, S0-referred: (V - Vq) / S0 without noise),
and :func:`sense` turns it into a raw sweep like the rig's.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtr

from mrhyst import rig
from mrhyst.model import hall, ja

MU0 = ja.MU0
MECHANISMS = ("preisach", "two_phase", "hall_nonlinear", "hall_gain_drift", "leakage")
GAUSS_NODES = 48  # Gauss-Hermite nodes over ln hc (the hu integral is exact, via the normal CDF)

# default ranges (config blind.openworld overrides; the schema states the same)
DEFAULT_RANGES = {
    "preisach": {"Ms": [9.0e5, 1.9e6], "hc": [3.0e3, 3.0e4], "hc_logsd": [0.3, 0.8], "hu_over_hc": [0.2, 1.0],
                 "rev_frac": [0.05, 0.3], "h_rev": [2.0e4, 1.0e5]},
    "two_phase": {"frac": [0.05, 0.3], "hc_over_k": [0.2, 5.0], "hc_logsd": [0.2, 0.6], "hu_over_hc": [0.1, 0.5]},
    "hall_nonlinear": {"gain_error_at_peak": [0.005, 0.06]},
    "hall_gain_drift": {"gain_drift": [0.005, 0.08], "tau_over_sweep": [0.3, 3.0]},
    "leakage": {"kappa": [0.2, 3.0]},
}


def _logu(rng, lo, hi) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


# --------------------------------------------------------------------------------------------
# a Preisach model with a factorised (log-normal x Gaussian) switching-field distribution
# --------------------------------------------------------------------------------------------
def preisach_m(H, Ms: float, hc: float, hc_logsd: float, hu_sd: float, n_nodes: int = GAUSS_NODES):
    """M (A/m) of a Preisach ensemble along the field path H, from the AC-demagnetised state.

    A hysteron (alpha >= beta) switches up at H >= alpha and down at H <= beta; with coercivity
    hc = (alpha - beta)/2 and interaction field hu = (alpha + beta)/2 its thresholds are hu + hc and
    hu - hc. For one hc the 'up' hysterons are always hu <= u(hc) (a half-line): the demagnetised state is
    u = 0, rising H sets u = max(u, H - hc), falling H sets u = min(u, H + hc). Then
    M = Ms E_hc[2 Phi(u(hc) / hu_sd) - 1] with hu ~ N(0, hu_sd) (exact), ln hc ~ N(ln hc, hc_logsd)
    (Gauss-Hermite). Between samples the path is monotone, so the samples' extremes are exact."""
    H = np.asarray(H, dtype=float)
    x, w = np.polynomial.hermite_e.hermegauss(int(n_nodes))
    w = w / w.sum()
    hcs = hc * np.exp(hc_logsd * x)
    u = np.zeros_like(hcs)
    out = np.empty(H.size)
    prev = 0.0
    for j, h in enumerate(H):
        if h > prev:
            u = np.maximum(u, h - hcs)
        elif h < prev:
            u = np.minimum(u, h + hcs)
        prev = h
        out[j] = Ms * float(np.sum(w * (2.0 * ndtr(u / hu_sd) - 1.0)))
    return out


def reversible_m(H, Ms_rev: float, h_rev: float):
    """A reversible (anhysteretic, non-Langevin) part: Ms_rev (2/pi) arctan(H / h_rev)."""
    return Ms_rev * (2.0 / math.pi) * np.arctan(np.asarray(H, dtype=float) / h_rev)


# --------------------------------------------------------------------------------------------
# drawing one case's mechanism parameters, and the field the sensor reports
# --------------------------------------------------------------------------------------------
def draw(name: str, rng, truth: dict, ranges: dict | None = None) -> dict:
    """One case's parameters of mechanism ``name`` (log-uniform in its ``ranges``); ``truth``: the J-A core."""
    if name not in DEFAULT_RANGES:
        raise ValueError(f"unknown open-world mechanism {name!r}; expected one of {MECHANISMS}")
    r = dict(DEFAULT_RANGES[name], **(ranges or {}))
    if name == "preisach":
        hc = _logu(rng, *r["hc"])
        return {"Ms": _logu(rng, *r["Ms"]), "hc": hc, "hc_logsd": rng.uniform(*r["hc_logsd"]),
                "hu_sd": hc * rng.uniform(*r["hu_over_hc"]), "rev_frac": rng.uniform(*r["rev_frac"]),
                "h_rev": _logu(rng, *r["h_rev"])}
    if name == "two_phase":
        hc = truth["k"] * _logu(rng, *r["hc_over_k"])
        return {"Ms2": truth["Ms"] * _logu(rng, *r["frac"]), "hc": hc, "hc_logsd": rng.uniform(*r["hc_logsd"]),
                "hu_sd": hc * rng.uniform(*r["hu_over_hc"])}
    if name == "hall_nonlinear":
        sign = 1.0 if rng.uniform() < 0.5 else -1.0
        return {"gain_error_at_peak": sign * _logu(rng, *r["gain_error_at_peak"])}
    if name == "hall_gain_drift":
        sign = 1.0 if rng.uniform() < 0.5 else -1.0
        return {"gain_drift": sign * _logu(rng, *r["gain_drift"]), "tau_over_sweep": _logu(rng, *r["tau_over_sweep"])}
    return {"kappa": _logu(rng, *r["kappa"])}  # leakage


def has_ja_truth(name: str) -> bool:
    """Whether the mechanism sits on a J-A core (then the reference fit can start at its truth)."""
    return name != "preisach"


def field(name: str, mp: dict, truth: dict, current, time_s, n_over_le: float, substeps: int = 8):
    """(B_reported, B_core, ok): the S0-referred field the sensor reports, and the J-A core's own field
    (a Preisach core has no J-A core: B_core = B_reported)."""
    H = np.asarray(current, dtype=float) * float(n_over_le)
    if name == "preisach":
        M = preisach_m(H, (1.0 - mp["rev_frac"]) * mp["Ms"], mp["hc"], mp["hc_logsd"], mp["hu_sd"])
        M = M + reversible_m(H, mp["rev_frac"] * mp["Ms"], mp["h_rev"])
        B = MU0 * (H + M)
        return B, B, bool(np.all(np.isfinite(B)))
    core, ok = rig.observe(ja.as_param_array(truth), current, time_s, n_over_le, [], substeps=substeps)
    if name == "two_phase":
        return core + MU0 * preisach_m(H, mp["Ms2"], mp["hc"], mp["hc_logsd"], mp["hu_sd"]), core, ok
    if name == "leakage":
        return core + MU0 * mp["kappa"] * H, core, ok
    if name == "hall_nonlinear":  # V - Vq = S0 (1 + beta |B|) B, beta set by the gain error at the core's peak
        beta = mp["gain_error_at_peak"] / max(float(np.max(np.abs(core))), 1e-12)
        return core * (1.0 + beta * np.abs(core)), core, ok
    if name == "hall_gain_drift":  # V - Vq = S0 (1 + g(t)) B, g(t0) = 0, g(t_end) = gain_drift
        t = np.asarray(time_s, dtype=float)
        span = float(t[-1] - t[0]) or 1.0
        tau = mp["tau_over_sweep"] * span
        g = mp["gain_drift"] * (1.0 - np.exp(-(t - t[0]) / tau)) / (1.0 - math.exp(-span / tau))
        return core * (1.0 + g), core, ok
    raise ValueError(f"unknown open-world mechanism {name!r}; expected one of {MECHANISMS}")


def sense(B_reported, time_s, current, *, noise_sigma_T: float, seed: int, n_over_le: float, dwell_s: float,
          sensor: str = "hall1", sensitivity_V_per_T: float = hall.A1304_SENSITIVITY_V_PER_T,
          supply_V: float = hall.A1304_SUPPLY_V, output_min_V: float = 0.2, output_max_V: float = 3.1):
    """The rig's sensor chain on a given field: V = Vq + S0 B + noise, output limits, ADC; rig's sidecar keys.

    The noise is drawn as the rig draws it (one standard normal per sample from ``default_rng(seed)``),
    and the sidecar has the same keys as a blind closed-world case (no output limits)."""
    rng = np.random.default_rng(seed)
    Vq = hall.quiescent_voltage(supply_V)
    V = hall.tesla_to_volts(B_reported, sensitivity_V_per_T, Vq)
    V = V + (sensitivity_V_per_T * noise_sigma_T) * rng.standard_normal(len(current))
    V = rig.quantise(np.clip(V, output_min_V, output_max_V))
    side = {"supply_V": float(supply_V), "coil_turns_per_m": float(n_over_le), "dwell_s": float(dwell_s),
            "sensors": {sensor: {"sensitivity_V_per_T": float(sensitivity_V_per_T), "quiescent_V": float(Vq)}}}
    return {sensor: V}, np.asarray(time_s, dtype=float), np.asarray(current, dtype=float), side
