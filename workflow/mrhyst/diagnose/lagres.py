"""Does a lag on the flexible base survive a finer base? (issue 23: a held-out clean core named eddy_lag.)

The flexible base (:mod:`.everett`) places ``layers.grid`` switching fields per sign. On a sweep with more distinct
current levels than that, the base cannot be as steep as the core between two of its fields, and an eddy lag on top
(B delayed by a share of each step) makes a steep part steeper-looking where the base is too soft: a patch of the
base's resolution, not a time effect. Measured on bench/heldout_openworld.py (seed 0, bipolar, 27 levels per
branch): the clean control core ``control_hall_offset_03_core`` gains 31 BIC with a lag of 0.20 on the 10-field
base, 0.14 on 14 fields (gain 22), 0.094 on 16, 0.095 on 20 (gain 5); a real lag is a property of the sweep and
keeps its size however finely the base resolves the loop.

:func:`finer_sizes` is one more base of stability check (d) (:mod:`.layered`): the lag refitted (size only, on the
start state and H offset the judged increment chose) on a base with ``layers.fine_grid`` (16) fields per sign, at most
the data's own levels.
Nothing is added where the grid is at the data's resolution already (a stepped sweep with a few levels per branch:
every real-cores Hall sweep) or where the lag does not earn (it cannot be named; the refit is not paid for).
"""

from __future__ import annotations

import numpy as np

from mrhyst.diagnose import everett


def finer_grid(sw, G: int, fine: int) -> int | None:
    """``fine`` (config ``layers.fine_grid``), at most the number of midpoints between the sweep's distinct |H|
    levels; None when that is not finer than ``G`` (:func:`mrhyst.diagnose.everett.grid_levels` takes at most a
    midpoint per level)."""
    H = np.abs(sw.current[sw.valid])
    top = float(np.max(H)) if H.size else 0.0
    mids = max(np.unique(np.round(H / top, 9)).size - 1, 1) if top > 0 else 1  # levels equal to 1e-9 of the top
    G2 = min(int(fine), mids)
    return G2 if G2 > G else None


def finer_sizes(base: dict, effect: str, inc: dict, gain: float, sw, cfg: dict, margin: float) -> list:
    """[the lag on the finer base] for an eddy-lag increment ``inc`` ({"size", "start", "h0"}) that earns (BIC
    ``gain`` > ``margin``), else []. ``cfg``: the ``layers`` settings (grid, fine, grid_db_share, lag_grid,
    lag_refine)."""
    G2 = finer_grid(sw, int(cfg["grid"]), int(cfg["fine_grid"])) if effect == "eddy_lag" and gain > margin else None
    if G2 is None:
        return []
    key = (inc["start"], inc.get("h0", 0.0))
    ev = everett.Everett(sw, G2, key[0], int(cfg["fine"]), everett.first_sample(sw), float(cfg["grid_db_share"]),
                         key[1])
    fine = dict(base, starts={key: (ev, everett.Model(ev.A, sw.B - ev.fixed, ev.D))})
    return [float(everett.increment(fine, effect, sw, cfg, size_only=True)["size"])]
