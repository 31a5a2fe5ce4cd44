"""A lag on the flexible base that only patches the base's resolution is not named (issue 23: the held-out clean
control core named eddy_lag on a bipolar sweep). Expectations from loops written here: tanh branches (a rate-
independent core J-A does not fit, clean or behind a first-order lag of known size), stepped bipolar paths."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst import diagnose as dg
from mrhyst.diagnose.lagres import finer_grid

FAST = {"n_random": 300, "n_random_deep": 100, "n_starts": 2, "max_iter": 80, "budget_seeds": 1}
SENSOR = {"sensitivity_V_per_T": 5.0, "quiescent_V": 1.65, "supply_V": 3.3}
DWELL = 0.06


def path(n):
    """0 -> 2 -> -2 -> 2 A in n steps per 2 A (n + 1 levels per half-branch)."""
    full = np.linspace(2.0, -2.0, 2 * n + 1)
    return np.r_[np.linspace(0.0, 2.0, n + 1), full[1:], full[-2::-1]]


def tanh_core(cur, hc, w, bs=0.2, chi=0.01):
    """B of a core whose branches are bs tanh((I -+ hc) / w) + chi I (+hc descending); rate-independent."""
    out, prev, br = [], 0.0, -1.0
    for i in cur:
        br = 1.0 if i < prev else (-1.0 if i > prev else br)
        out.append(bs * math.tanh((i + br * hc) / w) + chi * i)
        prev = i
    return np.array(out)


def lagged(b, lag):
    """A first-order lag per reading, written out: B_obs[j] = B[j] + lag (B_obs[j-1] - B[j])."""
    out = np.array(b, dtype=float)
    for j in range(1, out.size):
        out[j] = b[j] + lag * (out[j - 1] - b[j])
    return out


def sweep_of(cur, b, seed=3):
    b = b + 2.5e-4 * np.random.default_rng(seed).standard_normal(cur.size)
    return dg.sweep_from_arrays(cur, DWELL * np.arange(1, cur.size + 1), b, 1000.0, dwell_s=DWELL, sensor_info=SENSOR)


@pytest.mark.parametrize("hc, w", [(0.5, 0.15), (0.6, 0.25)])
def test_a_clean_rate_independent_core_on_a_fine_bipolar_sweep_is_not_named_a_lag(hc, w):
    """27 levels per branch, a 10-field base: a lag of 0.38-0.52 earned 80-100 BIC on it (named on main); on the
    16-field base it is less than half of that. Not a measurement fault: at most the declared confound."""
    cur = path(26)
    d = dg.diagnose(sweep_of(cur, tanh_core(cur, hc, w)), FAST)
    assert d["effect"] != "eddy_lag"
    inc = d["layers"]["evidence"]["increments"]["eddy_lag"]
    assert min(inc["sizes_other_bases"]) < 0.5 * inc["size"]  # the finer base's lag
    if "eddy_lag" in d["ambiguous_with"]:
        assert "long_dwell" in {c["separated_by"] for c in d["confounds"]}


def test_a_real_lag_on_a_soft_core_is_named_with_its_size_or_left_as_the_declared_confound():
    """A 0.2 lag on a soft tanh core: the 10-field base gave 0.54 (2.7x the truth, named on main); the finer base
    gives ~0.19. Named, its size within 25 %; otherwise in ambiguous_with, a longer dwell to separate it."""
    cur = path(26)
    d = dg.diagnose(sweep_of(cur, lagged(tanh_core(cur, 0.6, 0.25), 0.2)), FAST)
    if d["effect"] == "eddy_lag":
        assert abs(d["effect_size"]["value"] - 0.2) <= 0.25 * 0.2
    else:
        assert "eddy_lag" in d["ambiguous_with"]
        assert "long_dwell" in {c["separated_by"] for c in d["confounds"]}


@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 40), G=st.integers(2, 16), F=st.integers(2, 32))
def test_the_finer_grid_exists_only_where_the_sweep_has_more_levels_than_the_base(n, G, F):
    """A stepped sweep with n + 1 levels per half-branch has n midpoints between its |I| levels; a base of G
    fields per sign is refined to min(F, n), and not at all when that is no finer (every real-cores Hall sweep)."""
    cur = path(n)
    sw = dg.sweep_from_arrays(cur, DWELL * np.arange(1, cur.size + 1), tanh_core(cur, 0.5, 0.2), 1000.0,
                              dwell_s=DWELL)
    got = finer_grid(sw, G, F)
    assert got == (min(F, n) if min(F, n) > G else None)
