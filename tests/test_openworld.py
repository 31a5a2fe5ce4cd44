"""Out-of-vocabulary mechanisms (mrhyst.blind.openworld): the physics each one claims, and its independence of
the diagnosis's forward functions."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst import rig
from mrhyst.blind import openworld
from mrhyst.model import ja

MU0 = 4e-7 * math.pi
TRUTH = {"Ms": 1.4e6, "a": 3.0e4, "alpha": 3.0e-3, "c": 0.4, "k": 2.0e4}


def _path(i_max=2.0, n=27):
    return ja.paper_current_path(i_max, n)


# ---------------------------------------------------------------- Preisach
def test_preisach_starts_demagnetised_and_saturates_at_ms():
    H = np.linspace(0.0, 2.0e6, 200)
    M = openworld.preisach_m(H, 1.0e6, 1.0e4, 0.5, 5.0e3)
    assert M[0] == pytest.approx(0.0, abs=1e-6)
    assert M[-1] == pytest.approx(1.0e6, rel=1e-6)
    assert np.all(np.diff(M) >= -1e-9)  # rising field: every hysteron can only switch up


def test_preisach_major_loop_closes_and_is_odd():
    """A major loop (from saturation to saturation) closes on itself, and its descending branch is the ascending
    one mirrored: M_down(H) = -M_up(-H) (the distribution is symmetric in hu)."""
    h = np.linspace(-2.0e5, 2.0e5, 81)
    path = np.concatenate([np.linspace(0, 2.0e5, 41), h[::-1][1:], h[1:], h[::-1][1:]])
    M = openworld.preisach_m(path, 1.0e6, 2.0e4, 0.4, 8.0e3)
    down1, up, down2 = M[40:120], M[120:200], M[200:280]
    assert np.allclose(down1, down2, atol=1e-6 * 1e6)  # closed
    assert np.allclose(up, -down1, atol=1e-6 * 1e6)  # up[m] sits at H = h[m+1], down1[m] at -h[m+1]


def test_preisach_return_point_memory():
    """The Preisach hallmark: after a minor excursion H1 -> H2 -> H1 the state is the one left at H1, and the
    branch continues as if the excursion had not happened (wiping-out property)."""
    direct = np.array([0.0, 3.0e4, -1.0e4, 2.5e4])
    excursion = np.array([0.0, 3.0e4, -1.0e4, 1.0e4, 0.0, 1.0e4, 2.5e4])
    a = openworld.preisach_m(direct, 1.0e6, 1.5e4, 0.5, 6.0e3)
    b = openworld.preisach_m(excursion, 1.0e6, 1.5e4, 0.5, 6.0e3)
    assert b[-1] == pytest.approx(a[-1], rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-3.0e5, 3.0e5), min_size=2, max_size=30), st.floats(1.0e3, 5.0e4), st.floats(0.1, 1.0))
def test_preisach_stays_within_ms_and_follows_the_field(H, hc, sd):
    """Any path: |M| <= Ms, and M moves with the field on every step (never against it)."""
    H = np.array(H)
    M = openworld.preisach_m(H, 1.0e6, hc, sd, 0.5 * hc)
    assert np.all(np.abs(M) <= 1.0e6 * (1 + 1e-12))
    dH, dM = np.diff(H), np.diff(M)
    assert np.all(dM * np.sign(dH) >= -1e-6)


# ---------------------------------------------------------------- the other mechanisms
def _field(name, mp, nle=3000.0, dwell=0.1):
    I = _path()
    t = rig.sample_times(I.size, dwell)
    B, core, ok = openworld.field(name, mp, TRUTH, I, t, nle)
    assert ok
    return I * nle, t, B, core


def test_two_phase_adds_a_bounded_second_magnetisation():
    H, _, B, core = _field("two_phase", {"Ms2": 2.0e5, "hc": 3.0e3, "hc_logsd": 0.3, "hu_sd": 1.0e3})
    M2 = (B - core) / MU0
    assert M2[0] == pytest.approx(0.0, abs=1e-6)
    assert np.all(np.abs(M2) <= 2.0e5) and np.max(np.abs(M2)) > 1.0e3
    assert M2[-1] > 0  # the particle phase keeps a remanence of its own at 0 A


def test_hall_laws_scale_the_core_as_stated():
    H, t, B, core = _field("hall_nonlinear", {"gain_error_at_peak": 0.03})
    j = int(np.argmax(np.abs(core)))
    assert B[j] / core[j] == pytest.approx(1.03, rel=1e-12)
    assert B[0] == core[0] == 0.0
    _, t, B, core = _field("hall_gain_drift", {"gain_drift": -0.05, "tau_over_sweep": 0.7})
    gain = B[1:] / core[1:]
    assert gain[-1] == pytest.approx(0.95, rel=1e-12) and B[0] == pytest.approx(core[0])
    assert np.all(np.diff(gain) <= 1e-15)  # the gain moves one way as the coil heats


def test_leakage_adds_a_linear_field_term():
    H, _, B, core = _field("leakage", {"kappa": 1.5})
    assert np.allclose(B - core, MU0 * 1.5 * H, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("name", openworld.MECHANISMS)
def test_draws_stay_in_their_ranges(name):
    rng = np.random.default_rng(3)
    r = openworld.DEFAULT_RANGES[name]
    for _ in range(50):
        mp = openworld.draw(name, rng, TRUTH)
        for key, (lo, hi) in r.items():
            if key in mp:
                assert lo <= abs(mp[key]) <= hi, (key, mp[key])
    with pytest.raises(ValueError, match="unknown open-world mechanism"):
        openworld.draw("gremlins", rng, TRUTH)


def test_preisach_core_does_not_touch_the_diagnosis_forward(monkeypatch):
    """A Preisach core is computed without mrhyst.model.effects or mrhyst.model.ja's integrator (its own magnetics)."""
    from mrhyst.model import effects

    def boom(*a, **k):
        raise AssertionError("shared forward function called")

    monkeypatch.setattr(effects, "forward", boom)
    monkeypatch.setattr(ja, "simulate", boom)
    monkeypatch.setattr(ja, "simulate_h", boom)
    mp = openworld.draw("preisach", np.random.default_rng(0), TRUTH)
    I = _path()
    B, _, ok = openworld.field("preisach", mp, None, I, rig.sample_times(I.size, 0.1), 3000.0)
    assert ok and np.max(B) > 0


def test_sense_is_the_rig_chain_and_deterministic():
    I = _path()
    t = rig.sample_times(I.size, 0.1)
    B = 0.05 * np.sin(np.linspace(0, 3, I.size))
    v1, _, _, side = openworld.sense(B, t, I, noise_sigma_T=0.0, seed=1, n_over_le=3000.0, dwell_s=0.1,
                                     sensitivity_V_per_T=5.0)
    back = (v1["hall1"] - side["sensors"]["hall1"]["quiescent_V"]) / 5.0
    assert np.max(np.abs(back - B)) <= rig.adc_lsb() / 5.0  # within one ADC code
    a = openworld.sense(B, t, I, noise_sigma_T=1.5e-4, seed=7, n_over_le=3000.0, dwell_s=0.1)[0]["hall1"]
    b = openworld.sense(B, t, I, noise_sigma_T=1.5e-4, seed=7, n_over_le=3000.0, dwell_s=0.1)[0]["hall1"]
    assert np.array_equal(a, b)
    assert sorted(side) == ["coil_turns_per_m", "dwell_s", "sensors", "supply_V"]
