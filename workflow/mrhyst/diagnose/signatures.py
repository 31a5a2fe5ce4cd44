"""Signatures no material can make (issue 23, item 2): model-free tests of a sweep, read before any fit.

A rate-independent magnetic material ties B to the field history: B cannot change while the current is
held, cannot move against the current on a monotone branch, cannot sit flat at one level with a kink where
it was rising, and a symmetric major loop of it is centred on B = 0 and closes on a repeat. A measurement
chain breaks each of these (a drift, an eddy settling, an unrecorded excursion, a clipped output, a Hall
offset). Each test here is a pure function from arrays (current or H, B, the noise sigma) to a list of
:class:`Signature` records: its ``kind``, its ``size_T``, its significance ``sigma`` in noise standard
deviations and the ``samples`` where it shows (0-based indices into the arrays given; for a diagnosis, the
measured samples after any conditioning prefix). ``supports`` names the effects of the vocabulary it is
evidence for; ``why`` says it in words.

==================  ========================================================================================
kind                what (size_T; sigma)
==================  ========================================================================================
``held_current``    B changes between two consecutive readings at the same current (the change; |change| /
                    (sqrt 2 sigma)): a time effect (drift, eddy settling) or an unrecorded excursion (a
                    polarity switch at 0 A)
``clip``            samples at a declared output limit (sidecar ``output_min_V`` / ``output_max_V``): a clip,
                    full stop (the level in T; the depth of the kink below the extrapolated branch, in
                    sigmas of that extrapolation; 0 when no branch precedes it)
``flat_kink``       B flat within noise at one level over >= ``flat_min_samples`` distinct currents at a
                    turn, flatter than mu0 H alone, after a branch whose extrapolation rises beyond that
                    level (the level; the kink's depth in sigmas): a clip at an undeclared limit
``against_field``   B moves against the current on a monotone branch (the largest fall, signed against the
                    branch; fall / (sqrt 2 sigma)): no rate-independent material; a drift or an eddy lag
``centre_offset``   the centre of a symmetric major loop, (B_up(H) + B_down(-H)) / 2 averaged over the loop
                    (the centre; centre / standard error): a constant offset
``not_closed``      B at the same (current, direction) one cycle later, the virgin branch left out (mean
                    difference; mean / standard error): a drift (accommodation of a core decays, a drift
                    does not)
``reversed_sign``   B runs against the current over whole branches of both directions: its net change along
                    each monotone branch with >= 3 currents is against the branch on a rising and on a falling
                    one and with none (the mean net change; the smallest net change / (sqrt 2 sigma); each such
                    branch's first and last sample): the sign of B or of the current is reversed, a sensor
                    facing the other way or a coil connected the other way round. No material (B rises with H
                    along any branch) and no time effect (a drift moves B one way in time: it cannot turn both
                    a rise and a fall) makes it
``clockwise``       the loop runs clockwise: the integral of H dB along the path, from its first valid reading
                    to the one nearest its field on the last return (closed by a straight step), is negative
                    (the mean opening of the loop in B, integral / the field's span, negative; -integral / its
                    standard error from the noise; the path's first and last sample). A material at a fixed
                    temperature dissipates energy over a cycle, so its loop runs anticlockwise in (H, B): B and
                    the current read out of step or out of order (a B reading taken before its current was set,
                    one channel reversed or shifted in time) or a time effect larger than the loop's own
                    opening (a drift of the sensor, the core warming during the sweep). Not tested when
                    ``reversed_sign`` shows (that turns the loop too)
``first_zero``      B at the first reading when it is at zero current, of a Hall sweep (B; |B| / sigma): a
                    remanent start or a Hall offset; one unipolar sweep cannot tell them apart, a saturating
                    sweep can (an offset moves the loop's centre, a remanent start is wiped by the first
                    reversal); a bipolar one to the same amplitude only when the loop is closed at its turn
                    (:mod:`.confounds`, whose rows give the verdict's next_measurement)
==================  ========================================================================================

Significance uses the one noise-floor estimate of the project (:func:`mrhyst.diagnose.sweep.noise_floor`; the
diagnosis passes its own). Thresholds: config ``diagnose.signatures`` (defaults in the schema).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mrhyst.data.shape import PathShape, branch_nets, closed_loss, path_shape, reversed_branches

KINDS = ("held_current", "clip", "flat_kink", "against_field", "reversed_sign", "clockwise", "centre_offset",
         "not_closed", "first_zero")
SUPPORTS = {"held_current": ("thermal_drift", "eddy_lag"), "clip": ("sensor_saturation",),
            "flat_kink": ("sensor_saturation",), "against_field": ("thermal_drift", "eddy_lag"), "reversed_sign": (),
            "clockwise": ("thermal_drift",), "centre_offset": ("hall_offset",), "not_closed": ("thermal_drift",),
            "first_zero": ("hall_offset", "remanent_start")}
WHY = {
    "held_current": "B changed while the current did not (a time effect: drift, eddy settling; or an unrecorded "
                    "excursion, e.g. a polarity switch)",
    "clip": "B sits at the sensor's declared output limit: a clip",
    "flat_kink": "B flat at one level with a kink where the branch was rising: a clip at an undeclared limit",
    "against_field": "B moves against the current on a monotone branch: no rate-independent material does",
    "reversed_sign": "B runs against the current over whole rising and falling branches: the sign of B or of the "
                     "current is reversed (a sensor facing the other way, a coil connected the other way round); "
                     "no material or measurement effect does this",
    "clockwise": "the loop runs clockwise (the integral of H dB is negative: the core would give energy back): no "
                 "material at a fixed temperature does; B and the current are read out of step or out of order, or "
                 "B moves in time by more than the loop's own opening (a sensor drift, the core warming)",
    "centre_offset": "the centre of the symmetric major loop is away from B = 0: an offset",
    "not_closed": "the loop does not close on a repeated cycle: B moves with time",
    "first_zero": "B is not zero at the first 0 A reading: a remanent start or an offset (one unipolar sweep "
                  "cannot tell them apart; a sweep that saturates the core can: an offset moves the loop's centre, "
                  "a full reversal wipes a remanent start. A bipolar sweep to the same amplitude wipes a J-A-like "
                  "remanence only: while the loop is open at its turn, a part of the core switching beyond it "
                  "keeps its remanence, an offset on that sweep too; the verdict's next_measurement says which)",
}
SQ2 = math.sqrt(2.0)
MU0 = 4e-7 * math.pi


@dataclass(frozen=True)
class Signature:
    kind: str
    size_T: float
    sigma: float
    samples: tuple = field(default_factory=tuple)

    def to_dict(self, offset: int = 0) -> dict:
        """The contract record ``{"kind", "size_T", "sigma", "samples", "supports", "why"}``; ``offset`` is
        added to the sample indices (a conditioning prefix)."""
        return {"kind": self.kind, "size_T": float(self.size_T), "sigma": float(self.sigma),
                "samples": [int(j) - offset for j in self.samples], "supports": list(SUPPORTS[self.kind]),
                "why": WHY[self.kind]}


def _shape(cur, shape) -> PathShape:
    """The path's shape: ``shape`` when the caller has it (a diagnosis: the sweep's, derived once), else derived."""
    return path_shape(cur) if shape is None else shape


def _same(a, b, scale: float) -> bool:
    return abs(float(a) - float(b)) <= 1e-9 * max(scale, 1e-300)


def held_current(current, B, sigma: float, ok, min_sigma: float) -> list[Signature]:
    """Consecutive readings at the same current whose B differs by >= ``min_sigma`` x sqrt(2) sigma."""
    cur, B = np.asarray(current, dtype=float), np.asarray(B, dtype=float)
    scale = float(np.max(np.abs(cur)))
    out = []
    for j in range(1, cur.size):
        if ok[j] and ok[j - 1] and _same(cur[j], cur[j - 1], scale):
            d = float(B[j] - B[j - 1])
            z = abs(d) / (SQ2 * sigma)
            if z >= min_sigma:
                out.append(Signature("held_current", d, z, (j - 1, j)))
    return out


def _kink(cur, B, run: np.ndarray, level: float, sigma: float, near: list) -> float:
    """Depth (in sigmas of the prediction) by which the branch beside ``run`` (the samples ``near``, up to 3
    distinct currents next to it on one monotone segment, a linear fit in the current) extrapolated to the
    run's current farthest from them passes ``level`` (away from zero); 0 with fewer than 2 currents."""
    if len(near) < 2 or len({float(cur[j]) for j in near}) < 2:
        return 0.0
    x, y = cur[near], B[near]
    xb = float(np.mean(x))
    sxx = float(np.sum((x - xb) ** 2))
    slope = float(np.sum((x - xb) * (y - np.mean(y))) / sxx)
    x0 = float(cur[run][np.argmax(np.abs(cur[run] - xb))])
    pred = float(np.mean(y)) + slope * (x0 - xb)
    sd = sigma * math.sqrt(1.0 / len(near) + (x0 - xb) ** 2 / sxx + 1.0 / run.size)
    return max(math.copysign(1.0, level) * (pred - level), 0.0) / sd if sd > 0 else 0.0


def _beside(cur, run: np.ndarray, ok, side: int) -> list:
    """Up to 3 valid samples next to ``run`` on the side ``side`` (-1 before, +1 after), on the monotone stretch
    that meets it (stops where the current turns)."""
    out, j = [], (int(run.min()) - 1 if side < 0 else int(run.max()) + 1)
    last, sgn = None, None
    while 0 <= j < cur.size and len(out) < 3:
        if last is not None and cur[j] != cur[last]:
            d = np.sign(cur[j] - cur[last])
            if sgn is not None and d != sgn:
                break
            sgn = d
        if ok[j]:
            out.append(j)
        last, j = j, j + side
    return out[::-1] if side < 0 else out


def _kink_both(cur, B, run, level, sigma, ok) -> float:
    """The larger kink of the two branches that meet a flat run (a clip has one on each side of a turn)."""
    return max(_kink(cur, B, run, level, sigma, _beside(cur, run, ok, side)) for side in (-1, 1))


def clip(current, B, sigma: float, limits_T: tuple, tol_sigma: float) -> list[Signature]:
    """Samples within ``tol_sigma`` x sigma of (or beyond) a declared limit (B_lo, B_hi) in T (None: not
    declared): one signature per limit, whatever its significance (a clip at a declared limit is a clip)."""
    cur, B = np.asarray(current, dtype=float), np.asarray(B, dtype=float)
    out = []
    for lim, sgn in zip(limits_T, (-1.0, 1.0)):
        if lim is None:
            continue
        at = np.flatnonzero(sgn * (B - lim) >= -tol_sigma * sigma)
        if at.size == 0:
            continue
        z = _kink_both(cur, B, at[: _run_len(at)], float(lim), sigma, np.ones(cur.size, dtype=bool))
        out.append(Signature("clip", float(lim), z, tuple(int(j) for j in at)))
    return out


def _run_len(at: np.ndarray) -> int:
    """Length of the first contiguous run of indices in ``at``."""
    gaps = np.flatnonzero(np.diff(at) != 1)
    return int(gaps[0]) + 1 if gaps.size else int(at.size)


def _vacuum_deficit(x, y, sigma: float, n_over_le: float) -> tuple[float, float]:
    """(deficit, power): how far the least-squares slope of B on the current over a run falls below the
    vacuum's mu0 N/Le, and that slope itself, in standard errors of the slope (0, 0 for one current)."""
    xb = float(np.mean(x))
    sxx = float(np.sum((x - xb) ** 2))
    if not sxx > 0 or not sigma > 0:
        return 0.0, 0.0
    slope = float(np.sum((x - xb) * (y - np.mean(y)))) / sxx
    se = sigma / math.sqrt(sxx)
    return (MU0 * float(n_over_le) - slope) / se, MU0 * float(n_over_le) / se


def flat_kink(current, B, sigma: float, ok, min_sigma: float, min_run: int, n_over_le: float,
              vacuum_sigma: float, skip=(), shape: PathShape | None = None) -> list[Signature]:
    """At each turn of the current (and the path's first and last samples): the samples around it within 3
    sigma of B there; a signature when they span >= ``min_run`` distinct currents, B's slope over them is below
    the vacuum part of B = mu0 (H + M), mu0 x ``n_over_le``, by >= ``vacuum_sigma`` standard errors (M never
    falls on a monotone branch, so no material, even saturated, is flatter; a Preisach core at full
    saturation in the blind benchmark rose 2.5-2.8 mT over runs whose vacuum part was 0.7-1.4 mT, and was
    named a flat kink before this test; where the vacuum slope is too small against the noise for that test,
    e.g. a B(H) loop, the kink must reach twice ``min_sigma``: those Preisach kinks were 6.0 and 6.4 sigma),
    and a branch that meets them
    extrapolates beyond their level by >= ``min_sigma`` (a kink). Runs touching a sample in ``skip`` (already
    a declared clip) are left out."""
    cur, B = np.asarray(current, dtype=float), np.asarray(B, dtype=float)
    turns = sorted({0, cur.size - 1, *(s.stop for s in _shape(cur, shape).segments[:-1])})
    out, done = [], set(skip)
    for t in turns:
        if not ok[t] or t in done:
            continue
        lo = hi = t
        while lo - 1 >= 0 and ok[lo - 1] and abs(B[lo - 1] - B[t]) <= 3 * sigma:
            lo -= 1
        while hi + 1 < cur.size and ok[hi + 1] and abs(B[hi + 1] - B[t]) <= 3 * sigma:
            hi += 1
        run = np.arange(lo, hi + 1)
        if len({float(c) for c in cur[run]}) < min_run or done & set(run.tolist()):
            continue
        deficit, power = _vacuum_deficit(cur[run], B[run], sigma, n_over_le)
        if power >= vacuum_sigma and deficit < vacuum_sigma:
            continue  # not flatter than the vacuum's mu0 H: a saturated material can be this flat
        level = float(np.mean(B[run]))
        z = _kink_both(cur, B, run, level, sigma, ok)
        if z >= (min_sigma if power >= vacuum_sigma else 2 * min_sigma):
            out.append(Signature("flat_kink", level, z, tuple(run.tolist())))
            done |= set(run.tolist())
    return out


def against_field(current, B, sigma: float, ok, min_sigma: float, shape: PathShape | None = None) -> list[Signature]:
    """On each monotone segment, the largest move of B against the current between two valid samples at
    different currents (a later sample below an earlier one on a rising branch): one signature per segment
    whose move is >= ``min_sigma`` x sqrt(2) sigma."""
    cur, B = np.asarray(current, dtype=float), np.asarray(B, dtype=float)
    out = []
    for s in _shape(cur, shape).segments:
        idx = np.array([j for j in range(s.start, s.stop + 1) if ok[j]])
        if idx.size < 2:
            continue
        b, c = s.direction * B[idx], cur[idx]
        fall = b[:, None] - b[None, :]  # fall[i, k] = b_i - b_k: > 0 when the later k lies below the earlier i
        later = np.triu(np.ones(fall.shape, dtype=bool), 1) & (c[:, None] != c[None, :])
        fall = np.where(later, fall, -np.inf)
        i, k = np.unravel_index(int(np.argmax(fall)), fall.shape)
        z = float(fall[i, k]) / (SQ2 * sigma)
        if z >= min_sigma:
            out.append(Signature("against_field", -s.direction * float(fall[i, k]), z, (int(idx[i]), int(idx[k]))))
    return out


def reversed_sign(current, B, sigma: float, ok, min_sigma: float, shape: PathShape | None = None) -> list[Signature]:
    """B's net change along each monotone segment with >= 3 distinct valid currents (last minus first valid sample,
    signed by the segment's direction): one signature when it is against the segment by >= ``min_sigma`` x sqrt(2)
    sigma on at least one rising and one falling segment and with it by as much on none."""
    cur = np.asarray(current, dtype=float)
    against = reversed_branches(branch_nets(cur, B, ok, _shape(cur, shape)), min_sigma * SQ2 * sigma)
    if against is None:
        return []
    z = min(-n[1] for n in against) / (SQ2 * sigma)
    size = float(np.mean([n[1] for n in against]))
    return [Signature("reversed_sign", size, z, tuple(j for n in against for j in n[2:]))]


def clockwise(current, B, sigma: float, ok, min_sigma: float, tol: float = 0.02) -> list[Signature]:
    """The closed integral of H dB along the sweep (:func:`mrhyst.data.shape.closed_loss`: from the first valid
    reading to the one nearest its current on the path's last return, closed by a straight step): one signature
    when it is negative by >= ``min_sigma`` standard errors (sigma sqrt(sum c_j^2), the integral being sum c_j B_j).
    A path with no reversal in that stretch is not tested."""
    got = closed_loss(current, B, ok, tol)
    if got is None:
        return []
    w, se, first, last, span = got
    z = -w / (sigma * se)
    return [Signature("clockwise", w / span, z, (first, last))] if z >= min_sigma else []


def _branch(cur, B, s, ok) -> tuple[np.ndarray, np.ndarray]:
    """(current, B) of segment ``s`` in increasing current, valid samples only, repeats averaged."""
    idx = [j for j in range(s.start, s.stop + 1) if ok[j]]
    x, y = cur[idx], B[idx]
    xs = np.unique(x)
    return xs, np.array([float(np.mean(y[x == v])) for v in xs])


def steady_segments(current, cycled: bool, tol: float = 0.02, shape: PathShape | None = None) -> list:
    """The monotone segments of a cyclic steady state: a full swing (from within ``tol`` of one extreme of
    the path to within ``tol`` of the other) whose own start is a loop tip reached on a full swing: the
    segment before it is a full swing that is not the first branch, or the recording starts at an extreme of
    |I| (a recorded loop that starts at its tip, as third-party B(H) loops do). The branch after a virgin
    curve (the first branch of a sweep from 0 A, even when it spans 0 -> max) is not steady: a core (and J-A)
    accommodates there (J-A's first loop after 0 -> 2 A is off-centre by 2.5 % of its 0.11 T peak; the
    following cycles differ by 0.9-2 %, decaying by a factor 0.25-0.75 per cycle). A sweep from a demagnetised
    core at 0 A has none unless ``cycled`` (the sidecar declares the preconditioning): at low drive J-A goes
    on accommodating for many cycles (the blind bipolar variant's clean two-cycle sweeps, 0.03-0.08 T: loops
    off-centre by 1.6-4.9 % of the peak, moving by 3.4-3.7 % from one cycle to the next)."""
    cur = np.asarray(current, dtype=float)
    lo, hi = float(np.min(cur)), float(np.max(cur))
    span, top = hi - lo, float(np.max(np.abs(cur)))
    segs = _shape(cur, shape).segments
    full = [abs(cur[s.stop] - cur[s.start]) >= (1 - 2 * tol) * span for s in segs]
    at_tip = abs(cur[0]) >= (1 - tol) * top  # the recording starts at a loop tip (not at 0 A, not virgin)
    if not (at_tip or cycled):
        return []
    out = []
    for k, s in enumerate(segs):
        tip = (full[k - 1] and (k > 1 or at_tip)) if k > 0 else at_tip
        if full[k] and tip:
            out.append(s)
    return out


def centre_offset(current, B, sigma: float, ok, min_sigma: float, min_frac: float, cycled: bool,
                  sym_tol: float = 0.02, shape: PathShape | None = None) -> list[Signature]:
    """The centre of a symmetric major loop (I_max = -I_min within ``sym_tol``): on the last steady ascending
    branch (:func:`steady_segments`) each valid sample at |I| <= (1 - 5 sym_tol) I_max is paired with the last
    steady descending branch interpolated at -I; the centre is the mean of (B_up(I) + B_down(-I)) / 2, its
    standard error from the pairs' scatter (never below sigma / sqrt(2 n)). Named when it is >= ``min_sigma``
    standard errors AND >= ``min_frac`` of the loop's peak |B| (a measured loop is centred only to a
    fraction of its peak: a fluxmeter's integration constant, a core's own asymmetry; the clean real loops
    of data/external are off by 0.2-0.8 %)."""
    cur, B = np.asarray(current, dtype=float), np.asarray(B, dtype=float)
    imax, imin = float(np.max(cur)), float(np.min(cur))
    if not (imin < 0 < imax) or abs(imax + imin) > sym_tol * imax:
        return []
    steady = steady_segments(cur, cycled, sym_tol, shape)
    up = [s for s in steady if s.direction > 0]
    down = [s for s in steady if s.direction < 0]
    if not up or not down:
        return []
    xu, yu = _branch(cur, B, up[-1], ok)
    xd, yd = _branch(cur, B, down[-1], ok)
    keep = np.abs(xu) <= (1 - 5 * sym_tol) * imax
    if int(keep.sum()) < 4 or xd.size < 2:
        return []
    c = 0.5 * (yu[keep] + np.interp(-xu[keep], xd, yd))
    n = c.size
    se = max(float(np.std(c, ddof=1)), sigma / SQ2) / math.sqrt(n)
    z = abs(float(np.mean(c))) / se if se > 0 else 0.0
    if z < min_sigma or abs(float(np.mean(c))) < min_frac * float(np.max(np.abs(B[ok]))):
        return []
    samples = [j for j in range(up[-1].start, up[-1].stop + 1) if ok[j] and abs(cur[j]) <= (1 - 5 * sym_tol) * imax]
    return [Signature("centre_offset", float(np.mean(c)), z, tuple(samples))]


def _cycle_differences(cur, B, v, shape: PathShape) -> dict:
    """{cycle c: [(earlier sample, later sample, B difference), ...]} at the same (current, direction) in
    cycles c - 1 and c (:attr:`mrhyst.data.shape.PathShape.cycle`), samples where ``v``."""
    cyc, dirs = shape.cycle, shape.directions
    out = {}
    for c in range(1, int(cyc.max()) + 1):
        prev = {(round(float(cur[j]), 12), int(dirs[j])): j for j in np.flatnonzero((cyc == c - 1) & v)}
        rows = [(prev[key], int(j), float(B[j] - B[prev[key]])) for j in np.flatnonzero((cyc == c) & v)
                if (key := (round(float(cur[j]), 12), int(dirs[j]))) in prev]
        if rows:
            out[c] = rows
    return out


def not_closed(current, B, sigma: float, ok, min_sigma: float, min_frac: float, cycled: bool,
               keep_ratio: float = 0.8, shape: PathShape | None = None) -> list[Signature]:
    """B at the same (current, direction) one cycle later, on steady branches only (:func:`steady_segments`: a
    virgin curve and the branch after it accommodate): the mean difference over >= 4 pairs, named when >=
    ``min_sigma`` standard errors (sqrt(2) sigma / sqrt(n)) and, a core's own accommodation being a change
    that decays from cycle to cycle while a drift's does not: with two or more cycle-to-cycle differences, when
    the last keeps >= ``keep_ratio`` of the first (same sign); with one, when it is >= ``min_frac`` of the peak
    |B| (J-A's accommodation after 0 -> 1-2 A: 0.9-2 % per cycle, decaying by 0.3-0.6 per cycle)."""
    cur, B = np.asarray(current, dtype=float), np.asarray(B, dtype=float)
    ok = np.asarray(ok, dtype=bool)
    sh = _shape(cur, shape)
    v = np.zeros(cur.size, dtype=bool)
    for s in steady_segments(cur, cycled, shape=sh):
        v[s.start + 1: s.stop + 1] = True
    per = _cycle_differences(cur, B, v & ok, sh)
    d = [r[2] for rows in per.values() for r in rows]
    if len(d) < 4:
        return []
    m = float(np.mean(d))
    z = abs(m) / (SQ2 * sigma / math.sqrt(len(d)))
    means = [float(np.mean([r[2] for r in per[c]])) for c in sorted(per)]
    if len(means) >= 2:
        grows = means[-1] * means[0] > 0 and abs(means[-1]) >= keep_ratio * abs(means[0])
    else:
        grows = abs(m) >= min_frac * float(np.max(np.abs(B[ok])))
    if z < min_sigma or not grows:
        return []
    js = sorted({j for rows in per.values() for r in rows for j in r[:2]})
    return [Signature("not_closed", m, z, tuple(js))]


def first_zero(current, B, sigma: float, ok, min_sigma: float) -> list[Signature]:
    """B at the first valid reading when that reading is at zero current (a sweep that starts at 0 A)."""
    cur = np.asarray(current, dtype=float)
    first = np.flatnonzero(np.asarray(ok, dtype=bool))
    if first.size == 0 or not _same(cur[first[0]], 0.0, float(np.max(np.abs(cur)))):
        return []
    j = int(first[0])
    z = abs(float(B[j])) / sigma
    return [Signature("first_zero", float(B[j]), z, (j,))] if z >= min_sigma else []


def find(current, B, sigma: float, settings: dict, *, n_over_le: float, valid=None,
         limits_T: tuple = (None, None), hall: bool = True, cycled: bool = False,
         shape: PathShape | None = None) -> list[Signature]:
    """Every signature of one sweep (kinds in :data:`KINDS` order). ``settings``: config
    ``diagnose.signatures`` (min_sigma, flat_min_samples, vacuum_sigma, clip_tol_sigma, centre_min_frac,
    repeat_min_frac); ``valid``: samples usable as B
    (a flagged saturated sample is used only by the clip test); ``limits_T``: the declared output limits in
    B (lower, upper; None where not declared); ``n_over_le``: H per unit of ``current`` (1 for a B(H) loop, whose
    current is H); ``cycled``: the core was cycled before the recording (a declared preconditioning), so a
    sweep from 0 A has steady branches (:func:`steady_segments`); ``hall``: a raw Hall sweep (B at its first
    0 A reading is the core's start state plus the sensor's zero) rather than a third-party B(H) loop; ``shape``:
    the current's :class:`~mrhyst.data.shape.PathShape` when the caller has it (else derived here, once)."""
    cur, B = np.asarray(current, dtype=float), np.asarray(B, dtype=float)
    ok = np.ones(cur.size, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    if not sigma > 0 or cur.size < 3:
        return []
    ms, sh = float(settings["min_sigma"]), _shape(cur, shape)
    clips = clip(cur, B, sigma, limits_T, float(settings["clip_tol_sigma"]))
    on_limit = {j for s in clips for j in s.samples}
    ok_b = ok & ~np.isin(np.arange(cur.size), list(on_limit))
    out = held_current(cur, B, sigma, ok_b, ms) + clips
    out += flat_kink(cur, B, sigma, ok_b, ms, int(settings["flat_min_samples"]), n_over_le,
                     float(settings["vacuum_sigma"]), skip=on_limit, shape=sh)
    out += against_field(cur, B, sigma, ok_b, ms, shape=sh)
    turned = reversed_sign(cur, B, sigma, ok_b, ms, shape=sh)
    out += turned or clockwise(cur, B, sigma, ok_b, ms)  # a reversed sign turns the loop too: said once
    out += centre_offset(cur, B, sigma, ok_b, ms, float(settings["centre_min_frac"]), cycled, shape=sh)
    out += not_closed(cur, B, sigma, ok_b, ms, float(settings["repeat_min_frac"]), cycled, shape=sh)
    if hall:
        out += first_zero(cur, B, sigma, ok_b, ms)
    return out


def declared_limits_T(sensor_info: dict) -> tuple:
    """The declared output limits of a Hall sensor (sidecar output_min_V / output_max_V) as B in T: (low, high), None
    where none is declared; for a sensor mounted reversed (S < 0) output_max_V is the low one."""
    S, q = sensor_info.get("sensitivity_V_per_T"), sensor_info.get("quiescent_V")
    if not S or q is None:
        return None, None
    lo, hi = (None if sensor_info.get(k) is None else (float(sensor_info[k]) - q) / S
              for k in ("output_min_V", "output_max_V"))
    return (lo, hi) if S > 0 else (hi, lo)


def of_sweep(sweep, sigma: float, settings: dict) -> list[dict]:
    """The contract's ``signatures`` list of a diagnosis Sweep (measured samples only: a conditioning prefix
    is left out and the indices count from the first measured sample). A core the sidecar declares cycled
    has no ``first_zero`` test: its history sets B at the first reading (remanence is physics there)."""
    a = int(sweep.start)
    cycled = (getattr(sweep, "start_state", None) or {}).get("state") == "cycled"
    sig = find(sweep.current[a:], sweep.B[a:], sigma, settings, n_over_le=sweep.n_over_le, valid=sweep.valid[a:],
               limits_T=declared_limits_T(sweep.sensor_info), hall=sweep.kind == "hall" and not cycled,
               cycled=cycled, shape=sweep.measured_shape)
    return [s.to_dict() for s in sig]


def text(sigs: list[dict]) -> str:
    """The signatures for the verdict line ('' when none): '; signatures: WHY (KIND SIZE mT, Z sigma, samples
    A-B)' per signature, the most significant first."""
    if not sigs:
        return ""
    parts = []
    for s in sorted(sigs, key=lambda s: -s["sigma"]):
        j = s["samples"]
        where = f"sample {j[0]}" if len(j) == 1 else f"samples {j[0]}-{j[-1]}"
        parts.append(f"{s['why']} ({s['kind']} {s['size_T'] * 1e3:+.3g} mT, {s['sigma']:.1f} sigma, {where})")
    return "; signatures: " + "; ".join(parts)


def evidence_for(sigs: list[dict], effect: str, min_sigma: float = 0.0) -> list[dict]:
    """The signatures (contract records) that support ``effect`` at >= ``min_sigma``, most significant first: what
    a policy reads as "its signature is present" (a clip is always present once found)."""
    out = [s for s in sigs if effect in s["supports"] and (s["kind"] == "clip" or s["sigma"] >= min_sigma)]
    return sorted(out, key=lambda s: -s["sigma"])
