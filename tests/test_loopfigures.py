"""Loop figures a materials lab reads (issue 17, point 4): Hc, Br, loop area, max differential
permeability, on analytic loops whose figures are known in closed form."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.data import loopfigures as lf


def parallelogram(Hm, Hc, s, n=200):
    """Descending B = s (H + Hc), ascending B = s (H - Hc), vertical sides at +-Hm (a repeated H sample
    at each reversal): area 4 s Hc Hm, Hc, Br = s Hc, max slope s."""
    down = np.linspace(Hm, -Hm, n)
    up = np.linspace(-Hm, Hm, n)
    H = np.concatenate([down, up, [Hm]])
    B = np.concatenate([s * (down + Hc), s * (up - Hc), [s * (Hm + Hc)]])
    return H, B


@settings(max_examples=40, deadline=None)
@given(st.floats(10.0, 1e4), st.floats(0.05, 0.9), st.floats(1e-5, 1e-2))
def test_parallelogram_figures_are_exact(Hm, hc_frac, s):
    Hc = hc_frac * Hm
    H, B = parallelogram(Hm, Hc, s)
    f = lf.figures(H, B)
    assert f["Hc_A_per_m"] == pytest.approx(Hc, rel=1e-9)
    assert f["Br_T"] == pytest.approx(s * Hc, rel=1e-9)
    assert f["loop_area_J_per_m3"] == pytest.approx(4 * s * Hc * Hm, rel=1e-9)
    assert f["mu_diff_max_T_m_per_A"] == pytest.approx(s, rel=1e-9)
    assert f["mu_r_diff_max"] == pytest.approx(s / lf.MU0, rel=1e-9)


@settings(max_examples=40, deadline=None)
@given(st.floats(10.0, 1e4), st.floats(0.1, 2.0), st.floats(0.05, 1.4))
def test_ellipse_area_hc_br(Hm, Bm, phi):
    """H = Hm cos t, B = Bm cos(t - phi): area pi Hm Bm sin(phi), Hc = Hm sin(phi), Br = Bm sin(phi)."""
    t = np.linspace(0.0, 2 * np.pi, 4001)
    H, B = Hm * np.cos(t), Bm * np.cos(t - phi)
    f = lf.figures(H, B)
    assert f["cycle"] == [0, t.size - 1]
    assert f["loop_area_J_per_m3"] == pytest.approx(math.pi * Hm * Bm * math.sin(phi), rel=1e-5)
    assert f["Hc_A_per_m"] == pytest.approx(Hm * math.sin(phi), rel=1e-4)
    assert f["Br_T"] == pytest.approx(Bm * math.sin(phi), rel=1e-4)


def test_last_full_cycle_of_an_open_path():
    """0 -> +Hm -> -Hm -> +Hm: the cycle is from the first +Hm to the last; the virgin rise is left out."""
    Hm, Hc, s = 100.0, 20.0, 1e-3
    Hp, Bp = parallelogram(Hm, Hc, s)
    virgin = np.linspace(0.0, Hm, 50)[:-1]
    H = np.concatenate([virgin, Hp])
    B = np.concatenate([s * virgin * 0.5, Bp])
    f = lf.figures(H, B)
    assert f["cycle"][0] == virgin.size
    assert f["loop_area_J_per_m3"] == pytest.approx(4 * s * Hc * Hm, rel=1e-9)


def test_no_cycle_no_loop_figures():
    """The paper's 0 -> 2 A -> 0 sweep is not a loop: Hc, Br and area are None, not numbers from half a loop."""
    H = np.concatenate([np.linspace(0, 6000, 27), np.linspace(6000, 0, 27)[1:]])
    B = 1e-5 * H
    f = lf.figures(H, B)
    assert f["Hc_A_per_m"] is None and f["Br_T"] is None and f["loop_area_J_per_m3"] is None
    assert f["mu_diff_max_T_m_per_A"] == pytest.approx(1e-5)


def test_saturated_samples_are_left_out():
    H, B = parallelogram(100.0, 20.0, 1e-3)
    B2 = B.copy()
    B2[5] = 50.0  # a clipped, flagged sample
    valid = np.ones(B.size, bool)
    valid[5] = False
    assert lf.figures(H, B2, valid)["mu_diff_max_T_m_per_A"] == pytest.approx(1e-3, rel=1e-6)
