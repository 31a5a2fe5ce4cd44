"""The regions of a loop along any current path; its segments, turning points and cycles come from the path's
one :class:`mrhyst.data.shape.PathShape` (the functions here that take the current derive it, for callers
that hold nothing else; the diagnosis asks its sweep's shape).

A raw sweep is one row per applied current, in the order applied (ARCHITECTURE 4). Any piecewise-monotone
path is accepted: the paper's 0 -> max -> 0, bipolar major loops, repeated cycles, minor loops. A repeated
current (a dwell at the same value) belongs to the segment it was reached on.

Regions along the loop (the diagnosis's "where"):

- ``asc_low|mid|high`` / ``desc_low|mid|high``: ascending or descending current, by |I| / max|I| below
  ``low_frac``, below ``high_frac``, or above (the same labels for every branch of that direction);
- ``turning``: the samples at a reversal of the current (the extreme and its repeats);
- ``remanence``: a sample at zero current (|I| <= ``zero_tol_frac`` max|I|) reached after a turning point;
- ``coercive``: on a branch after a turning point, the sample nearest to each sign change of B
  (only when B is given).

For the paper's protocol these are exactly the eight regions the diagnosis always had.
"""

from __future__ import annotations

import numpy as np

from mrhyst.data.shape import PathShape, Segment, directions, path_shape  # noqa: F401  (re-exported)

REGIONS = ("asc_low", "asc_mid", "asc_high", "turning", "desc_high", "desc_mid", "desc_low", "remanence", "coercive")


def segments(current) -> list[Segment]:
    """The monotone segments of the path (:class:`mrhyst.data.shape.PathShape`'s)."""
    return list(path_shape(current).segments)


def turning_mask(current) -> np.ndarray:
    """True at every reversal of the current: the extreme sample and its repeats."""
    return np.array(path_shape(current).turning)


def reversals(current) -> int:
    return path_shape(current).reversals


def cycle_index(current) -> np.ndarray:
    """Which cycle each sample belongs to: a cycle starts each time the path turns from falling to rising
    (0 before the first such turn). For the paper's protocol every sample is in cycle 0; for two bipolar
    cycles 0 -> +I -> -I -> +I -> -I -> +I, the second rising turn starts cycle 1 ... so the same
    (current, direction) is met again one cycle later."""
    return np.array(path_shape(current).cycle)


def region_labels(current, B, regions) -> np.ndarray:
    """Region (REGIONS) of each sample of any piecewise-monotone path; see the module text. ``regions``: the
    config's diagnose.regions (low_frac, high_frac, zero_tol_frac; their defaults are the schema's)."""
    return labels_of(path_shape(current), B, regions)


def labels_of(shape: PathShape, B, regions) -> np.ndarray:
    """:func:`region_labels` of a path whose shape is known (:meth:`PathShape.regions`)."""
    rc = regions
    cur = shape.path
    imax = float(np.max(np.abs(cur)))
    if not imax > 0:
        raise ValueError("the current is zero throughout")
    frac = np.abs(cur) / imax
    side = np.where(shape.directions > 0, "asc", "desc")
    level = np.where(frac < rc["low_frac"], "low", np.where(frac < rc["high_frac"], "mid", "high"))
    lab = np.array([f"{s}_{lv}" for s, lv in zip(side, level)], dtype=object)
    turn = shape.turning
    lab[turn] = "turning"
    first_turn = int(np.flatnonzero(turn)[0]) if turn.any() else cur.size
    after = np.arange(cur.size) > first_turn
    lab[after & ~turn & (frac <= rc["zero_tol_frac"])] = "remanence"
    if B is not None:
        lab[coercive_points(shape, B) & ~turn] = "coercive"
    return lab


def coercive_points(shape: PathShape, B) -> np.ndarray:
    """True at the sample nearest to each sign change of B on a segment after the first turning point."""
    b = np.asarray(B, dtype=float)
    m = np.zeros(shape.n, dtype=bool)
    for s in shape.segments[1:]:
        seg = np.arange(s.start, s.stop + 1)
        sb = b[seg]
        for j in np.flatnonzero(np.sign(sb[1:]) * np.sign(sb[:-1]) < 0):
            m[seg[j] if abs(sb[j]) <= abs(sb[j + 1]) else seg[j + 1]] = True
    return m


def monotone_index(H, frac: float) -> np.ndarray:
    """Indices of the path as monotone legs between its real reversals: a reversal is real when H comes back by
    more than ``frac`` x max |H| (a densely sampled measured loop - the gadolinium loops, 5,000 samples at 3 Hz -
    jitters back and forth by a few A/m, hundreds of "reversals" of 2-3 samples each); within a leg only the
    samples that extend its running extreme are kept (ties too). Every index when the path has no jitter (as many
    legs either way), when ``frac`` is 0, or with fewer than 3 samples."""
    H = np.asarray(H, dtype=float)
    every = np.arange(H.size)
    if not frac > 0 or H.size < 3:
        return every
    tol = frac * float(np.max(np.abs(H)))
    away = np.flatnonzero(np.abs(H - H[0]) > tol)
    if away.size == 0:
        return every
    d = 1 if H[away[0]] > H[0] else -1  # the first leg's direction
    keep, ext = [0], H[0]
    for j in range(1, H.size):
        h = H[j]
        if (h - ext) * d < -tol:  # a real reversal: the extreme was the turning point
            d = -d
        if (h - ext) * d >= 0:
            keep.append(j)
            ext = h
    k = np.asarray(keep)
    if k.size == H.size or len(segments(H[k])) == len(segments(H)):  # no jitter: the path as read (its tips as
        return every  # measured; nothing dropped: no path derived)
    return k
