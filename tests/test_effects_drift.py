"""thermal_drift's physical size (issue 12 (c)): a Hall zero creeps no faster than its quiescent tempco x supply
x the fastest heating the sensor sees (config diagnose.plausible), and the blind generator's drifts stay within
that same bound. No fitting here: the registry's plausible function and the generator's draws."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.blind import cases
from mrhyst.model import effects as fx
from mrhyst.model import hall

DRIFT = fx.REGISTRY["thermal_drift"]


def ctx(duration_s=7.33, **sensor):
    return fx.Context(span_mT=100.0, duration_s=duration_s, B_mT=np.zeros(3), t_rel=np.zeros(3),
                      mask=np.ones(3, bool), sensor=sensor)


def bound_T_per_s(rg, sens=5.0, supply=3.3):
    return rg["drift_tc_frac_supply_per_K"] * supply * rg["drift_heating_K_per_s"] / sens


def test_the_rate_bound_rejects_a_fast_drift_and_accepts_a_slow_one(config):
    """The held-out Rayleigh core's 'drift 51.9 mT over 7.33 s' (7.1 mT/s, 35 mV/s at 5 V/T) is far beyond a Hall
    zero's creep; 0.05 mT/s (0.25 mV/s) is within it. The total bound alone (10 % of 3.3 V = 66 mT) passed both."""
    rg = config["diagnose"]["plausible"]
    c = ctx(sensitivity_V_per_T=5.0, supply_V=3.3)
    ok, why = DRIFT.plausible(51.9e-3 / 7.33, c, rg)
    assert not ok
    assert "7.08 mT/s" in why and "35.4 mV/s" in why and "7.33 s" in why
    assert f"{bound_T_per_s(rg) * 1e3:.3g} mT/s" in why
    ok, why = DRIFT.plausible(-5.0e-5, c, rg)
    assert ok, why
    assert 51.9e-3 <= rg["drift_frac_supply"] * 3.3 / 5.0  # the total bound alone would not have caught it


def test_the_total_bound_still_holds_on_a_long_sweep(config):
    """A slow rate over a very long sweep can still exceed the quiescent tolerance over temperature."""
    rg = config["diagnose"]["plausible"]
    rate = 0.9 * bound_T_per_s(rg)
    long = rg["drift_frac_supply"] * 3.3 / 5.0 / rate * 1.5  # 1.5 x the total bound
    assert DRIFT.plausible(rate, ctx(duration_s=30.0, sensitivity_V_per_T=5.0, supply_V=3.3), rg)[0]
    assert not DRIFT.plausible(rate, ctx(duration_s=long, sensitivity_V_per_T=5.0, supply_V=3.3), rg)[0]


def test_no_sensor_no_bound(config):
    """A third-party B(H) loop carries no sensitivity: no rate bound (as before)."""
    ok, why = DRIFT.plausible(1.0, ctx(), config["diagnose"]["plausible"])
    assert ok and "no bound" in why


@settings(max_examples=60, deadline=None)
@given(sens=st.floats(0.5, 10.0), supply=st.floats(3.0, 5.5), duration=st.floats(1.0, 60.0),
       frac=st.one_of(st.floats(0.01, 0.98), st.floats(1.02, 50.0)), sign=st.sampled_from([-1.0, 1.0]))
def test_plausible_exactly_when_the_output_rate_is_within_the_bound(config, sens, supply, duration, frac, sign):
    """Property: with the total within its bound, a drift is plausible iff |rate| x sensitivity <= tempco x supply
    x heating rate, whatever the sensor and the sweep."""
    rg = dict(config["diagnose"]["plausible"], drift_frac_supply=1.0e6)  # the total bound out of the way
    rate = sign * frac * bound_T_per_s(rg, sens, supply)
    ok, why = DRIFT.plausible(rate, ctx(duration, sensitivity_V_per_T=sens, supply_V=supply), rg)
    assert ok is (frac < 1.0), why


# ---------------------------------------------------------------- the blind generator
DRIFT_CLASSES = ("thermal_drift", "hall_offset+thermal_drift", "remanent_start+thermal_drift")


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), cls=st.sampled_from(DRIFT_CLASSES))
def test_generated_drifts_lie_within_the_physical_bound(config, seed, cls):
    """Property over seeds: every drift the blind generator injects (closed and compound classes) creeps at an
    output-referred rate within the diagnosis's bound, with the case's own sensitivity and the rig's supply."""
    bcfg = config["blind"]
    spec = cases._draw_one(cls, cases.class_kind(cls), np.random.default_rng(seed), bcfg, cases.current_path(bcfg))
    if spec is None:  # a J-A truth that does not integrate is drawn again by the generator
        return
    rate = dict(spec["effects"])["thermal_drift"]["drift_T_per_s"]
    out = abs(rate) * spec["sensitivity_V_per_T"]
    lim = fx.drift_rate_max_V_per_s(config["diagnose"]["plausible"], hall.A1304_SUPPLY_V)
    lo, hi = bcfg["magnitude"]["thermal_drift_V_per_s"]
    assert lo * (1 - 1e-9) <= out <= hi * (1 + 1e-9) and hi < lim


def test_every_draw_consumes_the_same_rng_stream():
    """Each effect's blind draw takes the same number of rng draws, so the classes' streams stay aligned."""
    m = {"hall_offset_sigmas": [1.0, 60.0], "remanent_start_sigmas": [1.0, 100.0],
         "thermal_drift_V_per_s": [1e-4, 7.9e-4], "sensor_saturation_sigmas": [2.0, 100.0],
         "sensor_saturation_max_frac": 0.3, "eddy_lag": [0.02, 0.5], "air_gap_above_alpha": [2e-3, 3e-2]}
    case = {"sigma_T": 1.5e-4, "peak_T": 0.09, "truth": {"alpha": 1e-3}, "duration_s": 5.2,
            "sensitivity_V_per_T": 5.0}
    nxt = {}
    for name, e in fx.REGISTRY.items():
        if e.draw is None:
            continue
        rng = np.random.default_rng(7)
        e.draw(rng, m, case)
        nxt[name] = rng.uniform()
    assert "thermal_drift" in nxt and len(set(nxt.values())) == 1, nxt


@pytest.mark.parametrize("bad", [{"thermal_drift_sigmas": [5.0, 300.0]}, {"thermal_drift_V_per_s": [0.0, 1e-3]}])
def test_the_old_drift_keys_or_a_zero_rate_are_config_errors(config, bad):
    """The blind drift range is a rate (V/s): the retired sigma range is an unknown key, a zero rate is refused."""
    from mrhyst.config import ConfigError, check_config

    cfg = dict(config, blind=dict(config["blind"], magnitude={**config["blind"]["magnitude"], **bad}))
    with pytest.raises(ConfigError, match="magnitude"):
        check_config(cfg)


# ---------------------------------------------------------------- through the diagnosis (a raw sweep with its sidecar)
@pytest.mark.parametrize("rate_T_per_s, dwell_s, named", [
    (1.5e-4, 0.5, True),    # 0.75 mV/s at 5 V/T over a 26 s sweep (3.9 mT): a Hall zero can creep so
    (3.0e-3, 0.1, False),   # 15 mV/s over 5.2 s (16 mT): the size test_diagnose injects; no Hall zero creeps so
])
def test_a_drift_is_named_only_at_a_physical_rate(tmp_path, rate_T_per_s, dwell_s, named):
    """The rig's core with a drift, written with its sidecar (sensitivity, supply): a physical creep is named and
    sized, a fast one fits as well but is not named, and its plausible_why gives the rate, the bound, the duration."""
    from mrhyst import diagnose as dg
    from mrhyst import rig
    from mrhyst.model import ja

    truth = np.array([1.357e6, 2.6882e4, 1.4697e-4, 0.4199, 5.6943e3])
    v, t, cur, side = rig.simulate_case(truth, [("thermal_drift", {"drift_T_per_s": rate_T_per_s})], 1.5e-4, 2,
                                        ja.paper_current_path(), n_over_le=3026.4, dwell_s=dwell_s,
                                        sensitivity_V_per_T=5.0, declare_limits=False)
    raw = tmp_path / "drift.csv"
    rig.write_case(raw, v, t, cur, side)
    d = dg.diagnose_file(raw, "hall1", config={"budget_seeds": 1, "n_random": 600, "series": False})
    c = {x["effect"]: x for x in d["candidates"]}["thermal_drift"]
    assert c["plausible"] is named, c["plausible_why"]
    assert "mV/s at the output" in c["plausible_why"] and f"({t[-1] - t[0]:.3g} s)" in c["plausible_why"]
    if named:
        assert d["effect"] == "thermal_drift", d["verdict"]
        assert abs(d["effect_size"]["value"] - rate_T_per_s) < max(4 * d["effect_size"]["stderr"], 0.1 * rate_T_per_s)
    else:
        assert d["effect"] != "thermal_drift" and d["policy"]["checks"]["plausible"] is False, d["verdict"]
