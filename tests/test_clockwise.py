"""A loop that runs clockwise (signature ``clockwise``): the integral of H dB along a path that returns to its field is
a material's dissipated energy, positive for any material at a fixed temperature; negative, B and the current are
read out of step or out of order, or B moves in time by more than the loop opens. The signature fires on the real
loops of other labs and on rig sweeps traversed backwards, never on them as measured or with any vocabulary effect
a material-like size; its standard error is the integral's own spread under white noise; a material verdict of
such a sweep is withdrawn, a measurement verdict stands (testable without fitting)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst import diagnose as dg
from mrhyst.data import shape as shp
from mrhyst.diagnose import polarity
from mrhyst.diagnose import signatures as sg
from mrhyst.report.summary import diagnosis_summary
from test_diagnose_signatures import FAST, write
from test_signatures import REAL, SET, observe, path, real_loop

MS = float(SET["min_sigma"])


def fires(cur, B, sigma):
    return sg.clockwise(cur, B, sigma, np.ones(B.size, dtype=bool), MS)


@pytest.mark.parametrize("loop", REAL, ids=lambda x: f"{x[0].parent.name}-{x[1]}")
def test_real_loops_run_anticlockwise_and_backwards_clockwise(loop):
    H, B = real_loop(*loop)
    assert fires(H, B, sigma=1e-6) == []  # as measured: not even at a noise of 1 uT
    got = fires(H, B[::-1], sigma=3e-4)  # B read in reverse order against H
    assert len(got) == 1 and got[0].size_T < 0 and got[0].sigma > 50


# every path from 0 A: a J-A core "demagnetised" at -2 A (M = 0 there) is no core's state, and closing a path at that
# field counts the energy of that jump (a real core at -I_max is magnetised before its first reading)
@pytest.mark.parametrize("tips", [(0.0, 2.0, 0.0), (0.0, 2.0, -2.0, 2.0), (0.0, -2.0, 2.0, -2.0), (0.0, -2.0, 0.0)])
@pytest.mark.parametrize("effect", [None, ("eddy_lag", {"lag": 0.6}), ("hall_offset", {"offset_T": 0.02}),
                                    ("sensor_saturation", {"B_sat_T": 0.05}), ("air_gap", {"Nd": 2e-3}),
                                    ("remanent_start", {"M0_A_per_m": -2e4})])
def test_rig_sweeps_with_any_effect_run_anticlockwise(tips, effect):
    cur = path(*tips, step=2.0 / 26)
    _, B = observe(cur, [effect] if effect else [])
    assert fires(cur, B, sigma=1e-6) == []
    got = fires(cur, B[::-1], sigma=1e-4)
    assert [s.kind for s in got] == ["clockwise"] and got[0].samples[0] == 0


def test_the_size_is_the_mean_opening_and_the_sigma_the_integrals_own_spread():
    """A rectangle in (I, B) run clockwise: B falls by d between 1 and 0.9 A (at 0.95 A by trapezoids), an opening of
    -0.95 d over the unit span; with white noise the integral's spread over
    seeds is the standard error the signature divides by (so 5 sigma is 5 sigma)."""
    cur = np.concatenate([np.linspace(0, 1, 11), np.linspace(1, 0, 11)[1:]])
    d, sigma = 2e-3, 1e-4
    B = np.where(np.arange(cur.size) <= 10, d, 0.0)  # high on the way up, low on the way down: clockwise
    got = fires(cur, B, sigma)
    assert got[0].size_T == pytest.approx(-0.95 * d, rel=1e-12)
    c = shp.loss_weights(cur)
    rng = np.random.default_rng(7)
    w = [float(np.dot(c, sigma * rng.standard_normal(cur.size))) for _ in range(4000)]
    assert np.std(w) == pytest.approx(sigma * np.sqrt(np.dot(c, c)), rel=0.05)
    assert got[0].sigma == pytest.approx(-float(np.dot(c, B)) / (sigma * np.sqrt(np.dot(c, c))), rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(6, 80))
def test_white_noise_on_a_loop_without_opening_never_fires(seed, n):
    cur = np.concatenate([np.linspace(0, 2, n), np.linspace(2, -2, 2 * n)[1:], np.linspace(-2, 0, n)[1:]])
    B = 0.05 * np.tanh(cur) + 1e-4 * np.random.default_rng(seed).standard_normal(cur.size)
    assert fires(cur, B, 1e-4) == []


@settings(max_examples=60, deadline=None)
@given(steep=st.floats(0.2, 30.0), peak=st.floats(0.01, 2.0), n=st.integers(6, 60), shift=st.floats(-0.5, 0.5))
def test_a_curve_without_opening_that_ends_past_its_first_field_never_fires(steep, peak, n, shift):
    """A single-valued B(I) on 0 -> 2 -> -2 -> 2 A: the stretch tested ends at the last reading within 2 % of the
    span from 0 A, one step past it (2 / (n - 1) A <= 0.08 A); closed by a straight step back to the first reading,
    a curve with no opening encloses nothing. Closed at the last reading's current instead, it enclosed a triangle:
    a steep anhysteretic core (held-out oov_leakage_02, 0.26 T peak) ran "clockwise" at 5.6 sigma without noise."""
    up = np.linspace(0.0, 2.0, n)
    cur = np.concatenate([up, up[::-1][1:], -up[1:], (-up[::-1])[1:], up[1:]])
    B = peak * np.tanh(steep * (cur - shift * 2.0 / (n - 1))) + 1e-3 * peak * cur
    assert fires(cur, B, sigma=1e-9 * peak) == []


def test_a_straight_closing_step_encloses_nothing_where_the_path_never_comes_back_exactly():
    """0 -> 2 -> -2 -> 0.05 A with no reading at 0 A on the way back: B linear in I (no opening) closes to 0."""
    cur = np.concatenate([np.linspace(0.0, 2.0, 21), np.linspace(2.0, -2.0, 41)[1:], np.linspace(-1.95, 0.05, 21)])
    w, se, first, last, span = shp.closed_loss(cur, 0.1 * cur, np.ones(cur.size, dtype=bool))
    assert first == 0 and last >= cur.size - 2 and abs(w) < 1e-14 * se


def test_one_branch_or_a_path_that_never_returns_is_not_tested():
    up = np.linspace(0, 2, 27)
    assert fires(up, -np.tanh(up), 1e-4) == []
    assert fires(np.concatenate([up, up[::-1][1:14]]), np.zeros(40), 1e-4) == []  # 0 -> 2 -> 1: no return to 0


def test_a_reversed_sign_is_said_once():
    cur = path(0.0, 2.0, 0.0, step=2.0 / 26)
    _, B = observe(cur)
    got = sg.find(cur, -B, 1e-4, SET, n_over_le=3000.0)
    assert "reversed_sign" in [s.kind for s in got] and "clockwise" not in [s.kind for s in got]


def _out(effect, kind="clockwise"):
    sig = sg.Signature(kind, -0.02, 300.0, (0, 52)).to_dict()
    return {"effect": effect, "ambiguous_with": ["hall_offset"], "ambiguity_reason": "x", "effect_size": None,
            "verdict": f"{effect}: ...", "signatures": [sig],
            "next_measurement": {"protocol": "bipolar", "separation_sigma": 1.9, "why": "."}}


@pytest.mark.parametrize("effect", ["model_form", "none"])
def test_a_material_verdict_of_a_clockwise_loop_is_withdrawn_without_fitting(effect):
    got = polarity.apply(_out(effect))
    assert got["effect"] == "unexplained" and got["ambiguous_with"] == []
    assert got["orientation"] == {"clockwise": True, "effect_withdrawn": effect, "size_T": -0.02, "sigma": 300.0}
    assert got["next_measurement"]["protocol"] == "long_dwell" and "in step" in got["next_measurement"]["why"]
    assert got["verdict"].startswith("loop runs clockwise:") and f"({effect}) is withdrawn" in got["verdict"]


def test_unexplained_is_led_by_it_and_a_measurement_verdict_stands():
    got = polarity.apply(_out("unexplained"))
    assert got["orientation"]["effect_withdrawn"] is None and got["verdict"].startswith("loop runs clockwise:")
    assert "withdrawn" not in got["verdict"].split(". As declared")[0]
    for effect in ("thermal_drift", "hall_offset"):
        assert polarity.apply(_out(effect)) == _out(effect)
    assert polarity.apply(_out("model_form", kind="first_zero")) == _out("model_form", kind="first_zero")


def test_a_sweep_read_backwards_is_diagnosed_as_a_clockwise_loop(tmp_path):
    cur = path(0.0, 2.0, 0.0, step=2.0 / 26)
    t, B = observe(cur, dwell=0.1)
    d = dg.diagnose_file(write(tmp_path, "back", cur, t, B[::-1]), "hall1", config=FAST)
    assert "clockwise" in [s["kind"] for s in d["signatures"]]
    assert d["effect"] == "unexplained" and d["orientation"]["clockwise"]
    lines = diagnosis_summary(d).splitlines()
    assert lines[0] == "verdict: unexplained - the loop runs clockwise"
    assert any(x.startswith("  next measurement: long_dwell: check that B and the current") for x in lines)
