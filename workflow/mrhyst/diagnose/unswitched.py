"""Is every part of the core switched by the sweep? A model-free test of the loop next to its turning points
(issue 23: a Hall offset against a remanent start on a bipolar sweep of a core that is not Jiles-Atherton).

A bipolar sweep tells a Hall offset from a remanent start on a J-A core because J-A's irreversible
magnetisation relaxes towards the anhysteretic curve on every branch: the first reversal wipes any start state.
A real core is a population of parts that switch at their own fields (a Preisach model's hysterons, the
particles of a Stoner-Wohlfarth ensemble, the hard phase of a two-phase core). A part whose switching fields lie
beyond the sweep's amplitude never switches: its remanence stays what it was before the sweep, a constant B in
the sensor, exactly a Hall offset on every sweep up to that amplitude, bipolar or repeated. Only a sweep that
switches it (to an amplitude that saturates the core, or an AC demagnetisation from there) tells the two apart.

Where the loop closes before its turning points (the branches to and from the largest |current| meet within
noise), the switching is complete below that current and no part is left unswitched: a bipolar sweep wipes a
remanent start. Where the loop is still open at its turning points, switching goes on at the largest current
and parts beyond it may hold a remanence. :func:`open_at_tips` measures that opening: at every turning point at
the largest |current|, the departing branch minus the approaching branch at the same currents within ``tip_frac``
of it (the turning reading left out), signed so that a hysteretic opening is positive; its mean over the pairs,
against its standard error sqrt(2) sigma / sqrt(pairs).

Pure: arrays in, a record out; no fitting.
"""

from __future__ import annotations

import math

import numpy as np


def _turns(cur: np.ndarray, ok: np.ndarray, imax: float) -> list[int]:
    """Readings at the largest |current| where the current turns back (a valid reading with a neighbour each side)."""
    tol = 1e-9 * imax
    return [j for j in range(1, cur.size - 1)
            if ok[j] and abs(abs(cur[j]) - imax) <= tol and (cur[j] - cur[j - 1]) * (cur[j + 1] - cur[j]) <= 0]


def tip_pairs(current, B, valid, tip_frac: float) -> np.ndarray:
    """The signed openings (T) next to every turning point at the largest |current|: sign(I_turn) x (B departing
    - B approaching) at equal currents within ``tip_frac`` x I_max of the turn, walking out from it while both
    sides stay on their branch."""
    cur, B = np.asarray(current, dtype=float), np.asarray(B, dtype=float)
    ok = np.ones(cur.size, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    imax = float(np.max(np.abs(cur))) if cur.size else 0.0
    if not imax > 0:
        return np.empty(0)
    tol, out = 1e-9 * imax, []
    for j in _turns(cur, ok, imax):
        s = math.copysign(1.0, cur[j])
        k = 1
        while (j - k >= 0 and j + k < cur.size and abs(cur[j - k]) >= (1.0 - tip_frac) * imax
               and abs(cur[j + 1 - k]) >= abs(cur[j - k]) - tol and abs(cur[j + k - 1]) >= abs(cur[j + k]) - tol):
            if ok[j - k] and ok[j + k] and abs(cur[j - k] - cur[j + k]) <= tol:
                out.append(s * (B[j + k] - B[j - k]))
            k += 1
    return np.asarray(out, dtype=float)


def open_at_tips(current, B, sigma: float, valid=None, *, tip_frac: float, min_sigma: float) -> dict | None:
    """``{"open", "opening_T", "sigma", "pairs"}``: is the loop open next to its turning points (mean opening >=
    ``min_sigma`` standard errors)? None when the sweep has no pair of readings to compare (no turn at the
    largest current, or currents that do not repeat)."""
    d = tip_pairs(current, B, valid, tip_frac)
    if d.size == 0 or not sigma > 0:
        return None
    mean = float(np.mean(d))
    z = mean / (math.sqrt(2.0) * sigma / math.sqrt(d.size))
    return {"open": bool(z >= min_sigma), "opening_T": mean, "sigma": float(z), "pairs": int(d.size)}


def of_sweep(sweep, sigma: float, settings: dict) -> dict | None:
    """:func:`open_at_tips` of a diagnosis Sweep's measured samples (a conditioning prefix left out); ``settings``:
    config ``diagnose.signatures`` (``tip_frac``, ``min_sigma``). None for a B(H) loop (no start state to judge)."""
    if sweep.kind != "hall":
        return None
    a = int(sweep.start)
    return open_at_tips(sweep.current[a:], sweep.B[a:], sigma, sweep.valid[a:], tip_frac=float(settings["tip_frac"]),
                        min_sigma=float(settings["min_sigma"]))
