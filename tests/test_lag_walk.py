"""The lag search's walked grid (mrhyst.diagnose.everett._walk; issue 23's speed goal): the same lag as the whole
grid with fewer NNLS solves."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.diagnose import everett
from mrhyst.diagnose.settings import resolve_config
from mrhyst.diagnose.sweep import sweep_from_arrays
from mrhyst.model import effects as fx
from test_layers import path, preisach_loop

CFG = dict(resolve_config(None)["layers"], cv_folds=5)


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 4), st.integers(2, 8), st.integers(0, 2**31 - 1))
def test_the_walk_finds_the_grid_minimum_of_every_unimodal_curve(n_starts, n_grid, seed):
    """Each start's RSS along the grid falls to one minimum and rises after it (random depths, ties excluded): the
    walk's minimum is np.argmin's over the whole table, and it evaluates no start past the point after its minimum."""
    rng = np.random.default_rng(seed)
    table = np.empty((n_starts, n_grid))
    for s in range(n_starts):
        k = int(rng.integers(0, n_grid))
        table[s, : k + 1] = np.cumsum(rng.uniform(0.1, 1.0, k + 1))[::-1]
        table[s, k:] = table[s, k] + np.cumsum(np.r_[0.0, rng.uniform(0.1, 1.0, n_grid - k - 1)])
        table[s] += rng.uniform(0.0, 5.0)
    grid = list(np.arange(n_grid) * 0.1 + 0.05)
    asked = []

    def cost(g, s):
        asked.append((g, s))
        return float(table[s, grid.index(g)])

    c = everett._walk(cost, grid, list(range(n_starts)))
    s0, i0 = np.unravel_index(int(np.argmin(table)), table.shape)
    assert min(c, key=c.get) == (grid[i0], s0)
    for s in range(n_starts):
        assert sum(1 for _, t in asked if t == s) <= min(int(np.argmin(table[s])) + 2, n_grid)


def whole_grid(cost, grid, starts):
    return {(g, s): cost(g, s) for s in starts for g in grid}


@pytest.mark.parametrize("lag", [0.0, 0.25, 0.5])
def test_a_lag_search_walks_to_the_whole_grids_lag_with_fewer_solves(monkeypatch, lag):
    """A Preisach loop (a generator the base was not built from) through the registry's eddy filter at 0, 0.25 and
    0.5, 2e-4 T of noise: the lag, its statistics and its start state are the same numbers with the walked grid as
    with the whole grid, from fewer NNLS solves."""
    p = path()
    t = np.arange(1, p.size + 1, dtype=float)
    B = preisach_loop(p)
    if lag:
        B = fx.REGISTRY["eddy_lag"].signal(B[None, :], lag, t)[0]
    B = B + np.random.default_rng(3).normal(0.0, 2e-4, p.size)
    sw = sweep_from_arrays(p * 2.0, t, B, 1000.0)
    runs = {}
    for name, walk in (("walk", everett._walk), ("grid", whole_grid)):
        monkeypatch.setattr(everett, "_walk", walk)
        n, orig = [0], everett.nnls_gram  # every solve of the base's weights goes through it (or its fallback)

        def counted(*a, _orig=orig, _n=n, **k):
            _n[0] += 1
            return _orig(*a, **k)

        monkeypatch.setattr(everett, "nnls_gram", counted)
        base = everett.fit_base(sw, CFG)
        n[0] = 0
        runs[name] = (everett.increment(base, "eddy_lag", sw, CFG), n[0])
        monkeypatch.setattr(everett, "nnls_gram", orig)
    (w, nw), (g, ng) = runs["walk"], runs["grid"]
    assert w["size"] == g["size"] and w["start"] == g["start"]
    assert w["stats"]["bic"] == g["stats"]["bic"] and w["stats"]["cv_T"] == g["stats"]["cv_T"]
    assert nw < ng
    if lag:
        assert abs(w["size"] - lag) <= 0.1 * lag
