"""Unmodelled effects as small augmentations of the J-A forward model.

The vocabulary is a contract (ARCHITECTURE section 4): ``none``,
``hall_offset``, ``remanent_start``, ``eddy_lag``, ``thermal_drift``,
``sensor_saturation``, ``air_gap``, ``unexplained``. Each effect (but
``none`` and ``unexplained``) has one or two parameters and acts either on the
model (initial state, molecular field) or on the signal after the model.
The same functions serve the virtual rig (to inject an effect) and the
diagnosis (to refit a model that includes it).

=================  =========================  =======================================================
effect             parameters                 forward model
=================  =========================  =======================================================
hall_offset        offset_T                   B_obs = B + offset (a constant Hall zero error)
remanent_start     M0_A_per_m                 integration starts from M(0) = M0, not 0: the core is
                                              left magnetised by an earlier sweep
eddy_lag           lag                        after each current step the flux has not settled when
                                              sampled: B_obs[j] = B[j] + lag (B_obs[j-1] - B[j]),
                                              lag = exp(-dwell / tau) in [0, 1) (first-order, per step)
thermal_drift      drift_T_per_s              B_obs = B + drift (t - t[0]): the Hall offset creeps as
                                              the coil heats (zeroed at the start of the sweep)
sensor_saturation  B_sat_T                    B_obs = min(B, B_sat): the output sticks at its limit
air_gap            Nd                         demagnetising field -Nd M of the MR-fluid gap; exactly
                                              a shift alpha' = (alpha - Nd) / (1 - Nd) (ARCHITECTURE 5)
=================  =========================  =======================================================
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import ja

VOCABULARY = (
    "none",
    "hall_offset",
    "remanent_start",
    "eddy_lag",
    "thermal_drift",
    "sensor_saturation",
    "air_gap",
    "unexplained",
)


@dataclass(frozen=True)
class EffectSpec:
    name: str
    params: tuple[str, ...]
    level: str  # "model" (changes the J-A integration) or "signal" (acts on B afterwards)
    doc: str


EFFECTS = {
    "none": EffectSpec("none", (), "signal", "plain J-A"),
    "hall_offset": EffectSpec("hall_offset", ("offset_T",), "signal", "constant Hall zero error"),
    "remanent_start": EffectSpec("remanent_start", ("M0_A_per_m",), "model", "sweep starts from a remanent state"),
    "eddy_lag": EffectSpec("eddy_lag", ("lag",), "signal", "first-order flux settling per current step"),
    "thermal_drift": EffectSpec("thermal_drift", ("drift_T_per_s",), "signal", "Hall offset drifting with time"),
    "sensor_saturation": EffectSpec("sensor_saturation", ("B_sat_T",), "signal", "sensor output at its limit"),
    "air_gap": EffectSpec("air_gap", ("Nd",), "model", "demagnetising field of the fluid gap"),
}
# effects that can be injected/refitted (all but the verdict-only 'unexplained')
MODELLED = tuple(EFFECTS)


def _check(effect: str, eparams: dict | None) -> dict:
    if effect not in EFFECTS:
        raise ValueError(f"unknown effect {effect!r}; expected one of {MODELLED}")
    eparams = dict(eparams or {})
    need = EFFECTS[effect].params
    missing = [p for p in need if p not in eparams]
    if missing:
        raise ValueError(f"effect {effect!r} needs parameter(s) {missing}")
    extra = [p for p in eparams if p not in need]
    if extra:
        raise ValueError(f"effect {effect!r} has no parameter(s) {extra}")
    return eparams


def air_gap_alpha(alpha, Nd):
    """alpha' = (alpha - Nd) / (1 - Nd): the molecular-field coefficient seen with a gap."""
    return (np.asarray(alpha, dtype=float) - Nd) / (1.0 - Nd)


def eddy_filter(B, lag):
    """B_obs[j] = B[j] + lag (B_obs[j-1] - B[j]); B_obs[0] = B[0]. Works along the last axis."""
    B = np.asarray(B, dtype=float)
    lag = np.broadcast_to(np.asarray(lag, dtype=float), B.shape[:-1])
    out = np.empty_like(B)
    out[..., 0] = B[..., 0]
    for j in range(1, B.shape[-1]):
        out[..., j] = B[..., j] + lag * (out[..., j - 1] - B[..., j])
    return out


def forward(
    ja_params,
    current_A,
    time_s,
    n_over_le: float,
    effect: str = "none",
    eparams: dict | None = None,
    *,
    form: str = "physical",
    substeps: int = 2,
    dman: str = "total",
    M0=0.0,
):
    """B (T) observed along a sweep with one effect present.

    ``ja_params``: (5,) or (n, 5). Effect parameters are scalars or arrays of
    shape (n,). Returns ``(B, ok)`` like :func:`mrhyst.ja.simulate`.
    """
    eparams = _check(effect, eparams)
    P = np.array(ja_params, dtype=float, copy=True)
    single = P.ndim == 1
    P = np.atleast_2d(P)
    m0 = M0
    if effect == "remanent_start":
        m0 = np.asarray(eparams["M0_A_per_m"], dtype=float)
    elif effect == "air_gap":
        P[:, 2] = air_gap_alpha(P[:, 2], np.asarray(eparams["Nd"], dtype=float))
    B, ok = ja.simulate(P, current_A, n_over_le, form=form, substeps=substeps, dman=dman, M0=m0)
    if effect == "hall_offset":
        B = B + np.asarray(eparams["offset_T"], dtype=float)[..., None]
    elif effect == "eddy_lag":
        B = eddy_filter(B, np.broadcast_to(np.asarray(eparams["lag"], dtype=float), B.shape[:1]))
    elif effect == "thermal_drift":
        t = np.asarray(time_s, dtype=float)
        B = B + np.asarray(eparams["drift_T_per_s"], dtype=float)[..., None] * (t - t[0])
    elif effect == "sensor_saturation":
        B = np.minimum(B, np.asarray(eparams["B_sat_T"], dtype=float)[..., None])
    if single:
        return B[0], bool(ok[0])
    return B, ok
