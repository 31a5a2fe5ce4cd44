"""The sweep: one Hall channel of a raw sweep (any piecewise-monotone current path) or a third-party B(H)
loop, its segments and regions along the loop (:mod:`mrhyst.data.loops`), the noise floor."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mrhyst.data import loops
from mrhyst.data.io import InputError, raw_to_loop, read_loop, read_raw
from mrhyst.diagnose.settings import resolve_config

MU0 = 4e-7 * math.pi

REGIONS = loops.REGIONS


@dataclass
class Sweep:
    """One Hall channel of a raw sweep along any piecewise-monotone current path (or a B(H) loop, with H in
    place of the current and N/Le = 1). ``valid`` marks the samples fitted: a saturated sample, or the
    conditioning prefix of a third-party loop (the path run before it, for a cyclic start), is not."""

    source: str
    sensor: str
    current: np.ndarray
    time: np.ndarray
    B: np.ndarray
    valid: np.ndarray
    n_over_le: float
    region: np.ndarray = field(default=None)
    peak_first: int = 0  # the first turning point (its first and last sample: the extreme and its repeats)
    peak_last: int = 0
    dwell_s: float | None = None  # time per current step (sidecar), for the plausible size of an eddy lag
    sensor_info: dict = field(default_factory=dict)  # sensitivity_V_per_T, quiescent_V, supply_V when known
    kind: str = "hall"  # "hall" (a raw sweep) or "bh" (a third-party B(H) loop: no Hall chain, maybe no times)
    has_time: bool = True  # False: no sample times (eddy lag and drift cannot be judged)
    start: int = 0  # first measured sample (after a conditioning prefix)
    M0: float = 0.0  # magnetisation at the first sample (A/m): 0 = demagnetised; a B(H) loop starts from its own

    @property
    def n(self) -> int:
        return int(self.B.size)

    @property
    def segments(self) -> list:
        return loops.segments(self.current)

    @property
    def cycle(self) -> np.ndarray:
        return loops.cycle_index(self.current)


def check_protocol(current, source: str = "sweep") -> tuple[int, int]:
    """(first, last) index of the first turning point of any piecewise-monotone path; InputError when the
    current never changes or never turns (a single ramp has no second branch to judge a fit by)."""
    cur = np.asarray(current, dtype=float)
    try:
        segs = loops.segments(cur)
    except ValueError:
        raise InputError(f"{source}: the current never changes; diagnose needs a current path with at least one "
                         f"reversal (e.g. 0 -> max -> 0)") from None
    if len(segs) < 2:
        raise InputError(f"{source}: the current only {'rises' if segs[0].direction > 0 else 'falls'} (no "
                         f"reversal); diagnose needs at least one reversal (e.g. 0 -> max -> 0)")
    turn = np.flatnonzero(loops.turning_mask(cur))
    last = segs[0].stop
    first = int(turn[turn <= last][0])
    return first, int(last)


def region_labels(current, peak_first: int = 0, peak_last: int = 0, cfg: dict | None = None, B=None) -> np.ndarray:
    """Region of each sample (REGIONS) of any path (:func:`mrhyst.data.loops.region_labels`); the turning-point
    arguments are kept for callers of the paper-protocol version and not needed."""
    return loops.region_labels(current, B, resolve_config(cfg)["regions"])


def check_branches(current, valid, cfg: dict, source: str, row_offset: int = 2, start: int = 0) -> None:
    """Every monotone branch needs ``min_per_branch`` usable samples (turning points included) and the sweep
    ``min_samples``; else one InputError naming the row where the short branch starts."""
    v = np.asarray(valid, dtype=bool)
    need, per = int(cfg["min_samples"]), int(cfg["min_per_branch"])
    if int(v.sum()) < need:
        raise InputError(f"{source}: {int(v.sum())} usable samples; diagnose needs at least {need}")
    for s in loops.segments(current):
        lo = max(s.start, start)
        if s.stop < start:
            continue
        nv = int(v[lo: s.stop + 1].sum())
        if nv < per:
            kind = "ascending" if s.direction > 0 else "descending"
            raise InputError(f"{source}: row {lo - start + row_offset}: the {kind} branch from here has {nv} usable "
                             f"samples; diagnose needs at least {per} per branch to split the loop into regions")


def sweep_from_arrays(current, time_s, B, n_over_le: float, valid=None, cfg: dict | None = None,
                      source: str = "arrays", sensor: str = "B", dwell_s: float | None = None,
                      sensor_info: dict | None = None) -> Sweep:
    """A Sweep from arrays (tests, the blind key's detectability check); protocol checked as for a file.
    ``dwell_s`` and ``sensor_info`` (sensitivity_V_per_T, quiescent_V, supply_V) bound plausible sizes."""
    cfg = resolve_config(cfg)
    cur = np.asarray(current, dtype=float)
    pf, pl = check_protocol(cur, source)
    valid = np.ones(cur.size, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    sw = Sweep(source, sensor, cur, np.asarray(time_s, dtype=float), np.asarray(B, dtype=float), valid,
               float(n_over_le), peak_first=pf, peak_last=pl, dwell_s=dwell_s, sensor_info=dict(sensor_info or {}))
    sw.region = region_labels(cur, cfg=cfg, B=sw.B)
    return sw


def load_sweep(raw_path, sensor: str, cfg: dict | None = None) -> Sweep:
    """Read a raw sweep, convert one channel, check the protocol and the sample count."""
    cfg = resolve_config(cfg)
    raw = read_raw(raw_path)
    loop = raw_to_loop(raw, sensor)
    src = str(raw_path)
    pf, pl = check_protocol(raw.current_A, src)
    valid = np.ones(len(loop), dtype=bool)
    if "saturated" in loop:
        valid = ~loop["saturated"].to_numpy().astype(bool)
    check_branches(raw.current_A, valid, cfg, src)
    B = loop["B_T"].to_numpy(dtype=float)
    sw = Sweep(src, sensor, raw.current_A.astype(float), raw.time_s.astype(float), B, valid,
               float(raw.coil_turns_per_m), peak_first=pf, peak_last=pl, dwell_s=_dwell(raw),
               sensor_info=_sensor_info(raw, sensor))
    sw.region = region_labels(sw.current, cfg=cfg, B=B)
    return sw


def decimate(H, max_samples: int) -> np.ndarray:
    """Indices of at most about ``max_samples`` samples along a dense loop: every k-th sample plus every
    turning point and the last sample (the diagnosis's fits are sized for sweeps of tens to hundreds of
    samples; a densely digitised loop holds no more information about a smooth gap than its decimation)."""
    n = int(np.size(H))
    if n <= max_samples:
        return np.arange(n)
    k = int(np.ceil(n / max_samples))
    keep = set(range(0, n, k)) | set(np.flatnonzero(loops.turning_mask(H)).tolist()) | {n - 1}
    return np.array(sorted(keep))


def sweep_from_bh(path, loop_index: int | None = None, cfg: dict | None = None) -> Sweep:
    """A third-party B(H) loop (``H_A_per_m,B_T[,loop_index]``) as a Sweep: H in place of the current
    (N/Le = 1), no Hall chain, no sample times (the sample index stands in; eddy lag and drift are not
    judged), decimated to ``bh.max_samples``. A measured loop is rarely taken from the demagnetised state, so
    the model runs the loop's own path ``bh.conditioning_passes`` times first (a cyclic start, as
    ``mrhyst fit --start cyclic``: from the first sample's state, M0 = B0/mu0 - H0, so that J-A does not start
    far from the loop) and is compared on the last pass only (the conditioning is not fitted)."""
    cfg = resolve_config(cfg)
    loop = read_loop(path, loop_index)
    where = f"{path}" + ("" if loop_index is None else f" (loop_index {loop_index})")
    H, B, v = (np.asarray(x, dtype=float) for x in (loop.H_A_per_m, loop.B_T, loop.valid))
    check_protocol(H, where)
    try:
        check_branches(H, v.astype(bool), cfg, where, row_offset=0)
    except InputError as e:
        raise InputError(str(e).replace(": row ", ": sample ", 1)) from None
    keep = decimate(H, int(cfg["bh"]["max_samples"]))
    H, B, v = H[keep], B[keep], v[keep].astype(bool)
    k, n = int(cfg["bh"]["conditioning_passes"]), H.size
    cur = np.tile(H, k + 1)
    valid = np.concatenate([np.zeros(k * n, dtype=bool), v])
    pf, pl = check_protocol(H, where)
    sw = Sweep(where, "B", cur, np.arange(cur.size, dtype=float), np.tile(B, k + 1), valid, 1.0,
               peak_first=pf + k * n, peak_last=pl + k * n, kind="bh", has_time=False, start=k * n,
               M0=float(B[0] / MU0 - H[0]))
    sw.region = region_labels(cur, cfg=cfg, B=sw.B)
    return sw


def _trunc_factor(c: float) -> float:
    """E[x^2 | |x| < c] for a standard normal x."""
    phi = math.exp(-0.5 * c * c) / math.sqrt(2 * math.pi)
    return 1.0 - 2.0 * c * phi / math.erf(c / math.sqrt(2))


def noise_floor(resid, sweep: Sweep, clip: float) -> float:
    """Sensor noise sigma (T) from the residual's second differences along each branch.

    d2[j] = r[j-1] - 2 r[j] + r[j+1] of white noise has sd sqrt(6) sigma; a smooth model misfit adds
    little to it. A MAD estimate first, then the RMS of the d2 within ``clip`` MAD-sigmas (kinks,
    e.g. where a sensor starts to clip, drop out), corrected for the truncation. Triples that
    straddle a turning point or contain a flagged (or conditioning) sample are not used.
    """
    r = np.asarray(resid, dtype=float)
    v = sweep.valid
    d2 = []
    for seg in sweep.segments:
        for j in range(seg.start + 1, seg.stop):
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
    j = np.cumsum(sweep.valid) - 1  # position among the fitted samples (a conditioning prefix has none)
    m = max(int(sweep.valid.sum()), 1)
    out = j % int(K) if kind == "interleaved" else (np.clip(j, 0, None) * int(K)) // m
    return np.where(sweep.valid, out, -1)


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
        for k in ("output_min_V", "output_max_V"):  # declared limits bound where a clip can be (effects)
            if getattr(s, k, None) is not None:
                out[k] = float(getattr(s, k))
    if getattr(raw, "supply_V", None):
        out["supply_V"] = float(raw.supply_V)
    return out
