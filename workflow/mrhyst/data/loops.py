"""The shape of any current path: monotone segments, cycles, and the regions of a loop.

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

from dataclasses import dataclass

import numpy as np

REGIONS = ("asc_low", "asc_mid", "asc_high", "turning", "desc_high", "desc_mid", "desc_low", "remanence", "coercive")


@dataclass(frozen=True)
class Segment:
    """Samples start..stop (inclusive) on which the current moves in one direction (+1 up, -1 down)."""

    start: int
    stop: int
    direction: int

    @property
    def n(self) -> int:
        return self.stop - self.start + 1


def directions(current) -> np.ndarray:
    """+1 / -1 per sample: the direction of the change that reached it (a repeat keeps it; the first
    sample takes the direction of the first change). Raises ValueError when the current never changes."""
    cur = np.asarray(current, dtype=float)
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


def segments(current) -> list[Segment]:
    """The monotone segments of the path. Consecutive segments share their turning sample: segment k
    ends at the last sample before the current turns, and segment k+1 starts there."""
    dirs = directions(current)
    cuts = np.flatnonzero(dirs[1:] != dirs[:-1])  # the sample before each first sample of a new direction
    out, start = [], 0
    for c in cuts:
        out.append(Segment(start, int(c), int(dirs[c])))
        start = int(c)
    out.append(Segment(start, len(dirs) - 1, int(dirs[-1])))
    return out


def turning_mask(current) -> np.ndarray:
    """True at every reversal of the current: the extreme sample and its repeats."""
    cur = np.asarray(current, dtype=float)
    segs = segments(cur)
    m = np.zeros(cur.size, dtype=bool)
    for s in segs[:-1]:
        j = s.stop
        m[j] = True
        k = j - 1
        while k >= s.start and cur[k] == cur[j]:  # repeats before the turn
            m[k] = True
            k -= 1
    return m


def reversals(current) -> int:
    return len(segments(current)) - 1


def cycle_index(current) -> np.ndarray:
    """Which cycle each sample belongs to: a cycle starts each time the path turns from falling to rising
    (0 before the first such turn). For the paper's protocol every sample is in cycle 0; for two bipolar
    cycles 0 -> +I -> -I -> +I -> -I -> +I, the second rising turn starts cycle 1 ... so the same
    (current, direction) is met again one cycle later."""
    segs = segments(current)
    out = np.zeros(segs[-1].stop + 1, dtype=int)
    c = 0
    for prev, s in zip(segs[:-1], segs[1:]):
        if prev.direction < 0 and s.direction > 0:
            c += 1
        out[s.start + 1: s.stop + 1] = c
    return out


def region_labels(current, B, regions) -> np.ndarray:
    """Region (REGIONS) of each sample of any piecewise-monotone path; see the module text. ``regions``: the
    config's diagnose.regions (low_frac, high_frac, zero_tol_frac; their defaults are the schema's)."""
    rc = regions
    cur = np.asarray(current, dtype=float)
    imax = float(np.max(np.abs(cur)))
    if not imax > 0:
        raise ValueError("the current is zero throughout")
    frac = np.abs(cur) / imax
    dirs = directions(cur)
    side = np.where(dirs > 0, "asc", "desc")
    level = np.where(frac < rc["low_frac"], "low", np.where(frac < rc["high_frac"], "mid", "high"))
    lab = np.array([f"{s}_{lv}" for s, lv in zip(side, level)], dtype=object)
    turn = turning_mask(cur)
    lab[turn] = "turning"
    first_turn = int(np.flatnonzero(turn)[0]) if turn.any() else cur.size
    after = np.arange(cur.size) > first_turn
    lab[after & ~turn & (frac <= rc["zero_tol_frac"])] = "remanence"
    if B is not None:
        lab[coercive_points(cur, B) & ~turn] = "coercive"
    return lab


def coercive_points(current, B) -> np.ndarray:
    """True at the sample nearest to each sign change of B on a segment after the first turning point."""
    cur = np.asarray(current, dtype=float)
    b = np.asarray(B, dtype=float)
    m = np.zeros(cur.size, dtype=bool)
    for s in segments(cur)[1:]:
        seg = np.arange(s.start, s.stop + 1)
        sb = b[seg]
        for j in np.flatnonzero(np.sign(sb[1:]) * np.sign(sb[:-1]) < 0):
            m[seg[j] if abs(sb[j]) <= abs(sb[j + 1]) else seg[j + 1]] = True
    return m
