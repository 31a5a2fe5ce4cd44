"""Unmodelled effects and the ONE forward model: J-A plus any set of effects.

The vocabulary is a contract (ARCHITECTURE section 4): ``none``, ``hall_offset``, ``remanent_start``,
``eddy_lag``, ``thermal_drift``, ``sensor_saturation``, ``air_gap``, ``model_form`` (physics J-A leaves
out; diagnosed by :mod:`mrhyst.diagnose.modelform`, not an augmentation of J-A) and ``unexplained``.

Every augmentation is ONE :class:`Effect` entry of :data:`REGISTRY` (issue 22): its parameters, physical
stage, forward action, what a sweep must provide to judge it (``needs``: sample times, a free start state, a
sensor), the diagnosis's coordinate (scale, bounds, data-derived starts, deep-search grid; or a ``shared`` J-A
coordinate, the air gap's alpha'), its plausible-size check (issue 12; its numbers in config
``diagnose.plausible``), its roles in an ambiguity (``confused_with``) and a next measurement (``at_dwell``), and
its blind draw (``draw``, ``draw_keys``: random numbers from its own stream, keyed by its name).
:func:`forward` applies any set of them in physical order; the virtual rig (:func:`mrhyst.rig.observe`) and the
diagnosis (:class:`mrhyst.diagnose.problem.Problem`) both call it, and nothing else applies an effect.
:func:`register` adds an effect (tests register toy effects that then flow rig -> diagnosis -> blind score; the
config schema's effect enums are tested against this registry).

Physical order (``STAGES``): ``model`` (the core: initial state, molecular field) -> ``flux`` (eddy
settling of the flux) -> ``zero`` (the Hall zero error) -> ``output`` (the sensor's output limit).

=================  ==============  ======  ===============================================================
effect             parameter       stage   forward action
=================  ==============  ======  ===============================================================
remanent_start     M0_A_per_m      model   the integration starts from M(0) = M0 (left by an earlier sweep)
air_gap            Nd              model   demagnetising field -Nd M: alpha' = (alpha - Nd)/(1 - Nd)
eddy_lag           lag             flux    B_obs[j] = B[j] + lag (B_obs[j-1] - B[j]), lag = exp(-dwell/tau)
hall_offset        offset_T        zero    B_obs = B + offset (a constant Hall zero error)
thermal_drift      drift_T_per_s   zero    B_obs = B + drift (t - t[0]) (the offset creeps as the coil heats)
sensor_saturation  B_sat_T         output  B_obs = clip(B, -B_sat, B_sat) (the output sticks at either limit)
=================  ==============  ======  ===============================================================
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numba
import numpy as np

from mrhyst.model import ja

MU0 = ja.MU0
STAGES = ("model", "flux", "zero", "output")


@dataclass
class Context:
    """What an effect's diagnosis hooks may know of a sweep (built by the diagnosis's Problem)."""

    span_mT: float  # largest |B| or peak-to-peak of the data, mT
    duration_s: float  # time from the first to the last sample
    B_mT: np.ndarray  # observed B, mT
    t_rel: np.ndarray  # (t - t0) / duration
    mask: np.ndarray  # samples fitted
    dwell_s: float | None = None  # time per current step (None when unknown)
    sensor: dict = field(default_factory=dict)  # sensitivity_V_per_T, quiescent_V, supply_V[, output_*_V] if known
    ja_coords: np.ndarray | None = None  # the base fit's J-A coordinates (ln Ms, ln a, alpha, c, ln k)


# What a sweep may provide that an effect needs to be judged at all (Effect.needs): the diagnosis says which
# it provides (mrhyst.diagnose.core.provided) and skips, with the effect's own reason, any effect that lacks one
NEEDS = {
    "time": "sample times over a time span (a per-second or per-step effect)",
    "free_start": "a start state the sweep leaves free (not a loop simulated in cyclic steady state)",
    "sensor": "a known Hall sensor (sensitivity and supply in the sidecar)",
}


@dataclass(frozen=True)
class SharedCoord:
    """How an effect without a coordinate of its own lives in J-A's (the air gap: alpha' = (alpha - Nd)/(1 - Nd)
    is a shift of alpha). It lets J-A coordinate ``col`` go down to config ``diagnose.<lo_key>``; ``size(x)`` is
    its contract size at that coordinate's value x, ``slope(x)`` = d size / dx, ``ja_value(x)`` the J-A parameter
    reported beside it, ``note(x)`` the contract's sentence on its size (None: none)."""

    col: int
    lo_key: str
    size: Callable
    slope: Callable
    ja_value: Callable
    note: Callable | None = None


@dataclass(frozen=True)
class Effect:
    """One augmentation of J-A: the single place that defines it.

    ``model(P, M0, value) -> (P, M0)`` (stage ``model``) or ``signal(B, value, time_s) -> B`` (other
    stages) is the forward action, batched: ``value`` is a scalar or an (n,) array. For the diagnosis:
    ``coord`` names its fitted coordinate (None: it reuses J-A's alpha, the air gap), ``unit(ctx)`` is
    the contract value of one coordinate unit, ``bounds(ctx)`` the coordinate's box, ``null`` the value
    that means "absent", ``starts(ctx, resid_mT)`` data-derived starts, ``grid(ctx)`` the deep-search
    grid, ``plausible(value, ctx, ranges) -> (ok, why)`` the physical-size check (``ranges``: config
    ``diagnose.plausible``).
    """

    name: str
    param: str
    stage: str
    doc: str
    model: Callable | None = None
    signal: Callable | None = None
    coord: str | None = None
    unit: Callable = lambda ctx: 1.0
    bounds: Callable = lambda ctx: (-np.inf, np.inf)
    null: float = 0.0
    starts: Callable = lambda ctx, r: [0.0]
    grid: Callable = lambda ctx: [0.0]
    plausible: Callable = lambda value, ctx, ranges: (True, "no range stated")
    step: float = 1e-6  # forward-difference step of the coordinate (Jacobian)
    # False when one branch cannot determine the effect apart from J-A's shape (a drift rate over time on the
    # ascending branch alone trades off against a, c, k): the branch hold-out then does not judge it
    branch_identifiable: bool = True
    # True when the effect grows with time, not with the field (a drift): on repeated cycles its residual
    # must grow from one cycle to the next (issue 13), a field-bound gap repeats instead
    time_bound: bool = False
    # False when the effect's evidence sits in one stretch of the path that a contiguous CV block holds whole
    # (a remanent start shows at the first samples): the block CV then cannot predict it and does not judge it
    block_identifiable: bool = True
    # The blind benchmark (mrhyst.blind): draw(rng, m, case) -> (params, record) of one case's injected size,
    # m = config blind.magnitude, case = {"sigma_T", "peak_T", "truth", "duration_s",
    # "sensitivity_V_per_T" (the case's Hall)}; None: not drawn there
    draw: Callable | None = None
    # The blind key's independent reference fit (mrhyst.blind.reference): ref_starts(case) -> (starts, (lo, hi))
    # in contract units, case = {"resid_T" (of plain J-A), "B_T", "t_s" (from 0), "peak_T", "ja" (J-A set)}
    ref_starts: Callable = lambda case: ([0.0], (-np.inf, np.inf))
    # The size as the diagnosis reports it, from the injected params and the truth (None: the parameter itself)
    reported: Callable | None = None
    # What a sweep must provide to judge it: {need of NEEDS: why it is skipped without it}
    needs: dict = field(default_factory=dict)
    # Its contract size on a protocol with ``ratio`` x the measured dwell per step (the next measurement,
    # mrhyst.diagnose.nextmeas): at_dwell(value, ratio); None: the size is per second or per field, unchanged
    at_dwell: Callable | None = None
    # No coordinate of its own (coord None): how it widens one of J-A's (SharedCoord)
    shared: SharedCoord | None = None
    # Effects it is confounded with on one sweep, {other: why}: the ambiguity reason (mrhyst.diagnose.policy)
    confused_with: dict = field(default_factory=dict)
    # True: its parameter is a |B| limit that the rig realises as the sensor's output limit (before the ADC), not
    # by clipping the noise-free B (mrhyst.rig.simulate_case)
    output_limit: bool = False
    # The config blind.magnitude keys its draw reads (the schema requires these, tests/test_registry_schema.py)
    draw_keys: tuple = ()

    @property
    def params(self) -> tuple[str, ...]:
        return (self.param,)


# ------------------------------------------------------------------ forward actions
def air_gap_alpha(alpha, Nd):
    """alpha' = (alpha - Nd) / (1 - Nd): the molecular-field coefficient seen with a gap."""
    return (np.asarray(alpha, dtype=float) - Nd) / (1.0 - Nd)


def eddy_filter(B, lag):
    """B_obs[j] = B[j] + lag (B_obs[j-1] - B[j]); B_obs[0] = B[0]. Works along the last axis."""
    B = np.asarray(B, dtype=float)
    lag = np.asarray(lag, dtype=float)
    if B.ndim == 2 and lag.shape == B.shape[:1] and B.shape[1] and B.flags.c_contiguous and lag.flags.c_contiguous:
        return _eddy_rows(_writable(B), _writable(lag))  # a batch of rows, a lag each (the fitting loop's case)
    lag = np.broadcast_to(lag, B.shape[:-1])
    if B.shape[-1] == 0:
        return np.empty_like(B)
    rows = np.ascontiguousarray(B.reshape(-1, B.shape[-1]))
    return _eddy_rows(_writable(rows), _writable(np.ascontiguousarray(lag.reshape(-1)))).reshape(B.shape)


def _writable(a):
    """``a``, or its copy where it is read-only (a broadcast view): the kernel sees one array type, so numba
    compiles and caches one signature instead of one per flag."""
    return a if a.flags.writeable else a.copy()


@numba.njit(cache=True, error_model="numpy")
def _eddy_rows(B, lag):
    """eddy_filter of each row of B (n, m) with its lag (n,), compiled (the recursion runs along a row; no FMA,
    so the bytes of the numpy form)."""
    out = np.empty_like(B)
    for i in range(B.shape[0]):
        out[i, 0] = B[i, 0]
        for j in range(1, B.shape[1]):
            out[i, j] = B[i, j] + lag[i] * (out[i, j - 1] - B[i, j])
    return out


def _col(v):
    return np.asarray(v, dtype=float)[..., None]


def _air_gap_model(P, M0, Nd):
    P = P.copy()
    P[:, 2] = air_gap_alpha(P[:, 2], np.asarray(Nd, dtype=float))
    return P, M0


# ------------------------------------------------------------------ plausible sizes (issue 12 (c))
def _span(sensor: dict):
    """The supply's span (V): supply_V, less a bipolar supply's lower rail (sidecar supply_min_V, 0 by default);
    None when unknown."""
    vcc = sensor.get("supply_V")
    return None if not vcc else vcc - sensor.get("supply_min_V", 0.0)


def _sensor_T(ctx, frac_supply):
    """A fraction of the supply (its span, :func:`_span`) as an input-referred field (T, > 0 for either sign of
    the sensitivity); None when the sensor is unknown."""
    s, vcc = ctx.sensor.get("sensitivity_V_per_T"), _span(ctx.sensor)
    return None if not s or not vcc else frac_supply * vcc / abs(s)


def _plaus_offset(value, ctx, rg):
    lim = _sensor_T(ctx, rg["offset_frac_supply"])
    if lim is None:
        return _offset_in_midpoint(value, ctx, rg["offset_midpoint_frac"])
    return abs(value) <= lim, f"|offset| {abs(value) * 1e3:.3g} mT vs quiescent tolerance {lim * 1e3:.3g} mT"


def _offset_in_midpoint(value, ctx, frac):
    """Without a sensor to bound it (a third-party B(H) loop): a constant offset moves the loop's midpoint
    (max + min) / 2 by itself, so an offset is plausible only where the data's midpoint shows at least ``frac``
    (config ``diagnose.plausible.offset_midpoint_frac``, a half) of it. A loop its lab centred (midpoint 0) cannot
    carry one, whatever a fit gains from it (on the paper's 0 -> max -> 0 sweep the midpoint is half the peak, and
    this never binds)."""
    b = ctx.B_mT[ctx.mask] * 1e-3
    mid = 0.5 * (float(np.max(b)) + float(np.min(b)))
    ok = mid * value > 0 and abs(mid) >= float(frac) * abs(value)
    return ok, f"offset {value * 1e3:.3g} mT vs the data's midpoint (max + min)/2 = {mid * 1e3:.3g} mT"


def drift_rate_max_V_per_s(rg: dict, supply_V: float) -> float:
    """The fastest creep of a Hall zero, in V/s at the sensor output: the quiescent output's temperature
    coefficient (``drift_tc_frac_supply_per_K``, a fraction of the supply per kelvin) x the supply x the fastest
    heating the sensor sees (``drift_heating_K_per_s``). ``rg``: config ``diagnose.plausible``."""
    return float(rg["drift_tc_frac_supply_per_K"]) * float(supply_V) * float(rg["drift_heating_K_per_s"])


def _plaus_drift(value, ctx, rg):
    """A thermal drift is plausible when its RATE is one a Hall zero can show (:func:`drift_rate_max_V_per_s`)
    and its total over the sweep stays within the quiescent tolerance over temperature (``drift_frac_supply``).
    Held-out check: a Rayleigh core was named a drift of 51.9 mT over 7.33 s, 35 mV/s at the output."""
    lim = _sensor_T(ctx, rg["drift_frac_supply"])
    if lim is None:
        return True, "sensor unknown: no bound"
    s = abs(float(ctx.sensor["sensitivity_V_per_T"]))  # a sensor mounted reversed (S < 0) drifts in volts alike
    r_max = drift_rate_max_V_per_s(rg, _span(ctx.sensor))
    rate, tot = abs(value), abs(value) * ctx.duration_s
    return rate * s <= r_max and tot <= lim, (
        f"drift rate {rate * 1e3:.3g} mT/s ({rate * s * 1e3:.3g} mV/s at the output) vs at most "
        f"{r_max / s * 1e3:.3g} mT/s ({r_max * 1e3:.3g} mV/s: quiescent tempco {rg['drift_tc_frac_supply_per_K']:g} "
        f"Vcc/K x {rg['drift_heating_K_per_s']:g} K/s); {tot * 1e3:.3g} mT over the sweep ({ctx.duration_s:.3g} s) "
        f"vs the quiescent tolerance over temperature {lim * 1e3:.3g} mT")


def _plaus_lag(value, ctx, rg):
    if not ctx.dwell_s or value <= 0:
        return True, "dwell unknown or no lag"
    tau = -ctx.dwell_s / math.log(min(value, 1 - 1e-12))
    ok = tau <= rg["eddy_tau_max_s"]
    return ok, f"tau = {tau:.3g} s per dwell {ctx.dwell_s:.3g} s vs at most {rg['eddy_tau_max_s']:g} s"


def _plaus_remanent(value, ctx, rg):
    if ctx.ja_coords is None:
        return True, "no J-A fit: no bound"
    ms = math.exp(float(ctx.ja_coords[0]))
    ok = abs(value) <= rg["remanent_frac_Ms"] * ms
    return ok, f"|M0| {abs(value):.3g} A/m vs {rg['remanent_frac_Ms']:g} Ms = {rg['remanent_frac_Ms'] * ms:.3g} A/m"


def _plaus_gap(value, ctx, rg):
    ok = 0.0 <= value <= rg["Nd_max"]
    return ok, f"Nd {value:.3g} vs at most {rg['Nd_max']:g}"


def _plaus_sat(value, ctx, rg):
    """A clip is an output limit above the quiescent output; where the sweep's sidecar declares the sensor's
    limits (output_min_V / output_max_V), the clip must sit at them, within saturation_declared_tol_frac_supply
    of the supply: a sensor whose output stops well inside its declared range is not saturating, and a gap
    that such a clip fits is something else (held-out check: a cubic Hall nonlinearity was named a clip at
    2.27 V with 3.1 V declared and no sample near it)."""
    s, q, vcc = ctx.sensor.get("sensitivity_V_per_T"), ctx.sensor.get("quiescent_V"), _span(ctx.sensor)
    if not s or q is None or not vcc:
        return True, "sensor unknown: no bound"
    s = abs(s)  # symmetric about the quiescent output: the same range for a sensor mounted reversed (S < 0)
    v_hi, v_lo = q + s * abs(value), q - s * abs(value)  # the linear range |B| <= B_sat about the quiescent output
    rail = ctx.sensor.get("supply_min_V", 0.0)  # the output's floor: 0 V, or a bipolar supply's lower rail
    ok = v_hi - rail >= rg["saturation_min_frac_supply"] * vcc
    why = (f"clips at {v_hi:.3g} V vs an output limit of at least "
           f"{rail + rg['saturation_min_frac_supply'] * vcc:.3g} V")
    tol = rg["saturation_declared_tol_frac_supply"] * vcc
    lo_d, hi_d = ctx.sensor.get("output_min_V"), ctx.sensor.get("output_max_V")
    if lo_d is None and hi_d is None:
        return ok, why
    # the clip is symmetric about the quiescent output: plausible when one of its sides reaches a declared limit
    at_limit = (hi_d is not None and v_hi >= hi_d - tol) or (lo_d is not None and v_lo <= lo_d + tol)
    return ok and at_limit, (f"clips at {v_lo:.3g} / {v_hi:.3g} V vs the declared output limits "
                             f"{lo_d if lo_d is not None else '-'} / {hi_d if hi_d is not None else '-'} V "
                             f"(within {tol:.2g} V)")


# ------------------------------------------------------------------ the registry
def _drift_start(ctx, r):
    v = ctx.mask
    A = np.column_stack([np.ones(int(v.sum())), ctx.t_rel[v]])
    return [0.0, float(np.linalg.lstsq(A, r[v], rcond=None)[0][1])]


def _first(ctx):
    return int(np.flatnonzero(ctx.mask)[0])


REGISTRY: dict[str, Effect] = {}


# ------------------------------------------------------------------ blind benchmark draws and reference starts
def _lu(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _sign(rng):
    return 1.0 if rng.uniform() < 0.5 else -1.0


def _draw_offset(rng, m, c):
    s, k = _sign(rng), _lu(rng, *m["hall_offset_sigmas"])
    return {"offset_T": s * k * c["sigma_T"]}, {"sigmas": k}


def _draw_drift(rng, m, c):
    """A Hall zero creeping at a physical rate: the output-referred rate log-uniform in thermal_drift_V_per_s
    (within the diagnosis's bound, :func:`drift_rate_max_V_per_s`), over the case's sensitivity. A slow drift
    shows only on a long sweep: the detectable cases are mostly the long dwells."""
    s, v = _sign(rng), _lu(rng, *m["thermal_drift_V_per_s"])
    rate = v / c["sensitivity_V_per_T"]
    return {"drift_T_per_s": s * rate}, {"sigmas": rate * c["duration_s"] / c["sigma_T"], "V_per_s": v}


def _draw_remanent(rng, m, c):
    s, k = _sign(rng), _lu(rng, *m["remanent_start_sigmas"])
    return {"M0_A_per_m": s * k * c["sigma_T"] / MU0}, {"sigmas": k}


def _draw_saturation(rng, m, c):
    _sign(rng)  # one draw per case whatever the effect (the stream stays aligned across classes)
    k = _lu(rng, *m["sensor_saturation_sigmas"])
    depth = min(k * c["sigma_T"], float(m["sensor_saturation_max_frac"]) * c["peak_T"])
    return {"B_sat_T": c["peak_T"] - depth}, {"sigmas": depth / c["sigma_T"]}


def _draw_gap(rng, m, c):
    _sign(rng)
    x = _lu(rng, *m["air_gap_above_alpha"])
    return {"Nd": c["truth"]["alpha"] + x}, {"above_alpha": x}


def _draw_lag(rng, m, c):
    _sign(rng)
    return {"lag": _lu(rng, *m["eddy_lag"])}, {}


def _gap_reported(ep, truth):
    """The diagnosis reports the smallest Nd that explains alpha' (with alpha = 0)."""
    ae = float(air_gap_alpha(truth["alpha"], ep["Nd"]))
    return max(0.0, -ae / (1.0 - ae))


def _ref_drift(c):
    span = max(float(c["t_s"][-1]), 1e-9)
    return [float(np.polyfit(c["t_s"], c["resid_T"], 1)[0]), 0.0], (-2 * c["peak_T"] / span, 2 * c["peak_T"] / span)


def _ref_saturation(c):
    top = float(np.max(np.abs(c["B_T"])))
    return [top, 0.97 * top], (0.2 * c["peak_T"], 2.0 * c["peak_T"])


# the air gap frees no coordinate of its own: it lets J-A's alpha (column 2) go below 0, alpha' = (alpha - Nd)/(1 - Nd),
# and reports the smallest Nd that explains alpha' (with alpha = 0)
_GAP_COORD = SharedCoord(
    2, "alpha_eff_min", size=lambda x: max(0.0, -x / (1.0 - x)),
    slope=lambda x: -1.0 / (1.0 - x) ** 2 if x < 0 else 0.0, ja_value=lambda x: max(0.0, float(x)),
    note=lambda x: (f"an air gap is exactly a shift of alpha; this is the smallest Nd that explains the fitted "
                    f"alpha' = {x:.4g} (with alpha = 0)"))


def register(e: Effect) -> Effect:
    """Add (or replace) an effect: the rig, the diagnosis and the scorer then all know it."""
    _check(e)
    REGISTRY[e.name] = e
    _refresh()
    return e


def _check(e: Effect) -> None:
    if e.stage not in STAGES:
        raise ValueError(f"effect {e.name!r}: stage must be one of {STAGES}")
    if (e.stage == "model") == (e.model is None) or (e.stage != "model") == (e.signal is None):
        raise ValueError(f"effect {e.name!r}: stage {e.stage!r} needs its forward action")
    if (e.coord is None) == (e.shared is None):
        raise ValueError(f"effect {e.name!r}: needs a coordinate of its own (coord) or a shared J-A one (shared)")
    if set(e.needs) - set(NEEDS):
        raise ValueError(f"effect {e.name!r}: needs must be among {tuple(NEEDS)}, got {tuple(e.needs)}")


def unregister(name: str) -> None:
    REGISTRY.pop(name, None)
    _refresh()


for _e in (
    Effect("remanent_start", "M0_A_per_m", "model", "sweep starts from a remanent state",
           model=lambda P, M0, v: (P, np.asarray(v, dtype=float) + M0), coord="B0_mT",
           unit=lambda ctx: 1e-3 / MU0, bounds=lambda ctx: (-10 * ctx.span_mT, 10 * ctx.span_mT),
           starts=lambda ctx, r: [0.0, float(ctx.B_mT[_first(ctx)]), float(r[_first(ctx)])],
           grid=lambda ctx: [x * ctx.span_mT for x in (-0.3, -0.1, 0.1, 0.3)], plausible=_plaus_remanent,
           block_identifiable=False, draw=_draw_remanent, draw_keys=("remanent_start_sigmas",),
           ref_starts=lambda c: ([c["resid_T"][0] / MU0, -c["resid_T"][0] / MU0],
                                 (-5 * c["peak_T"] / MU0, 5 * c["peak_T"] / MU0)),
           needs={"free_start": "the sweep's history sets its start state (a third-party B(H) loop simulated in "
                                "cyclic steady state, or a preconditioning the sidecar declares), so it is not a free "
                                "effect"}),
    # the air gap frees no coordinate of its own: the diagnosis lets alpha' = (alpha - Nd)/(1 - Nd) go below 0
    Effect("air_gap", "Nd", "model", "demagnetising field of the fluid gap", model=_air_gap_model,
           starts=lambda ctx, r: [min(float(ctx.ja_coords[2]), 0.0) + x for x in (-2e-3, -1e-2, -3e-2)],
           grid=lambda ctx: [-3e-3, -1e-2, -3e-2], plausible=_plaus_gap, draw=_draw_gap,
           draw_keys=("air_gap_above_alpha",), shared=_GAP_COORD,
           # Nd = 0 is no gap at all (alpha' = alpha): J-A + a gap starts where plain J-A ended
           ref_starts=lambda c: ([0.0, c["ja"][2] + 0.02], (0.0, 0.6)), reported=_gap_reported),
    Effect("eddy_lag", "lag", "flux", "first-order flux settling per current step",
           signal=lambda B, v, t: eddy_filter(B, v),
           coord="lag", bounds=lambda ctx: (0.0, 0.95), starts=lambda ctx, r: [0.05, 0.3],
           grid=lambda ctx: [0.1, 0.3, 0.6], plausible=_plaus_lag, step=1e-7, draw=_draw_lag, draw_keys=("eddy_lag",),
           ref_starts=lambda c: ([0.05, 0.3], (0.0, 0.95)),
           # the lag is per current step: dwell' = r x dwell leaves lag' = exp(-r dwell / tau) = lag^r
           at_dwell=lambda lag, r: float(lag) ** float(r),
           needs={"time": "no sample times over a time span in the file (time_s absent, or the same in every row): an "
                          "eddy lag per current step needs them"}),
    Effect("hall_offset", "offset_T", "zero", "constant Hall zero error",
           signal=lambda B, v, t: B + _col(v), coord="offset_mT", unit=lambda ctx: 1e-3,
           bounds=lambda ctx: (-10 * ctx.span_mT, 10 * ctx.span_mT),
           starts=lambda ctx, r: [0.0, float(r[_first(ctx)]), float(np.mean(r[ctx.mask]))],
           grid=lambda ctx: [x * ctx.span_mT for x in (-0.2, -0.05, 0.05, 0.2)], plausible=_plaus_offset,
           draw=_draw_offset, draw_keys=("hall_offset_sigmas",),
           ref_starts=lambda c: ([c["resid_T"][0], float(np.mean(c["resid_T"]))], (-2 * c["peak_T"], 2 * c["peak_T"])),
           confused_with={"remanent_start": "a constant Hall offset and a remanent start both move the 0 A start, "
                                            "and the shape of the low-field ascending branch does not decide "
                                            "between them here"}),
    Effect("thermal_drift", "drift_T_per_s", "zero", "Hall offset drifting with time",
           signal=lambda B, v, t: B + _col(v) * (np.asarray(t, dtype=float) - float(t[0])),
           coord="drift_mT", unit=lambda ctx: 1e-3 / ctx.duration_s if ctx.duration_s > 0 else 0.0,
           bounds=lambda ctx: (-10 * ctx.span_mT, 10 * ctx.span_mT), starts=_drift_start,
           grid=lambda ctx: [x * ctx.span_mT for x in (-0.3, -0.1, 0.1, 0.3)], plausible=_plaus_drift,
           branch_identifiable=False, time_bound=True, draw=_draw_drift, ref_starts=_ref_drift,
           draw_keys=("thermal_drift_V_per_s",),
           needs={"time": "no sample times over a time span in the file (time_s absent, or the same in every row): a "
                          "drift per second needs them"}),
    Effect("sensor_saturation", "B_sat_T", "output", "sensor output at its limit",
           # the A1304's linear range is symmetric about its quiescent output: one limit |B| <= B_sat, which on
           # the paper's 0 -> max -> 0 sweep (B >= 0) is the upper limit alone
           signal=lambda B, v, t: np.clip(B, -_col(v), _col(v)), coord="Bsat_mT", unit=lambda ctx: 1e-3,
           bounds=lambda ctx: (0.0, float(np.max(np.abs(ctx.B_mT[ctx.mask]))) + ctx.span_mT),
           null=1.0e12, starts=lambda ctx, r: [float(x) for x in np.sort(np.abs(ctx.B_mT[ctx.mask]))[::-1][[0, 2]]],
           grid=lambda ctx: [float(np.max(np.abs(ctx.B_mT[ctx.mask])))], plausible=_plaus_sat,
           draw=_draw_saturation, ref_starts=_ref_saturation,
           draw_keys=("sensor_saturation_sigmas", "sensor_saturation_max_frac"), output_limit=True),
):
    _check(_e)
    REGISTRY[_e.name] = _e

# reference mode only (issue 24, mrhyst.diagnose.reference): the core is hotter or colder than at calibration; the
# material changed (a refit from the reference is needed). Not effects of the forward model: changes of the J-A
# parameters the reference holds, so no rig or blind class draws them as an effect.
REFERENCE_ONLY = ("core_temperature", "material_changed")
VOCABULARY: tuple = ()
EFFECTS: dict = {}
MODELLED: tuple = ()


@dataclass(frozen=True)
class _NoneSpec:
    name: str = "none"
    params: tuple = ()
    doc: str = "plain J-A"


def _refresh() -> None:
    """Derived views of the registry (module globals kept for callers that read them)."""
    global VOCABULARY, EFFECTS, MODELLED
    names = tuple(REGISTRY)
    VOCABULARY = ("none", *names, "model_form", "unexplained", *REFERENCE_ONLY)
    EFFECTS = {"none": _NoneSpec(), **REGISTRY}
    MODELLED = ("none", *names)


_refresh()


def ordered(names) -> list[str]:
    """Effect names in physical order (stage, then registry order)."""
    idx = {n: i for i, n in enumerate(REGISTRY)}
    return sorted(names, key=lambda n: (STAGES.index(REGISTRY[n].stage), idx[n]))


def unmet(provided) -> dict:
    """{effect: why it is skipped} for the registered effects that need (``Effect.needs``) something a sweep does
    not provide; ``provided``: the NEEDS the sweep meets."""
    out = {}
    for name, e in REGISTRY.items():
        why = [text for need, text in e.needs.items() if need not in provided]
        if why:
            out[name] = "; ".join(why)
    return out


def confusions(names) -> list[str]:
    """Why effects among ``names`` are confounded on one sweep (``Effect.confused_with``), in registry order; a
    name no longer registered (a saved evidence block re-decided) is passed over."""
    names = set(names)
    out = []
    for name in REGISTRY:
        if name in names:
            out += [t for other, t in REGISTRY[name].confused_with.items() if other in names and t not in out]
    return out


def normalise(effect="none", eparams: dict | None = None) -> dict:
    """{name: {param: value}} from one name (+ eparams), a list of (name, eparams) pairs or a mapping."""
    if isinstance(effect, str):
        items = [] if effect == "none" and not eparams else [(effect, eparams)]
    else:
        items = list(effect.items()) if isinstance(effect, dict) else list(effect or ())
    out = {}
    for item in items:
        try:
            name, ep = item
        except (TypeError, ValueError):
            raise ValueError(f"each effect must be a (name, params) pair, got {item!r}") from None
        if name == "none":
            continue
        if name not in REGISTRY:
            raise ValueError(f"unknown effect {name!r}; expected one of {MODELLED}")
        if name in out:
            raise ValueError(f"effect {name!r} given twice")
        ep = dict(ep or {})
        need = REGISTRY[name].params
        if sorted(ep) != sorted(need):
            raise ValueError(f"effect {name!r} takes parameter(s) {list(need)}, got {sorted(ep)}")
        out[name] = ep
    return out


def forward(ja_params, current_A, time_s, n_over_le: float, effect="none", eparams: dict | None = None, *,
            form: str, substeps: int, dman: str = "total", M0=0.0):
    """B (T) observed along a sweep: J-A plus any set of effects, applied in physical order.

    ``effect``: one name (with ``eparams``), a list of ``(name, eparams)`` pairs or a mapping
    ``{name: eparams}``. ``ja_params``: (5,) or (n, 5); effect parameters are scalars or (n,) arrays.
    Model-stage effects change the J-A integration (parameters, initial state), then the signal stages
    act on B in the order of :data:`STAGES`. Returns ``(B, ok)`` like :func:`mrhyst.model.ja.simulate`.
    """
    eff = normalise(effect, eparams)
    P = np.array(ja_params, dtype=float, copy=True)
    single = P.ndim == 1

    def run(P, m0):
        return ja.simulate(P, current_A, n_over_le, form=form, substeps=substeps, dman=dman, M0=m0)

    B, ok = apply(run, np.atleast_2d(P), M0, time_s, eff, ordered(eff))
    if single:
        return B[0], bool(ok[0])
    return B, ok


def apply(run, P, M0, time_s, eff: dict, order):
    """The effects ``eff`` (normalised, :func:`normalise`) in ``order`` (:func:`ordered`) around the J-A
    integration ``run(P, M0) -> (B, ok)`` of the sets P (n, 5): the model stage changes the sets and the start,
    the signal stages act on B. :func:`forward`'s body; a fitting loop that checked its effects once calls it
    with a prepared integration (:func:`mrhyst.model.ja.prepared`)."""
    m0 = np.asarray(M0, dtype=float)
    for name in order:
        e = REGISTRY[name]
        if e.stage == "model":
            P, m0 = e.model(P, m0, eff[name][e.param])
    B, ok = run(P, m0)
    for name in order:
        e = REGISTRY[name]
        if e.stage != "model":
            B = e.signal(B, eff[name][e.param], time_s)
    return B, ok
