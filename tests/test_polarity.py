"""A reversed sign (a Hall sensor facing the other way, a coil connected the other way round): the model-free
``reversed_sign`` signature fires on an upside-down loop and on no loop a material and a measurement chain make
(real loops of other labs, rig sweeps with every effect, a drift of any size); the verdict withdraws the fits'
effect and names the fix; a sensor declared with a negative sensitivity reads B with its sign."""

import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from mrhyst import diagnose as dg
from mrhyst import rig
from mrhyst.data import io
from mrhyst.diagnose import polarity
from mrhyst.diagnose import signatures as sg
from mrhyst.model import effects as fx
from mrhyst.model import ja
from mrhyst.report.summary import diagnosis_summary
from test_diagnose_signatures import FAST, write
from test_signatures import REAL, SET, observe, path, real_loop

MS = float(SET["min_sigma"])
SIGMA = 3e-4


def fires(cur, B, sigma=SIGMA):
    return sg.reversed_sign(cur, B, sigma, np.ones(B.size, dtype=bool), MS)


@pytest.mark.parametrize("loop", REAL, ids=lambda x: f"{x[0].parent.name}-{x[1]}")
def test_real_loops_of_other_labs_never_reversed_but_always_when_negated(loop):
    H, B = real_loop(*loop)
    assert fires(H, B, sigma=1e-6) == []  # as measured: not even at a noise of 1 uT
    got = fires(H, -B)
    assert len(got) == 1 and got[0].size_T < 0 and got[0].sigma > 100


@pytest.mark.parametrize("tips", [(0.0, 2.0, 0.0), (0.0, 2.0, -2.0, 2.0), (-2.0, 2.0, -2.0)])
@pytest.mark.parametrize("effect", [None, ("eddy_lag", {"lag": 0.6}), ("hall_offset", {"offset_T": 0.02}),
                                    ("sensor_saturation", {"B_sat_T": 0.05}), ("air_gap", {"Nd": 2e-3})])
def test_rig_sweeps_with_any_effect_never_reversed(tips, effect):
    cur = path(*tips, step=2.0 / 26)
    _, B = observe(cur, [effect] if effect else [])
    assert fires(cur, B, sigma=1e-6) == []
    assert [s.kind for s in fires(cur, -B)] == ["reversed_sign"]


@given(rate=st.floats(-50.0, 50.0), dwell=st.floats(0.05, 5.0))
def test_a_drift_of_any_size_turns_one_direction_only(rate, dwell):
    """A drift moves B one way in time: on a rise-then-fall sweep it can turn the rise or the fall against the
    current, never both (B falling on the rise needs a negative rate, on the fall a positive one)."""
    cur = path(0.0, 2.0, 0.0, step=2.0 / 26)
    t, B = observe(cur, dwell=dwell)
    assert fires(cur, B + rate * 1e-3 * (t - t[0]), sigma=1e-6) == []


def test_the_verdict_is_withdrawn_and_the_fix_named_without_fitting():
    sig = sg.Signature("reversed_sign", -0.08, 230.0, (0, 26, 26, 52)).to_dict()
    out = {"effect": "thermal_drift", "ambiguous_with": ["hall_offset"], "ambiguity_reason": "x",
           "effect_size": {"param": "drift_T_per_s", "value": 1e-3}, "verdict": "thermal_drift: ...",
           "signatures": [sig], "next_measurement": {"protocol": "bipolar", "separation_sigma": 1.9, "why": "."}}
    got = polarity.apply(dict(out))
    assert got["effect"] == "unexplained" and got["ambiguous_with"] == [] and got["effect_size"] is None
    assert got["sign"] == {"reversed": True, "effect_withdrawn": "thermal_drift", "size_T": -0.08, "sigma": 230.0}
    assert got["next_measurement"]["protocol"] == "reversed_sign" and "negative sensitivity" in got["verdict"]
    assert got["verdict"].startswith("sign reversed:") and got["verdict"].endswith("thermal_drift: ...")
    clean = dict(out, signatures=[])
    assert polarity.apply(dict(clean)) == clean


def _sweep(tmp_path):
    cur = ja.paper_current_path()
    t = rig.sample_times(cur.size, 0.1)
    B, ok = rig.observe(ja.as_param_array({"Ms": 1.3e6, "a": 2.2e4, "alpha": 1.5e-3, "c": 0.5, "k": 5.5e3}),
                        cur, t, 3000.0, [("hall_offset", {"offset_T": 2e-3})])
    assert ok
    return cur, t, B


def test_an_upside_down_sweep_is_diagnosed_as_a_reversed_sign(tmp_path):
    cur, t, B = _sweep(tmp_path)
    d = dg.diagnose_file(write(tmp_path, "flip", cur, t, -B), "hall1", config=FAST)
    assert d["effect"] == "unexplained" and d["ambiguous_with"] == []
    assert d["sign"]["reversed"] and d["next_measurement"]["protocol"] == "reversed_sign"
    assert "reversed_sign" in [s["kind"] for s in d["signatures"]]
    lines = diagnosis_summary(d).splitlines()
    assert lines[0] == "verdict: unexplained - sign reversed (B runs against the current)"
    assert any(x.startswith("  next measurement: reversed_sign: turn the Hall sensor over") for x in lines)


def test_a_sensor_declared_reversed_reads_b_with_its_sign_and_is_diagnosed_as_mounted(tmp_path):
    """The same field through a sensor facing the other way (V = Vq - |S| B), declared with S < 0: the same B to
    rounding, the same verdict as the sensor mounted the usual way."""
    cur, t, B = _sweep(tmp_path)
    up = write(tmp_path, "up", cur, t, B, sens=2.0)
    down = write(tmp_path, "down", cur, t, B, sens=-2.0)
    Bu, Bd = (io.read_raw(p) for p in (up, down))
    assert np.allclose(-(Bd.volts["hall1"] - 1.65), Bu.volts["hall1"] - 1.65, atol=1e-12)
    du, dd = (dg.diagnose_file(p, "hall1", config=FAST) for p in (up, down))
    assert dd["effect"] == du["effect"] == "hall_offset" and "sign" not in dd
    assert dd["effect_size"]["value"] == pytest.approx(du["effect_size"]["value"], rel=1e-3)  # the CSV rounds V


def test_plausible_sizes_do_not_depend_on_which_way_the_sensor_faces():
    seen = set()
    for e, size in (("hall_offset", 0.02), ("hall_offset", 0.5), ("thermal_drift", 1e-4), ("thermal_drift", 1e-3),
                    ("sensor_saturation", 0.28), ("sensor_saturation", 0.1)):
        verdicts = []
        for s in (5.0, -5.0):
            sensor = {"sensitivity_V_per_T": s, "quiescent_V": 1.65, "supply_V": 3.3, "output_min_V": 0.2,
                      "output_max_V": 3.1}
            ctx = fx.Context(span_mT=100.0, duration_s=5.3, B_mT=np.zeros(53), t_rel=np.linspace(0, 1, 53),
                             mask=np.ones(53, dtype=bool), sensor=sensor)
            verdicts.append(fx.REGISTRY[e].plausible(size, ctx, dg.defaults()["plausible"])[0])
        assert verdicts[0] == verdicts[1], e
        seen.add((e, verdicts[0]))
    assert seen == {(e, ok) for e in ("hall_offset", "thermal_drift", "sensor_saturation") for ok in (True, False)}


def test_a_zero_sensitivity_is_one_line_naming_the_key(tmp_path):
    cur, t, B = _sweep(tmp_path)
    p = write(tmp_path, "zero", cur, t, B)
    side = json.loads(p.with_suffix(".json").read_text())
    side["sensors"]["hall1"]["sensitivity_V_per_T"] = 0
    p.with_suffix(".json").write_text(json.dumps(side))
    with pytest.raises(io.InputError, match=r"zero.json: sensors.hall1: sensitivity_V_per_T must be non-zero"):
        io.read_raw(p)


def test_a_clip_at_the_declared_rails_reads_the_same_through_a_sensor_mounted_reversed(tmp_path):
    """With S < 0 a positive B saturates at output_min_V: the declared limits map to B with the sign, and the clip
    is named with the same size as through the sensor mounted the usual way."""
    cur = path(0.0, 2.0, -2.0, 2.0, step=2.0 / 26)
    t, B = observe(cur, dwell=0.5)
    peak = float(np.max(np.abs(B)))
    lo, hi = 1.65 - 5.0 * 0.8 * peak, 1.65 + 5.0 * 0.8 * peak
    got = []
    for s in (5.0, -5.0):
        V = np.clip(1.65 + s * (B + 1.5e-4 * np.random.default_rng(0).standard_normal(B.size)), lo, hi)
        side = {"supply_V": 3.3, "coil_turns_per_m": 3000.0, "dwell_s": 0.5,
                "sensors": {"hall1": {"sensitivity_V_per_T": s, "quiescent_V": 1.65, "output_min_V": lo,
                                      "output_max_V": hi}}}
        rig.write_case(tmp_path / f"s{s:+.0f}.csv", {"hall1": V}, t, cur, side)
        d = dg.diagnose_file(tmp_path / f"s{s:+.0f}.csv", "hall1", config=FAST)
        got.append((d["effect"], round(d["effect_size"]["value"], 9), sorted(x["kind"] for x in d["signatures"])))
    assert got[0] == got[1] and got[0][0] == "sensor_saturation"
    assert got[0][1] == pytest.approx(0.8 * peak, rel=0.05)
