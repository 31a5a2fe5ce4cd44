"""The shape of one path (a raw sweep's current, a B(H) loop's H), derived once (issue 22, point 2).

:func:`path_shape` reads the path once and returns a frozen :class:`PathShape`; everything downstream (the
loop file's ``branch`` column, the diagnosis's regions, noise floor, repeated cycles and protocol text, the
branch check, the decimation of a dense B(H) loop, the materials figures' last full cycle, the integration
tolerance of a fit) asks that object instead of deriving directions, segments, turning points or cycles
from the raw values again.

Definitions (ARCHITECTURE 4: any piecewise-monotone path):

- **direction** of a sample: +1 / -1, the sign of the change that reached it; a repeated value (a dwell)
  keeps it; the first sample takes the direction of the first change;
- **segments**: maximal runs of one direction; consecutive segments share their turning sample (segment k
  ends at the last sample before the path turns, segment k+1 starts there);
- **turning points**: the extreme at each reversal (a segment's last sample) and its repeats (``turning``
  mask); ``turning_points`` lists the extremes plus both ends;
- **cycles**: a cycle starts each time the path turns from falling to rising (0 before the first such turn);
- **interior** samples: those whose neighbours lie on the same segment (the centres of the second
  differences of :func:`noise_floor`).

The one noise-floor estimator lives here too (:func:`noise_floor`, see there for why this one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MAD_TO_SD = 1.482602218505602  # sd of a normal = this x its median absolute deviation


@dataclass(frozen=True)
class Segment:
    """Samples start..stop (inclusive) on which the path moves in one direction (+1 up, -1 down)."""

    start: int
    stop: int
    direction: int

    @property
    def n(self) -> int:
        return self.stop - self.start + 1


def directions(path) -> np.ndarray:
    """+1 / -1 per sample (see the module text). Raises ValueError when the path never changes."""
    cur = np.asarray(path, dtype=float)
    d = np.sign(np.diff(cur))
    nz = d[d != 0]
    if nz.size == 0:
        raise ValueError("the current never changes")
    out = np.empty(cur.size, dtype=int)
    now = int(nz[0])
    out[0] = now
    for j in range(1, cur.size):
        if d[j - 1] != 0:
            now = int(d[j - 1])
        out[j] = now
    return out


def _segments(dirs: np.ndarray) -> tuple[Segment, ...]:
    cuts = np.flatnonzero(dirs[1:] != dirs[:-1])  # the sample before each first sample of a new direction
    out, start = [], 0
    for c in cuts:
        out.append(Segment(start, int(c), int(dirs[c])))
        start = int(c)
    out.append(Segment(start, len(dirs) - 1, int(dirs[-1])))
    return tuple(out)


def _turning(cur: np.ndarray, segs) -> np.ndarray:
    m = np.zeros(cur.size, dtype=bool)
    for s in segs[:-1]:
        j = s.stop
        m[j] = True
        k = j - 1
        while k >= s.start and cur[k] == cur[j]:  # repeats before the turn
            m[k] = True
            k -= 1
    return m


def _cycles(segs, n: int) -> np.ndarray:
    out = np.zeros(n, dtype=int)
    c = 0
    for prev, s in zip(segs[:-1], segs[1:]):
        if prev.direction < 0 and s.direction > 0:
            c += 1
        out[s.start + 1: s.stop + 1] = c
    return out


def _frozen(a) -> np.ndarray:
    a = np.array(a)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class PathShape:
    """The shape of one path; built by :func:`path_shape` only. Arrays are read-only."""

    path: np.ndarray
    time: np.ndarray | None
    directions: np.ndarray
    segments: tuple
    turning: np.ndarray
    cycle: np.ndarray
    interior: np.ndarray

    @property
    def n(self) -> int:
        return int(self.path.size)

    @property
    def reversals(self) -> int:
        return len(self.segments) - 1

    @property
    def n_cycles(self) -> int:
        return int(self.cycle.max()) + 1

    @property
    def turning_points(self) -> list[int]:
        """The extreme of every reversal (a segment's last sample), plus both ends."""
        return [0, *(s.stop for s in self.segments[:-1]), self.n - 1]

    def turns(self, start: int = 0) -> list[tuple[int, int, int]]:
        """(first, last, direction before) of every turning point (the extreme and its repeats) of the path
        from sample ``start`` on: those that begin after ``start`` (a turn reached from ``start`` by repeats
        only is no turn of that part of the path)."""
        out = []
        for s in self.segments[:-1]:
            first = s.stop
            while first - 1 >= s.start and self.path[first - 1] == self.path[s.stop]:  # its repeats
                first -= 1
            if first > start:
                out.append((int(first), int(s.stop), int(s.direction)))
        return out

    def first_turn(self, start: int = 0) -> tuple[int, int]:
        """(first, last) sample of the first turning point from ``start`` on; (-1, -1) when there is none."""
        t = self.turns(start)
        return (t[0][0], t[0][1]) if t else (-1, -1)

    def counts(self, start: int = 0) -> tuple[int, int]:
        """(reversals, cycles) of the path from sample ``start`` on (a cycle starts at each falling-to-rising
        turn)."""
        t = self.turns(start)
        return len(t), 1 + sum(d < 0 for _, _, d in t)

    def branches(self) -> np.ndarray:
        """'up' / 'down' per sample (the loop file's ``branch`` column)."""
        return np.where(self.directions > 0, "up", "down").astype(object)

    def last_cycle(self, same_frac: float = 0.02) -> tuple[int, int] | None:
        """(i0, i1) of the last full cycle: turning points (or ends) two apart at the same extreme (within
        ``same_frac`` of the path's span) through an extreme of the other sign; None without one."""
        H, tp = self.path, self.turning_points
        span = float(np.ptp(H)) if H.size else 0.0
        for k in range(len(tp) - 3, -1, -1):
            i0, im, i1 = tp[k], tp[k + 1], tp[k + 2]
            if abs(H[i1] - H[i0]) <= same_frac * span and H[i0] * H[im] < 0:
                return i0, i1
        return None

    def regions(self, B, regions: dict) -> np.ndarray:
        """Region of each sample (:func:`mrhyst.data.loops.region_labels`; ``regions``: the config's
        diagnose.regions) from this shape."""
        from mrhyst.data import loops

        return loops.labels_of(self, B, regions)


def _derive(path, time) -> PathShape:
    """The one derivation of a path's shape (tests count calls to it)."""
    cur = np.asarray(path, dtype=float)
    dirs = directions(cur)
    segs = _segments(dirs)
    interior = [j for s in segs for j in range(s.start + 1, s.stop)]
    return PathShape(_frozen(cur), None if time is None else _frozen(np.asarray(time, dtype=float)),
                     _frozen(dirs), segs, _frozen(_turning(cur, segs)), _frozen(_cycles(segs, cur.size)),
                     _frozen(np.asarray(interior, dtype=int)))


def path_shape(path, time=None) -> PathShape:
    """The shape of ``path`` (current or H in the order applied; optional sample times). ValueError when the
    path never changes. Derived afresh at each call: a caller that reads a path's shape more than once keeps the
    object (a diagnosis's Sweep holds its path's shape and hands it on; tests/test_shape.py counts derivations)."""
    return _derive(path, time)


def branch_nets(path, B, ok, shape: PathShape | None = None, min_levels: int = 3) -> list[tuple[int, float, int, int]]:
    """(direction, B's net change along it, first, last valid sample) of each monotone segment of ``path`` with at
    least ``min_levels`` distinct valid levels: the last valid B minus the first, times the direction (> 0 where B
    follows the path, as every material's does over a whole branch)."""
    p, B = np.asarray(path, dtype=float), np.asarray(B, dtype=float)
    out = []
    for s in (path_shape(p) if shape is None else shape).segments:
        idx = [j for j in range(s.start, s.stop + 1) if ok[j]]
        if len(idx) >= 2 and len({float(p[j]) for j in idx}) >= min_levels:
            out.append((s.direction, s.direction * float(B[idx[-1]] - B[idx[0]]), idx[0], idx[-1]))
    return out


def reversed_branches(nets: list, lim: float) -> list | None:
    """The :func:`branch_nets` against their path by more than ``lim`` when there are such on a rising and on a
    falling segment and none with it by more than ``lim`` (the sign of B or of the path reversed), else None."""
    against = [n for n in nets if n[1] < -lim]
    if any(n[1] > lim for n in nets) or {n[0] for n in against} != {-1, 1}:
        return None
    return against


def loss_weights(h) -> np.ndarray:
    """c with sum(c_j B_j) = the closed trapezoid integral of H dB along h (:func:`closed_loss`): the polygon through
    the samples closed by a straight step from the last back to the first, so c_j = (h_{j-1} - h_{j+1}) / 2 with
    the indices taken around the closed path. A closing step at the last sample's H (h_last (B_first - B_last),
    2026-11-27 until this) added the triangle (h_last - h_first) (B_first - B_last) / 2 wherever the stretch ends
    near, not at, its first field: on a steep anhysteretic curve that ends one current step past 0 A, -0.0385 A x
    18 mT, a clockwise loop at 5.6 sigma with no noise at all (bench/heldout_openworld.py's oov_leakage_02)."""
    c = np.zeros(h.size)
    c[1:-1] = 0.5 * (h[:-2] - h[2:])
    c[0] = 0.5 * (h[-1] - h[1])
    c[-1] = 0.5 * (h[-2] - h[0])
    return c


def _closing_sample(h, tol: float) -> int:
    """Where the stretch of :func:`closed_loss` ends: on the path's last visit within ``tol`` of its first value, the
    sample nearest that value (the latest of equals), so that a path that returns to its first field exactly is
    closed there (a straight closing step across a curved, steep branch encloses an area of its own)."""
    near = np.abs(h - h[0]) <= tol
    last = int(np.flatnonzero(near)[-1])
    first = last
    while first > 0 and near[first - 1]:
        first -= 1
    d = np.abs(h[first: last + 1] - h[0])
    return first + int(np.flatnonzero(d == d.min())[-1])


def closed_loss(path, B, ok, tol: float = 0.02) -> tuple[float, float, int, int, float] | None:
    """The integral of H dB (trapezoids; ``path`` is H or the current, whose scale cancels in a ratio) over the ``ok``
    samples from the first to the one nearest the first's path value on the path's last visit within ``tol`` of the
    path's span from it (:func:`_closing_sample`), closed by a straight step back to the first
    (:func:`loss_weights`): (the integral, sqrt(sum c_j^2) (its standard error per unit of white noise on B), the
    first and last sample, the stretch's span). A material at a fixed temperature dissipates energy over a cycle:
    the integral is >= 0 along its loop (anticlockwise in (H, B)). None with fewer than 4 samples or no reversal in
    the stretch."""
    p, B = np.asarray(path, dtype=float), np.asarray(B, dtype=float)
    idx = np.flatnonzero(np.asarray(ok, dtype=bool))
    if idx.size < 4:
        return None
    h, b = p[idx], B[idx]
    span = float(np.max(h) - np.min(h))
    m = _closing_sample(h, tol * span) if span > 0 else 0
    steps = np.sign(np.diff(h[: m + 1]))
    steps = steps[steps != 0]
    if m < 3 or steps.size == 0 or np.all(steps == steps[0]):
        return None
    h, b = h[: m + 1], b[: m + 1]
    c = loss_weights(h)
    return float(np.dot(c, b)), math.sqrt(float(np.dot(c, c))), int(idx[0]), int(idx[m]), float(np.max(h) - np.min(h))


def _trunc_factor(c: float) -> float:
    """E[x^2 | |x| < c] for a standard normal x."""
    phi = math.exp(-0.5 * c * c) / math.sqrt(2 * math.pi)
    return 1.0 - 2.0 * c * phi / math.erf(c / math.sqrt(2))


def noise_floor(signal, shape: PathShape, valid, clip: float) -> float | None:
    """White-noise sigma of ``signal`` (a residual, or B itself) from its second differences along each segment.

    d2[j] = r[j-1] - 2 r[j] + r[j+1] of white noise has sd sqrt(6) sigma; a smooth signal (a model misfit, or
    a loop's own curvature on a fine path) adds little to it. A MAD estimate first, then the RMS of the d2
    within ``clip`` MAD-sigmas (kinks, e.g. where a sensor starts to clip, drop out), corrected for the
    truncation. Triples that straddle a turning point or hold a sample not ``valid`` are not used. None with
    fewer than 4 triples (the caller decides what stands in), 0 when the MAD is 0.

    Why this one (the project had two): the MAD alone (fit/accuracy.py's former estimator) uses the median
    of |d2| only; its efficiency for normal noise is 37 %, so on the ~50 triples of a paper sweep its relative
    sd is ~0.17 against ~0.10 for the clipped RMS, with the same robustness to the occasional kink."""
    r = np.asarray(signal, dtype=float)
    j = shape.interior
    if valid is not None:  # None: every sample
        v = np.asarray(valid, dtype=bool)
        j = j[v[j - 1] & v[j] & v[j + 1]]
    d2 = r[j - 1] - 2 * r[j] + r[j + 1]
    if d2.size < 4:
        return None
    s0 = MAD_TO_SD * float(np.median(np.abs(d2)))
    if s0 == 0.0:
        return 0.0
    keep = np.abs(d2) <= clip * s0
    s = math.sqrt(float(np.mean(d2[keep] ** 2)) / _trunc_factor(clip))
    return s / math.sqrt(6.0)
