"""The flexible base's resolution, chosen once per sweep from the sweep (issue 23).

The flexible base (:mod:`.everett`) places G switching fields per sign between the data's distinct |H| levels. Too
few for the sweep, and the base's own misfit is read as a measurement effect or hides one: measured, a held-out clean
control core (bipolar, 27 levels per branch) gained 31 BIC with a lag of 0.20 on 10 fields, 0.094 on 16 (a lag patching
the base's resolution); the Hiperco 50 B(H) loop (117 level midpoints) keeps 25 mT on 10 fields, more than a 1 % B
offset (19 mT), 14-19 mT on 16 (the offset then earns 76 BIC). The last session judged those two cases again on a finer
base (``finebase``, ``lagres``); this module replaces both with one choice that every increment is judged on:

* the rungs: ``layers.grid`` (the coarsest) and ``layers.grid_ladder`` (finer ones), each capped at the sweep's own
  number of level midpoints (a stepped sweep with 6 levels per branch gets 5 fields whatever the ladder says: a field
  between two readings' levels is all the data can place), duplicates dropped;
* the rung with the lowest BIC of the bare base (no measurement effect) on its best start state and H offset, at
  the best of ``layers.lambdas``, the effective degrees of freedom (the hat matrix's trace, plus the start state's
  and H offset's choices) as its parameters (at the middle lam alone the Hiperco loop's 16-field base lost to the
  10-field one: -733 against -738; its smallest lam gives it -802 against -770). A finer base is taken only where
  the data pay for its weights; the choice never sees a measurement effect, so it cannot be tuned to name one.

Where the plain rule's verdict is one the layers do not replace (a measurement effect, or none; not one of
:data:`mrhyst.diagnose.layerfit.MATERIAL_VERDICTS`), the layers give the JSON's evidence alone and the budget is the
plain rule's; there the ladder is not climbed (the coarsest rung, ``allowed`` and ``climbed`` false): on the blind
benchmark's 53-sample sweeps (26 level midpoints) a 16-field base costs ~2x the whole diagnosis (measured, case_007:
0.66 -> 1.50 CPU s) for evidence no verdict reads.

``choose(sw, lcfg, climb) -> (G, record, models)``: the grid, the evidence record
(``layers.evidence.everett.resolution``: {"levels", "rungs", "bic", "climbed", "allowed"}; ``allowed``: the plain
verdict let the ladder be climbed; ``climbed``: more than one rung was left after the cap and their BICs compared,
so a sweep with fewer level midpoints than ``layers.grid`` has ``allowed`` true, ``climbed`` false, ``bic`` null)
and the chosen rung's designs
(:func:`mrhyst.diagnose.everett.base_models`) for :func:`mrhyst.diagnose.everett.fit_base` to reuse.
"""

from __future__ import annotations

import math

import numpy as np

from mrhyst.diagnose import everett


def level_midpoints(sw) -> int:
    """The number of midpoints between the sweep's distinct |H| levels (levels equal to 1e-9 of the top are one)."""
    H = np.abs(sw.current[sw.valid])
    top = float(np.max(H)) if H.size else 0.0
    return max(np.unique(np.round(H / top, 9)).size - 1, 1) if top > 0 else 1


def rungs(levels: int, grid: int, ladder) -> list:
    """The ladder's grids capped at the sweep's ``levels`` (level midpoints), distinct, coarsest first."""
    return sorted({min(int(g), int(levels)) for g in (grid, *ladder)})


def bare_bic(sw, lcfg: dict, G: int) -> tuple:
    """(BIC, designs) of the bare base on ``G`` fields: its start state and H offset by the RSS at the middle lam (as
    :func:`mrhyst.diagnose.everett.fit_base`), the lowest BIC over ``layers.lambdas`` (the module docstring)."""
    c = dict(lcfg, grid=int(G))
    mods = everett.base_models(sw, c)
    rows = sw.valid.copy()
    lams = everett.lam_grid(c)
    mid = lams[len(lams) // 2]
    key = min(mods, key=lambda s: everett.rss_of((mods[s][1].fit(rows, mid)[0] - mods[s][1].y)[rows]))
    m, n, free = mods[key][1], int(rows.sum()), everett.free_choices(mods)
    out = []
    for lam in lams:
        pred, edf = m.fit(rows, lam, want_edf=True)
        rss = everett.rss_of((pred - m.y)[rows])
        out.append(n * math.log(max(rss, 1e-30) / n) + (edf + free) * math.log(n))
    return min(out), mods


def choose(sw, lcfg: dict, climb: bool = True) -> tuple:
    """(G, record, designs): see the module docstring. One rung: no fit to compare, its designs built by fit_base.
    ``climb`` False: the coarsest rung alone (the plain rule's verdict is one the layers do not replace)."""
    lv = level_midpoints(sw)
    rs = rungs(lv, int(lcfg["grid"]), lcfg["grid_ladder"] if climb else ())
    if len(rs) == 1:  # nothing to compare: not climbed, whether or not it was allowed
        return rs[0], {"levels": lv, "rungs": rs, "bic": None, "climbed": False, "allowed": bool(climb)}, None
    fits = {G: bare_bic(sw, lcfg, G) for G in rs}
    G = min(rs, key=lambda g: fits[g][0])
    rec = {"levels": lv, "rungs": rs, "bic": {str(g): round(fits[g][0], 3) for g in rs}, "climbed": True,
           "allowed": True}
    return G, rec, fits[G][1]
