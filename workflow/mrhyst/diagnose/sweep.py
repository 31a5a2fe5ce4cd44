"""The sweep: one Hall channel of a raw sweep (any piecewise-monotone current path) or a third-party B(H)
loop, the shape of its path (:class:`mrhyst.data.shape.PathShape`, derived once when the sweep is made: segments,
cycles, regions along the loop), the noise floor."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from mrhyst.data import loops
from mrhyst.data import shape as shp
from mrhyst.data.io import InputError, check_fittable, raw_to_loop, read_loop, read_raw, sidecar_path
from mrhyst.diagnose import startstate
from mrhyst.diagnose.settings import resolve_config
from mrhyst.model.ja import MU0

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
    shape: shp.PathShape = None  # the shape of the current path (segments, turning points, cycles)
    pass_shape: shp.PathShape = None  # a B(H) loop: the shape of one pass (the loop as fitted, decimated)
    n_file: int | None = None  # readings in the file when decimated (diagnose.max_samples), else None
    start_state: dict = field(default_factory=dict)  # how the core was conditioned (diagnose.startstate); {} = assumed
    measured: shp.PathShape = None  # with a conditioning prefix (start > 0): the shape of current[start:]
    dejittered: dict = field(default_factory=dict)  # a B(H) loop's jitter left out (diagnose.bh.reversal_frac)
    closure: dict = field(default_factory=dict)  # a B(H) record: closed (conditioned) or open (bh_closure)

    @property
    def n(self) -> int:
        return int(self.B.size)

    @property
    def measured_shape(self) -> shp.PathShape:
        """The shape of the measured samples' path, ``current[start:]`` (the signatures and the confound table
        read it): the sweep's own shape without a conditioning prefix, else the one kept when the prefix was
        prepended (derived here, once, when none was kept)."""
        if self.start == 0:
            return self.shape
        if self.measured is None:
            self.measured = shape_of(self.current[self.start:], self.source)
        return self.measured

    @property
    def segments(self) -> tuple:
        return self.shape.segments

    @property
    def cycle(self) -> np.ndarray:
        return self.shape.cycle


def shape_of(current, source: str = "sweep", time=None) -> shp.PathShape:
    """The path's shape (:func:`mrhyst.data.shape.path_shape`); a PathShape is returned as it is. InputError
    when the current never changes."""
    if isinstance(current, shp.PathShape):
        return current
    try:
        return shp.path_shape(current, time)
    except ValueError:
        raise InputError(f"{source}: the current never changes; diagnose needs a current path with at least one "
                         f"reversal (e.g. 0 -> max -> 0)") from None


def check_protocol(current, source: str = "sweep") -> tuple[int, int]:
    """(first, last) index of the first turning point of any piecewise-monotone path (its values or its
    PathShape); InputError when the current never changes or never turns (a single ramp has no second
    branch to judge a fit by)."""
    sh = shape_of(current, source)
    if sh.reversals < 1:
        raise InputError(f"{source}: the current only {'rises' if sh.segments[0].direction > 0 else 'falls'} (no "
                         f"reversal); diagnose needs at least one reversal (e.g. 0 -> max -> 0)")
    return sh.first_turn()


def region_labels(current, peak_first: int = 0, peak_last: int = 0, cfg: dict | None = None, B=None) -> np.ndarray:
    """Region of each sample (REGIONS) of any path (:func:`mrhyst.data.loops.region_labels`); the turning-point
    arguments are kept for callers of the paper-protocol version and not needed."""
    return loops.region_labels(current, B, resolve_config(cfg)["regions"])


def check_branches(current, valid, cfg: dict, source: str, row_offset: int = 2, start: int = 0,
                   rows=None) -> None:
    """Every monotone branch needs ``min_per_branch`` samples (turning points included) and the sweep
    ``min_samples`` usable ones; else one InputError naming the row where the short branch starts (``rows``: the
    file's index of each sample when some were left out, else its place). A sample at a declared output limit
    counts for its branch: a branch the clip covers whole is read, and the clip is what the diagnosis names."""
    v = np.asarray(valid, dtype=bool)
    need, per = int(cfg["min_samples"]), int(cfg["min_per_branch"])
    if int(v.sum()) < need:
        raise InputError(f"{source}: {int(v.sum())} usable samples; diagnose needs at least {need}")
    for s in shape_of(current, source).segments:
        lo = max(s.start, start)
        if s.stop < start:
            continue
        n = s.stop + 1 - lo
        if n < per:
            kind = "ascending" if s.direction > 0 else "descending"
            row = lo - start if rows is None else int(rows[lo])
            raise InputError(f"{source}: row {row + row_offset}: the {kind} branch from here has {n} samples; "
                             f"diagnose needs at least {per} per branch to split the loop into regions")


def sweep_from_arrays(current, time_s, B, n_over_le: float, valid=None, cfg: dict | None = None,
                      source: str = "arrays", sensor: str = "B", dwell_s: float | None = None,
                      sensor_info: dict | None = None, shape: shp.PathShape | None = None) -> Sweep:
    """A Sweep from arrays (tests, the blind key's detectability check); protocol checked as for a file.
    ``dwell_s`` and ``sensor_info`` (sensitivity_V_per_T, quiescent_V, supply_V) bound plausible sizes;
    ``shape``: the current's shape when it is known already (it is not derived again)."""
    cfg = resolve_config(cfg)
    cur, t = np.asarray(current, dtype=float), np.asarray(time_s, dtype=float)
    sh = shape_of(cur if shape is None else shape, source, t)
    pf, pl = check_protocol(sh, source)
    valid = np.ones(cur.size, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    sw = Sweep(source, sensor, cur, t, np.asarray(B, dtype=float), valid, float(n_over_le), peak_first=pf,
               peak_last=pl, dwell_s=dwell_s, sensor_info=dict(sensor_info or {}), shape=sh)
    sw.region = sh.regions(sw.B, cfg["regions"])
    return sw


def load_sweep(raw_path, sensor: str, cfg: dict | None = None) -> Sweep:
    """Read a raw sweep, convert one channel, check the protocol and the sample count."""
    cfg = resolve_config(cfg)
    raw = read_raw(raw_path)
    src = str(raw_path)
    cur, t = raw.current_A.astype(float), raw.time_s.astype(float)
    sh = shape_of(cur, src, t)
    pf, pl = check_protocol(sh, src)
    loop = raw_to_loop(raw, sensor, sh)
    valid = np.ones(len(loop), dtype=bool)
    if "saturated" in loop:
        valid = ~loop["saturated"].to_numpy().astype(bool)
    check_branches(sh, valid, cfg, src)
    B = loop["B_T"].to_numpy(dtype=float)
    dwell, n_file = _dwell(raw), None
    keep = decimate(sh, int(cfg["max_samples"]))  # bounded time and memory for a long log (issue 25)
    if keep.size > 2 * int(cfg["max_samples"]):  # turning points are always kept: a current that jitters
        raise InputError(f"{src}: {cur.size} readings whose current reverses {sh.reversals} times; more than "
                         f"2 x diagnose.max_samples ({int(cfg['max_samples'])}) samples would remain after decimation")
    if keep.size < cur.size:
        n_file, k = cur.size, int(np.ceil(cur.size / int(cfg["max_samples"])))
        cur, t, B, valid = cur[keep], t[keep], B[keep], valid[keep]
        dwell = dwell * k if dwell else None  # an eddy lag acts per kept step: k readings apart
        sh = shape_of(cur, src, t)
        pf, pl = check_protocol(sh, src)
    sw = Sweep(src, sensor, cur, t, B, valid, float(raw.coil_turns_per_m), peak_first=pf, peak_last=pl,
               dwell_s=dwell, sensor_info=_sensor_info(raw, sensor), shape=sh, n_file=n_file)
    sw.region = sh.regions(B, cfg["regions"])
    return startstate.apply(sw, raw.sidecar, cfg["regions"], str(sidecar_path(raw_path)))  # issue 23


def decimate(H, max_samples: int) -> np.ndarray:
    """Indices of at most about ``max_samples`` samples along a dense loop: every k-th sample plus every
    turning point and the last sample (the diagnosis's fits are sized for sweeps of tens to hundreds of
    samples; a densely digitised loop holds no more information about a smooth gap than its decimation)."""
    sh = shape_of(H)
    n = sh.n
    if n <= max_samples:
        return np.arange(n)
    k = int(np.ceil(n / max_samples))
    keep = set(range(0, n, k)) | set(np.flatnonzero(sh.turning).tolist()) | {n - 1}
    return np.array(sorted(keep))


JITTER_FRAC_CAP = 0.08  # the largest tolerance dejitter raises to: a real minor loop is rarely smaller


class Legs(NamedTuple):
    """A B(H) path as read (:func:`dejitter`): the file's samples kept, the tolerance used, the shape of the kept
    path, the decimation's indices into it and the decimated path's shape."""

    index: np.ndarray
    frac: float
    shape: shp.PathShape
    keep: np.ndarray
    thin: shp.PathShape


def dejitter(H, frac: float, per: int, max_samples: int, where: str = "loop") -> Legs:
    """A measured B(H) path that jitters in H read as its real legs (:func:`mrhyst.data.loops.monotone_index` at
    ``frac`` x max |H|). While legs of fewer than ``per`` samples remain, in the file or in its decimation to
    ``max_samples`` (a loop of a few hundred A/m wanders by 1-5 % of its peak at the start and at the tips; one
    spike above the tolerance makes a 1-sample leg), the tolerance is doubled up to JITTER_FRAC_CAP: a real minor
    loop is rarely smaller, and one that is stays (check_branches then names its short branch). ``frac`` 0: the
    path as read. Each path's shape is derived once."""
    H = np.asarray(H, dtype=float)

    def read(k) -> Legs:
        h = H if k.size == H.size else H[k]
        sh = shape_of(h, where)
        keep = decimate(sh, max_samples)
        return Legs(k, frac, sh, keep, sh if keep.size == h.size else shape_of(h[keep], where))

    out = read(loops.monotone_index(H, frac))
    while frac > 0 and _short(out, per) and frac * 2 <= JITTER_FRAC_CAP:
        frac *= 2
        k = loops.monotone_index(H, frac)
        if not np.array_equal(k, out.index):  # else the tolerance that made these legs stays the one recorded
            out = read(k)
    return out


def _short(legs: Legs, per: int) -> bool:
    return any(sg.stop - sg.start + 1 < per for s in (legs.shape, legs.thin) for sg in s.segments)


def sweep_from_bh(path, loop_index: int | None = None, cfg: dict | None = None) -> Sweep:
    """A third-party B(H) loop (``H_A_per_m,B_T[,loop_index]``) as a Sweep: H in place of the current
    (N/Le = 1), no Hall chain, no sample times (the sample index stands in; eddy lag and drift are not
    judged), decimated to ``bh.max_samples``. A measured loop is rarely taken from the demagnetised state, so
    a CLOSED record (its last sample back at its first, within ``bh.closed_tol_frac`` of max|H| in H and of the B
    amplitude in B: a loop in cyclic steady state) is simulated after ``bh.conditioning_passes`` runs of its own
    path (a cyclic start, as ``mrhyst fit --start cyclic``: from the first sample's state, M0 = B0/mu0 - H0, so
    that J-A does not start far from the loop) and compared on the last pass only (the conditioning is not
    fitted). An OPEN record (a virgin curve first, as the gadolinium loops and Hiperco 50's, or a converted
    0 -> max -> 0 sweep) is simulated once from its first sample's state: repeating it would invent a jump from
    its end back to its start (as the fits of data/external choose, :func:`mrhyst.materials.external.choose_start`).
    ``Sweep.closure`` records which, with the figures."""
    cfg = resolve_config(cfg)
    loop = read_loop(path, loop_index)
    check_fittable(loop, sign=False)  # a flat or one-branch loop, B or H in another unit: one line (issue 25); a
    # reversed sign is named by the diagnosis (signature reversed_sign, mrhyst.diagnose.polarity), not refused
    where = f"{path}" + ("" if loop_index is None else f" (loop_index {loop_index})")
    H, B, v = (np.asarray(x, dtype=float) for x in (loop.H_A_per_m, loop.B_T, loop.valid))
    legs = dejitter(H, float(cfg["bh"]["reversal_frac"]), int(cfg["min_per_branch"]), int(cfg["bh"]["max_samples"]),
                    where)
    dropped = H.size - legs.index.size
    H, B, v = H[legs.index], B[legs.index], v[legs.index]
    file_shape = legs.shape  # the loop as read: its branches checked, its turning points kept
    check_protocol(file_shape, where)
    try:
        check_branches(file_shape, v.astype(bool), cfg, where, row_offset=0, rows=legs.index)
    except InputError as e:
        raise InputError(str(e).replace(": row ", ": sample ", 1)) from None
    keep, pass_shape = legs.keep, legs.thin
    H, B, v = H[keep], B[keep], v[keep].astype(bool)
    closure = bh_closure(H, B, float(cfg["bh"]["closed_tol_frac"]))
    k, n = (int(cfg["bh"]["conditioning_passes"]) if closure["closed"] else 0), H.size
    cur = np.tile(H, k + 1)
    valid = np.concatenate([np.zeros(k * n, dtype=bool), v])
    sh = shape_of(cur, where)  # the path simulated: the decimated loop run k + 1 times
    pf, pl = sh.first_turn(k * n)
    sw = Sweep(where, "B", cur, np.arange(cur.size, dtype=float), np.tile(B, k + 1), valid, 1.0,
               peak_first=pf, peak_last=pl, kind="bh", has_time=False, start=k * n,
               M0=float(B[0] / MU0 - H[0]), shape=sh, pass_shape=pass_shape, measured=pass_shape)
    if dropped:
        sw.dejittered = {"samples_dropped": int(dropped), "reversal_frac": legs.frac}
    sw.closure = dict(closure, conditioning_passes=k)
    sw.region = sh.regions(sw.B, cfg["regions"])
    return sw


def bh_closure(H, B, tol: float) -> dict:
    """{"H_frac", "B_frac", "closed"}: |H_end - H_start| / max|H| and |B_end - B_start| / the B amplitude of a
    measured record, closed when both are <= ``tol`` (a loop in cyclic steady state: the clean loops of data/external
    that start at a tip are back within 0.0044; a record that starts with a virgin curve is off by ~1)."""
    from mrhyst.materials.external import closure  # the fits' own measure (their choose_start), at this tolerance

    fh, fb = closure(H, B)
    return {"H_frac": fh, "B_frac": fb, "closed": bool(fh <= tol and fb <= tol)}


def noise_floor(resid, sweep: Sweep, clip: float) -> float:
    """Sensor noise sigma (T) from the residual's second differences along each branch
    (:func:`mrhyst.data.shape.noise_floor`, over the fitted samples); the residual's RMS when the sweep has
    fewer than 4 usable triples."""
    s = shp.noise_floor(resid, sweep.shape, sweep.valid, clip)
    if s is None:
        rv = np.asarray(resid, dtype=float)[sweep.valid]
        return float(np.sqrt(np.mean(rv**2)))
    return s


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
    if getattr(raw, "supply_min_V", 0.0):  # a bipolar supply: the plausible sizes scale with the span
        out["supply_min_V"] = float(raw.supply_min_V)
    return out
