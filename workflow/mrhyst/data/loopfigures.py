"""The figures a materials lab reads off a B(H) loop (issue 17, point 4).

From a sampled path (H, B) in the order measured, the same function for the data and for a fit's model
B on the same H, so the two can be set side by side:

* **Hc**, coercive field (A/m): |H| where B crosses 0 (linear interpolation between the two samples that
  straddle it), averaged over the crossings of the last full cycle (descending and ascending branch);
* **Br**, remanence (T): |B| where H crosses 0, averaged the same way;
* **loop area** (J/m^3 per cycle): |closed integral of H dB| over the last full cycle (trapezoids, the
  cycle closed by a straight segment from its end back to its start); this is the hysteresis energy loss
  per cycle and unit volume;
* **mu_diff_max**: the largest chord slope dB/dH between consecutive samples of one sweep direction (T m/A),
  and ``mu_r_diff_max`` = that / mu0.

A *full cycle* is the part of the path from one turning point (or end point) at one field extreme to the
next at the same extreme, through an extreme of the other sign (e.g. +Hmax -> -Hmax -> +Hmax). A path
without one (the paper's 0 -> 2 A -> 0 sweep) has no loop area, Hc or Br: those are None, never a
number made up from half a loop.
A repeated sample (dH = 0, e.g. at a reversal) is allowed: it adds its dB to the area at constant H.
"""

from __future__ import annotations

import numpy as np

from mrhyst.data.shape import PathShape, path_shape
from mrhyst.model.ja import MU0


def turning_points(H) -> list[int]:
    """Indices where the sweep direction changes (the extreme itself: the last sample before the new
    direction's run), plus both ends (:attr:`mrhyst.data.shape.PathShape.turning_points`)."""
    H = np.asarray(H, dtype=float)
    try:
        return path_shape(H).turning_points
    except ValueError:  # a path that never changes: only its ends
        return [0] if H.size < 2 else [0, H.size - 1]


def last_cycle(H, shape: PathShape | None = None) -> tuple[int, int] | None:
    """(i0, i1) of the last full cycle: turning points two apart, at the same field extreme; else None
    (:meth:`mrhyst.data.shape.PathShape.last_cycle`; ``shape``: H's, when known)."""
    if shape is None:
        try:
            shape = path_shape(H)
        except ValueError:
            return None
    return shape.last_cycle()


def _crossings(x, y) -> np.ndarray:
    """y interpolated where x crosses 0 between consecutive samples (a sample exactly at 0 counts once)."""
    out = []
    for j in range(x.size - 1):
        x0, x1 = x[j], x[j + 1]
        if x0 == 0.0:
            out.append(y[j])
        elif x0 * x1 < 0:
            out.append(y[j] + (0.0 - x0) / (x1 - x0) * (y[j + 1] - y[j]))
    return np.asarray(out, dtype=float)


def loop_area(H, B) -> float:
    """|closed integral of H dB| over the path (closed by the segment from its end to its start)."""
    H = np.append(np.asarray(H, dtype=float), H[0])
    B = np.append(np.asarray(B, dtype=float), B[0])
    return float(abs(np.sum(0.5 * (H[1:] + H[:-1]) * np.diff(B))))


def mu_diff_max(H, B) -> float | None:
    """Largest dB/dH between consecutive samples with dH != 0 (T m/A); None without such a pair."""
    dH = np.diff(np.asarray(H, dtype=float))
    dB = np.diff(np.asarray(B, dtype=float))
    span = float(np.ptp(H)) if len(H) else 0.0
    m = np.abs(dH) > 1e-9 * max(span, 1e-300)
    if not m.any():
        return None
    return float(np.max(dB[m] / dH[m]))


def figures(H, B, valid=None, shape: PathShape | None = None) -> dict:
    """{"Hc_A_per_m", "Br_T", "loop_area_J_per_m3", "mu_diff_max_T_m_per_A", "mu_r_diff_max", "cycle"}
    of one sampled path (see the module doc); samples not ``valid`` (saturated) are left out. ``shape``: the
    shape of the path figured (H without the samples left out), when known."""
    H = np.asarray(H, dtype=float)
    B = np.asarray(B, dtype=float)
    if valid is not None:
        v = np.asarray(valid, bool)
        H, B = H[v], B[v]
    cyc = last_cycle(H, shape)
    mu = mu_diff_max(H, B)
    out = {"Hc_A_per_m": None, "Br_T": None, "loop_area_J_per_m3": None, "mu_diff_max_T_m_per_A": mu,
           "mu_r_diff_max": None if mu is None else mu / MU0, "cycle": None}
    if cyc is None:
        return out
    i0, i1 = cyc
    h, b = H[i0 : i1 + 1], B[i0 : i1 + 1]
    hc = _crossings(b, h)
    br = _crossings(h, b)
    out["cycle"] = [int(i0), int(i1)]
    out["Hc_A_per_m"] = float(np.mean(np.abs(hc))) if hc.size else None
    out["Br_T"] = float(np.mean(np.abs(br))) if br.size else None
    out["loop_area_J_per_m3"] = loop_area(h, b)
    return out


def side_by_side(H, B_data, B_model, valid=None, shape: PathShape | None = None) -> dict:
    """{"data": figures(H, B_data), "fit": figures(H, B_model) or None}: one path, its shape derived once
    (``shape``: H's, when known; used when no sample is left out)."""
    Hf = np.asarray(H, dtype=float) if valid is None else np.asarray(H, dtype=float)[np.asarray(valid, bool)]
    sh = shape if shape is not None and Hf.size == np.size(H) else None
    try:
        sh = path_shape(Hf) if sh is None else sh
    except ValueError:
        sh = None
    return {"data": figures(H, B_data, valid, sh),
            "fit": None if B_model is None else figures(H, B_model, valid, sh)}
