"""The sweep: one Hall channel of a raw sweep, its protocol, regions along the loop, the noise floor."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..io import InputError, raw_to_loop, read_raw
from .settings import resolve_config

REGIONS = ("asc_low", "asc_mid", "asc_high", "turning", "desc_high", "desc_mid", "desc_low", "remanence")


@dataclass
class Sweep:
    """One Hall channel of a raw sweep, checked for the 0 -> max -> 0 protocol."""

    source: str
    sensor: str
    current: np.ndarray
    time: np.ndarray
    B: np.ndarray
    valid: np.ndarray
    n_over_le: float
    region: np.ndarray = field(default=None)
    peak_first: int = 0
    peak_last: int = 0
    dwell_s: float | None = None  # time per current step (sidecar), for the plausible size of an eddy lag
    sensor_info: dict = field(default_factory=dict)  # sensitivity_V_per_T, quiescent_V, supply_V when known

    @property
    def n(self) -> int:
        return int(self.B.size)


def check_protocol(current, source: str = "sweep") -> tuple[int, int]:
    """(first, last) index of the turning point; InputError unless one ascent then one descent."""
    cur = np.asarray(current, dtype=float)
    d = np.sign(np.diff(cur))
    nz = d[d != 0]
    if nz.size == 0:
        raise InputError(f"{source}: the current never changes; diagnose needs the 0 -> max -> 0 protocol")
    if nz[0] < 0:
        raise InputError(f"{source}: the current first falls; diagnose supports only the paper's protocol "
                         f"(one ascent then one descent, 0 -> max -> 0)")
    reversals = int(np.sum(nz[1:] != nz[:-1]))
    if reversals == 0:
        raise InputError(f"{source}: the current only rises (no descending branch); diagnose supports only the "
                         f"paper's protocol (one ascent then one descent, 0 -> max -> 0)")
    if reversals > 1:
        raise InputError(f"{source}: the current path reverses {reversals} times; diagnose supports only the "
                         f"paper's protocol (one ascent then one descent, 0 -> max -> 0)")
    imax = cur.max()
    at = np.flatnonzero(cur == imax)
    if not imax > 0:
        raise InputError(f"{source}: the largest current is {imax:g} A; expected a positive turning point")
    return int(at[0]), int(at[-1])


def region_labels(current, peak_first: int, peak_last: int, cfg: dict) -> np.ndarray:
    """Region of each sample (REGIONS) from its branch and |I| / I_max."""
    cur = np.asarray(current, dtype=float)
    rc = cfg["regions"]
    imax = float(cur[peak_first])
    frac = cur / imax
    lab = np.empty(cur.size, dtype=object)
    for j in range(cur.size):
        if peak_first <= j <= peak_last:
            lab[j] = "turning"
            continue
        side = "asc" if j < peak_first else "desc"
        f = frac[j]
        lab[j] = f"{side}_low" if f < rc["low_frac"] else (f"{side}_mid" if f < rc["high_frac"] else f"{side}_high")
    if cur.size - 1 > peak_last and abs(cur[-1]) <= rc["zero_tol_frac"] * imax:
        lab[-1] = "remanence"
    return lab


def sweep_from_arrays(current, time_s, B, n_over_le: float, valid=None, cfg: dict | None = None,
                      source: str = "arrays", sensor: str = "B", dwell_s: float | None = None,
                      sensor_info: dict | None = None) -> Sweep:
    """A Sweep from arrays (tests, the blind key's detectability check); protocol checked as for a file.
    ``dwell_s`` and ``sensor_info`` (sensitivity_V_per_T, quiescent_V, supply_V) bound plausible sizes."""
    cfg = resolve_config(cfg) if cfg is None or "box" not in cfg else cfg
    cur = np.asarray(current, dtype=float)
    pf, pl = check_protocol(cur, source)
    valid = np.ones(cur.size, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    sw = Sweep(source, sensor, cur, np.asarray(time_s, dtype=float), np.asarray(B, dtype=float), valid,
               float(n_over_le), peak_first=pf, peak_last=pl, dwell_s=dwell_s, sensor_info=dict(sensor_info or {}))
    sw.region = region_labels(cur, pf, pl, cfg)
    return sw


def load_sweep(raw_path, sensor: str, cfg: dict | None = None) -> Sweep:
    """Read a raw sweep, convert one channel, check the protocol and the sample count."""
    cfg = resolve_config(cfg) if cfg is None or "box" not in cfg else cfg
    raw = read_raw(raw_path)
    loop = raw_to_loop(raw, sensor)
    src = str(raw_path)
    pf, pl = check_protocol(raw.current_A, src)
    valid = np.ones(len(loop), dtype=bool)
    if "saturated" in loop:
        valid = ~loop["saturated"].to_numpy().astype(bool)
    nv = int(valid.sum())
    n_up, n_down = int(valid[: pf + 1].sum()), int(valid[pl:].sum())
    need, per = int(cfg["min_samples"]), int(cfg["min_per_branch"])
    if nv < need or n_up < per or n_down < per:
        raise InputError(f"{src}: {nv} usable samples ({n_up} ascending, {n_down} descending, turning point "
                         f"included); diagnose needs at least {need} with {per} per branch to split the loop "
                         f"into regions")
    sw = Sweep(src, sensor, raw.current_A.astype(float), raw.time_s.astype(float),
               loop["B_T"].to_numpy(dtype=float), valid, float(raw.coil_turns_per_m), peak_first=pf, peak_last=pl,
               dwell_s=_dwell(raw), sensor_info=_sensor_info(raw, sensor))
    sw.region = region_labels(sw.current, pf, pl, cfg)
    return sw


def _trunc_factor(c: float) -> float:
    """E[x^2 | |x| < c] for a standard normal x."""
    phi = math.exp(-0.5 * c * c) / math.sqrt(2 * math.pi)
    return 1.0 - 2.0 * c * phi / math.erf(c / math.sqrt(2))


def noise_floor(resid, sweep: Sweep, clip: float = 3.5) -> float:
    """Sensor noise sigma (T) from the residual's second differences along each branch.

    d2[j] = r[j-1] - 2 r[j] + r[j+1] of white noise has sd sqrt(6) sigma; a smooth model misfit adds
    little to it. A MAD estimate first, then the RMS of the d2 within ``clip`` MAD-sigmas (kinks,
    e.g. where a sensor starts to clip, drop out), corrected for the truncation. Triples that
    straddle the turning point or contain a flagged sample are not used.
    """
    r = np.asarray(resid, dtype=float)
    v = sweep.valid
    d2 = []
    for lo, hi in ((0, sweep.peak_first), (sweep.peak_last, sweep.n - 1)):
        for j in range(lo + 1, hi):
            if v[j - 1] and v[j] and v[j + 1]:
                d2.append(r[j - 1] - 2 * r[j] + r[j + 1])
    d2 = np.asarray(d2)
    if d2.size < 4:
        rv = r[v]
        return float(np.sqrt(np.mean(rv**2)))
    s0 = 1.482602218505602 * float(np.median(np.abs(d2)))
    if s0 == 0.0:
        return 0.0
    keep = np.abs(d2) <= clip * s0
    s = math.sqrt(float(np.mean(d2[keep] ** 2)) / _trunc_factor(clip))
    return s / math.sqrt(6.0)


def region_breakdown(resid, sweep: Sweep) -> dict:
    r = np.asarray(resid, dtype=float)
    v = sweep.valid
    tot = float(np.sum(r[v] ** 2))
    out = {}
    for name in REGIONS:
        m = (sweep.region == name) & v
        k = int(m.sum())
        ss = float(np.sum(r[m] ** 2))
        out[name] = {
            "n": k,
            "share": ss / tot if tot > 0 else 0.0,
            "rms_T": math.sqrt(ss / k) if k else 0.0,
            "mean_T": float(np.mean(r[m])) if k else 0.0,
        }
    return out


def folds(sweep: Sweep, K: int, kind: str) -> np.ndarray:
    """Fold of each sample: ``interleaved`` (sample j in fold j mod K) or ``blocks`` (K contiguous blocks
    along the path)."""
    j = np.arange(sweep.n)
    return j % int(K) if kind == "interleaved" else (j * int(K)) // sweep.n


def _dwell(raw) -> float | None:
    d = getattr(raw, "dwell_s", None)
    if d is None:
        t = np.asarray(raw.time_s, dtype=float)
        d = float(np.median(np.diff(t))) if t.size > 1 else None
    return float(d) if d else None


def _sensor_info(raw, sensor: str) -> dict:
    s = raw.sensors.get(sensor)
    out = {}
    if s is not None:
        out = {"sensitivity_V_per_T": float(s.sensitivity_V_per_T), "quiescent_V": float(s.quiescent_V)}
    if getattr(raw, "supply_V", None):
        out["supply_V"] = float(raw.supply_V)
    return out
