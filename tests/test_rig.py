"""Virtual test rig (mrhyst.rig) and the committed synthetic sweep data/raw/li_gong_rig.*"""

import hashlib
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst import rig
from mrhyst.data import io
from mrhyst.model import effects, hall, ja
from mrhyst.paper import nle

RAW = "data/raw/li_gong_rig"
LSB = 20.0 / 2**16
S = hall.A1304_SENSITIVITY_V_PER_T
# a truth with a clear loop at the paper's path (rig hall1)
TRUTH = np.array([1.357e6, 2.6882e4, 1.4697e-4, 0.4199, 5.6943e3])
NLE = 3026.4


@pytest.fixture(scope="module")
def n_over_le(config):
    return nle.infer_n_over_le(config)["n_over_le"]


@pytest.fixture(scope="module")
def raw(root):
    return io.read_raw(root / f"{RAW}.csv")


def case(effs=(), sigma=0.0, seed=0, **kw):
    kw.setdefault("n_over_le", NLE)
    kw.setdefault("dwell_s", 0.1)
    return rig.simulate_case(TRUTH, effs, sigma, seed, **kw)


def to_B(volts, side, sensor="hall1"):
    s = side["sensors"][sensor]
    return hall.volts_to_tesla(volts[sensor], s["sensitivity_V_per_T"], s["quiescent_V"])


# ---------------------------------------------------------------- committed sweep
@pytest.mark.parametrize("sensor, group", [("hall1", "group1"), ("hall2", "group2")])
def test_committed_sweep_meets_targets(config, raw, sensor, group):
    loop = io.raw_to_loop(raw, sensor)
    assert len(loop) == 53
    # 27 currents up (the peak included) and 27 down sharing the peak: 26 rows reached going down
    assert (loop.branch == "up").sum() == 27 and (loop.branch == "down").sum() == 26
    np.testing.assert_allclose(loop.current_A, ja.paper_current_path(2.0, 27), atol=1e-9)
    B = loop.B_T.to_numpy()
    assert B.max() == pytest.approx(config["paper"]["peak_B_T"][group], rel=0.05)
    assert B[-1] == pytest.approx(config["paper"]["remanence_B_T"][group], rel=0.15)
    assert loop.saturated.sum() == 0


def test_committed_sidecar_contract(config, raw, n_over_le):
    # the rig's N/Le is the inferred one, rounded to 0.001 turns/m (rig.main)
    assert raw.coil_turns_per_m == round(n_over_le, 3)
    assert raw.supply_V == 3.3 and raw.dwell_s == config["rig"]["dwell_s"]
    np.testing.assert_allclose(np.diff(raw.time_s), raw.dwell_s, rtol=1e-9)
    assert set(raw.sensors) == {"hall1", "hall2"} == set(raw.volts)
    for s in raw.sensors.values():
        assert s.sensitivity_V_per_T == 5.0 and s.quiescent_V == 1.65
        assert s.output_min_V < 1.65 < s.output_max_V
    assert "SYNTHETIC" in raw.sidecar["provenance"]


def test_committed_checksums_match_readme(root):
    text = (root / "data/raw/README.md").read_text()
    sums = dict((name, h) for h, name in re.findall(r"\b([0-9a-f]{64})\s+(li_gong_rig\.(?:csv|json))", text))
    assert set(sums) == {"li_gong_rig.csv", "li_gong_rig.json"}
    for name, h in sums.items():
        assert hashlib.sha256((root / "data/raw" / name).read_bytes()).hexdigest() == h


def test_regeneration_is_byte_identical(root, config, tmp_path):
    seed = config["rig"]["seed"]
    readme = (root / "data/raw/README.md").read_text()
    assert f"python -m mrhyst.rig --config config.yaml --seed {seed} --out data/raw/li_gong_rig.csv" in readme
    out = tmp_path / "li_gong_rig.csv"
    assert rig.main(["--config", str(root / "config.yaml"), "--seed", str(seed), "--out", str(out)]) == 0
    for ext in (".csv", ".json"):
        assert out.with_suffix(ext).read_bytes() == (root / f"{RAW}{ext}").read_bytes()


def test_main_reports_a_bad_config(tmp_path, capsys):
    bad = tmp_path / "c.yaml"
    bad.write_text("paper: {}\n")
    assert rig.main(["--config", str(bad), "--out", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err
    assert not (tmp_path / "x.csv").exists()


# ---------------------------------------------------------------- ADC, noise, seeds
def test_adc_step():
    assert rig.adc_lsb() == LSB == 20.0 / 65536
    assert rig.quantise(10.5) == (2**15 - 1) * LSB and rig.quantise(-10.5) == -(2**15) * LSB


@settings(max_examples=50, deadline=None, derandomize=True)
@given(v=st.floats(-9.99, 9.99))
def test_quantise_is_on_the_grid(v):
    q = float(rig.quantise(v))
    assert q / LSB == round(q / LSB)
    assert abs(q - v) <= LSB / 2


def test_volts_are_adc_codes():
    volts, *_ = case(sigma=1.5e-4, seed=3)
    codes = volts["hall1"] / LSB
    np.testing.assert_array_equal(codes, np.round(codes))


def test_same_seed_same_bytes_different_seed_different_noise(tmp_path):
    paths = []
    for i, seed in enumerate((7, 7, 8)):
        p = tmp_path / f"c{i}.csv"
        rig.write_case(p, *case([("eddy_lag", {"lag": 0.3})], 1.5e-4, seed))
        paths.append(p)
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert paths[0].with_suffix(".json").read_bytes() == paths[1].with_suffix(".json").read_bytes()
    assert paths[0].read_bytes() != paths[2].read_bytes()
    a, b = io.read_raw(paths[0]).volts["hall1"], io.read_raw(paths[2]).volts["hall1"]
    assert np.sum(a != b) > 40


def test_noise_level_and_common_random_numbers():
    flat = np.zeros(4000)  # no field: what is left is the noise
    v1, _, _, side = case(sigma=1.5e-4, seed=11, current_path=flat, adc_bits=None)
    v2, *_ = case(sigma=3.0e-4, seed=11, current_path=flat, adc_bits=None)
    B1, B2 = to_B(v1, side), to_B(v2, side)
    assert np.std(B1) == pytest.approx(1.5e-4, rel=0.05)
    np.testing.assert_allclose(B2, 2 * B1, atol=1e-12)  # same pattern, scaled


def test_sensors_of_one_sweep_get_independent_noise(config, n_over_le):
    cfg = {**config["rig"], "sensors": {"hall1": config["rig"]["sensors"]["hall1"],
                                        "hall9": config["rig"]["sensors"]["hall1"]}}
    volts, *_ = rig.simulate_sweep(cfg, n_over_le, seed=1)
    assert np.sum(volts["hall1"] != volts["hall9"]) > 40


# ---------------------------------------------------------------- effects
SINGLE = [
    ("none", {}),
    ("hall_offset", {"offset_T": 2.0e-3}),
    ("remanent_start", {"M0_A_per_m": 8.0e3}),
    ("eddy_lag", {"lag": 0.35}),
    ("thermal_drift", {"drift_T_per_s": 4.0e-4}),
    ("sensor_saturation", {"B_sat_T": 0.07}),
    ("air_gap", {"Nd": 0.01}),
]


def _expected(name, ep, current, t):
    """What each effect does to the J-A truth, written out from its physics (not through mrhyst.model.effects):
    the core's B from ja.simulate alone, then the effect by hand."""
    sim = dict(form="physical", substeps=8)
    B0, ok = ja.simulate(TRUTH, current, NLE, **sim)
    assert ok
    if name == "none":
        return B0
    if name == "hall_offset":  # a constant zero error of the Hall output
        return B0 + ep["offset_T"]
    if name == "thermal_drift":  # the zero creeping linearly from the first sample on
        return B0 + ep["drift_T_per_s"] * (t - t[0])
    if name == "sensor_saturation":  # the output sticks at +-B_sat
        return np.minimum(np.maximum(B0, -ep["B_sat_T"]), ep["B_sat_T"])
    if name == "remanent_start":  # the core starts magnetised at M0
        return ja.simulate(TRUTH, current, NLE, M0=ep["M0_A_per_m"], **sim)[0]
    if name == "air_gap":  # a gap of demagnetising factor Nd: alpha -> (alpha - Nd) / (1 - Nd) (ARCHITECTURE 5)
        p = TRUTH.copy()
        p[2] = (p[2] - ep["Nd"]) / (1.0 - ep["Nd"])
        return ja.simulate(p, current, NLE, **sim)[0]
    if name == "eddy_lag":  # each step settles to (1 - lag) of its change before it is read
        out = B0.copy()
        for j in range(1, out.size):
            out[j] = B0[j] + ep["lag"] * (out[j - 1] - B0[j])
        return out
    raise AssertionError(name)


@pytest.mark.parametrize("name, ep", SINGLE)
def test_observe_adds_each_effect_as_its_physics_says(name, ep):
    current = ja.paper_current_path()
    t = rig.sample_times(current.size, 0.1)
    B, ok = rig.observe(TRUTH, current, t, NLE, [(name, ep)])
    assert ok
    np.testing.assert_allclose(B, _expected(name, ep, current, t), rtol=0, atol=1e-12)


def test_hall_voltage_by_hand():
    """The first sample of the paper's path is at 0 A on a demagnetised core: B = 0, so the A1304 reads its
    quiescent 3.3 V / 2 = 1.65 V, which the 6363 (20 V / 2^16 = 305.18 uV per code) reads as code
    round(1.65 / 305.18e-6) = round(5406.72) = 5407, i.e. 1.6500854 V. A 2 mT Hall offset adds 5 V/T x 2 mT =
    10 mV: 1.66 V = 5439.49 codes -> 5439 -> 1.6598511 V."""
    volts, _, current, _ = case(sigma=0.0)
    assert current[0] == 0.0
    assert volts["hall1"][0] == pytest.approx(5407 * 20.0 / 65536, abs=1e-12) == pytest.approx(1.6500854, abs=1e-7)
    volts, _, _, _ = case([("hall_offset", {"offset_T": 2.0e-3})], sigma=0.0)
    assert volts["hall1"][0] == pytest.approx(5439 * 20.0 / 65536, abs=1e-12) == pytest.approx(1.6598511, abs=1e-7)


@pytest.mark.parametrize("name, ep", SINGLE)
def test_noise_free_case_is_the_ideal_sensor(name, ep):
    volts, t, current, side = case([(name, ep)], adc_bits=None)
    Bf, _ = effects.forward(TRUTH, current, t, NLE, name, ep, form="physical", substeps=8)
    np.testing.assert_allclose(to_B(volts, side), Bf, atol=1e-12)


def plain_and(name, ep, **kw):
    base = to_B(*case(**kw)[::3])
    volts, t, current, side = case([(name, ep)], **kw)
    return base, to_B(volts, side), t, side


@settings(max_examples=15, deadline=None, derandomize=True)
@given(off=st.floats(-5e-3, 5e-3))
def test_offset_shifts_B_at_zero_current(off):
    base, B, _, _ = plain_and("hall_offset", {"offset_T": off}, sigma=1.5e-4, seed=5)
    assert B[0] - base[0] == pytest.approx(off, abs=LSB / S)  # same noise draw: only the ADC step differs
    np.testing.assert_allclose(B - base, off, atol=LSB / S)


def test_remanent_start_lifts_the_start_and_the_loop():
    base, B, _, _ = plain_and("remanent_start", {"M0_A_per_m": 8.0e3})
    assert B[0] == pytest.approx(ja.MU0 * 8.0e3, abs=LSB / S)
    assert np.all(B > base)


def test_eddy_lag_delays_both_branches():
    base, B, _, _ = plain_and("eddy_lag", {"lag": 0.35})
    up, down = slice(1, 27), slice(27, 53)
    assert np.all(B[up] < base[up]) and np.all(B[down] > base[down])
    assert B.max() < base.max() and B[-1] > base[-1]


def test_thermal_drift_grows_with_time():
    base, B, t, _ = plain_and("thermal_drift", {"drift_T_per_s": 4.0e-4})
    d = B - base
    np.testing.assert_allclose(d, 4.0e-4 * (t - t[0]), atol=LSB / S)
    assert d[-1] > d[26] > d[0] == pytest.approx(0, abs=LSB / S)


def test_air_gap_lowers_the_peak():
    base, B, _, _ = plain_and("air_gap", {"Nd": 0.01})
    assert B.max() < base.max()


def test_saturation_is_flagged_through_output_limits(tmp_path):
    bsat = 0.07
    clean, *_ = plain_and("none", {})
    volts, t, current, side = case([("sensor_saturation", {"B_sat_T": bsat})], 1.5e-4, 9)
    rig.write_case(tmp_path / "sat.csv", volts, t, current, side)
    loop = io.raw_to_loop(io.read_raw(tmp_path / "sat.csv"), "hall1")
    sat = loop.saturated.to_numpy().astype(bool)
    above, below = clean > bsat + 5e-4, clean < bsat - 5e-4
    assert above.sum() >= 5
    assert np.all(sat[above]) and not np.any(sat[below])
    assert side["sensors"]["hall1"]["output_max_V"] == pytest.approx(1.65 + S * bsat, abs=LSB)
    # the limits always act; declare_limits only decides whether the sidecar states them
    v2, *_, side2 = case([("sensor_saturation", {"B_sat_T": bsat})], 1.5e-4, 9, declare_limits=False)
    assert "output_max_V" not in side2["sensors"]["hall1"]
    np.testing.assert_array_equal(v2["hall1"], volts["hall1"])


def test_effects_compose_in_order():
    # two effects at once: flux settling then the Hall zero error (constant offset commutes with the filter)
    current = ja.paper_current_path()
    t = rig.sample_times(current.size, 0.1)
    B, _ = rig.observe(TRUTH, current, t, NLE, [("hall_offset", {"offset_T": 1e-3}), ("eddy_lag", {"lag": 0.3})])
    Be, _ = effects.forward(TRUTH, current, t, NLE, "eddy_lag", {"lag": 0.3}, form="physical", substeps=8)
    np.testing.assert_allclose(B, Be + 1e-3, atol=1e-15)
    B2, _ = rig.observe(TRUTH, current, t, NLE, [("remanent_start", {"M0_A_per_m": 5e3}), ("air_gap", {"Nd": 0.01})])
    P = TRUTH.copy()
    P[2] = effects.air_gap_alpha(P[2], 0.01)
    Br, _ = effects.forward(P, current, t, NLE, "remanent_start", {"M0_A_per_m": 5e3}, form="physical", substeps=8)
    np.testing.assert_array_equal(B2, Br)


@pytest.mark.parametrize("effs, msg", [
    ([("unexplained", {})], "unknown effect"),
    ([("eddy_lag", {})], "takes parameter"),
    ([("hall_offset", {"offset_T": 1e-3, "lag": 0.1})], "takes parameter"),
    ([("eddy_lag", {"lag": 0.1}), ("eddy_lag", {"lag": 0.2})], "twice"),
    (["eddy_lag"], "pair"),
])
def test_bad_effects_are_refused(effs, msg):
    with pytest.raises(ValueError, match=msg):
        case(effs)


def test_case_sidecar_is_a_valid_raw_sweep(tmp_path):
    volts, t, current, side = case([("eddy_lag", {"lag": 0.2})], 1.5e-4, 0, sensor="hallX", dwell_s=2.0)
    rig.write_case(tmp_path / "c.csv", volts, t, current, side)
    r = io.read_raw(tmp_path / "c.csv")
    assert r.dwell_s == 2.0 and r.coil_turns_per_m == NLE and list(r.volts) == ["hallX"]
    np.testing.assert_allclose(r.time_s, 2.0 * np.arange(1, 54))
