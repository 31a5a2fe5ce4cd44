"""The benchmark "real cores, known faults" (issue 23): its cases carry the injected fault and nothing of the key;
its scorer counts what the issue counts."""

import json

import numpy as np
import pytest
from mrhyst.blind import realcores, realscore
from mrhyst.data import io
from workflow_util import ROOT


def cfg(**kw):
    c = realcores.resolve({"sources": {"mnzn_ferrite": str(ROOT / "data/external/mnzn-ferrite-jamodel/loops.csv")},
                           "cores": ["mnzn_ferrite_L1"], **kw})
    return c


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    d = tmp_path_factory.mktemp("rc")
    key = realcores.generate(cfg(), d / "cases", d / "key.json")
    return d, key


def by_fault(key, proto):
    return {v["fault"]: c for c, v in key.items() if v["protocol"] == proto}


def test_every_fault_of_each_protocol_and_a_clean_case_per_core(made):
    _, key = made
    assert sorted(by_fault(key, "bh")) == ["hall_offset", "none", "sensor_saturation"]
    assert sorted(by_fault(key, "hall")) == ["eddy_lag", "hall_offset", "none", "sensor_saturation", "thermal_drift"]


def test_same_config_same_bytes_and_no_key_in_the_cases(made, tmp_path):
    d, key = made
    realcores.generate(cfg(), tmp_path / "cases", tmp_path / "key.json")
    for f in sorted((d / "cases").iterdir()):
        assert (tmp_path / "cases" / f.name).read_bytes() == f.read_bytes()
        assert f.stem.startswith("rc_") and b"fault" not in f.read_bytes() and b"offset_T" not in f.read_bytes()
    assert set(json.loads((d / "key.json").read_text())["cases"]) == set(key)


def test_a_bh_offset_is_exactly_the_injected_constant(made):
    d, key = made
    f = by_fault(key, "bh")
    clean, off = (io.read_loop(d / "cases" / f"{f[k]}.csv") for k in ("none", "hall_offset"))
    diff = np.asarray(off.B_T) - np.asarray(clean.B_T)
    assert np.allclose(diff, key[f["hall_offset"]]["size"], atol=1e-12)
    # the first level (the only core): 1 % of the loop's peak |B| (the ferrite's 16 A/m loop: 0.17361 T)
    assert abs(key[f["hall_offset"]]["size"]) == pytest.approx(0.01 * 0.17361, rel=1e-4)


def test_a_hall_offset_shifts_the_sweep_by_its_size_within_the_noise(made):
    d, key = made
    f = by_fault(key, "hall")
    B = {k: np.asarray(io.raw_to_loop(io.read_raw(d / "cases" / f"{f[k]}.csv"), "hall1").B_T)
         for k in ("none", "hall_offset")}
    k = key[f["hall_offset"]]
    se = np.sqrt(2) * k["noise_T"] / np.sqrt(B["none"].size)
    assert abs(np.mean(B["hall_offset"] - B["none"]) - k["size"]) < 4 * se + 2e-4 / k["sensitivity_V_per_T"]


def test_a_clip_sits_at_the_declared_output_limit_and_is_flagged(made):
    d, key = made
    c = by_fault(key, "hall")["sensor_saturation"]
    raw = io.read_raw(d / "cases" / f"{c}.csv")
    side = json.loads((d / "cases" / f"{c}.json").read_text())["sensors"]["hall1"]
    V = np.asarray(raw.volts["hall1"])
    assert np.max(V) == pytest.approx(side["output_max_V"], abs=1e-9)
    loop = io.raw_to_loop(raw, "hall1")
    assert int(loop["saturated"].sum()) >= 2
    b_sat = (side["output_max_V"] - side["quiescent_V"]) / side["sensitivity_V_per_T"]
    # the declared limit is the ADC's code of the lowered output limit: within half an LSB (20 V / 2^16 / 2)
    assert b_sat == pytest.approx(key[c]["size"], abs=0.5 * 20.0 / 2**16 / side["sensitivity_V_per_T"])


def test_the_scorer_counts_a_named_fault_an_ambiguous_set_with_a_next_measurement_and_false_alarms():
    k = {"core": "c", "protocol": "hall", "fault": "hall_offset", "size": 0.01}
    assert realscore.judge(k, {"effect": "hall_offset", "effect_size": {"value": 0.0124}}, 0.25)["size_ok"]
    assert not realscore.judge(k, {"effect": "hall_offset", "effect_size": {"value": 0.013}}, 0.25)["size_ok"]
    amb = {"effect": "remanent_start", "ambiguous_with": ["hall_offset"]}
    assert not realscore.judge(k, amb, 0.25)["named"]
    assert realscore.judge(k, dict(amb, next_measurement={"protocol": "bipolar"}), 0.25)["named"]
    clean = dict(k, fault="none")
    assert realscore.judge(clean, {"effect": "thermal_drift"}, 0.25)["false_alarm"]
    assert not realscore.judge(clean, {"effect": "remanent_start"}, 0.25)["false_alarm"]  # physics, not a fault
    # an accepted second effect: a fault beside a remanent start is named (its size from the secondary), and on a
    # clean core it is a false alarm (a build's rc_019: remanent_start + eddy_lag 0.22 on a clean M130-27s sweep)
    pair = {"effect": "remanent_start", "secondary": {"accepted": True, "effect": "hall_offset",
                                                      "size": {"param": "offset_T", "value": 0.0105}}}
    row = realscore.judge(k, pair, 0.25)
    assert row["named"] and row["size_ok"] and row["size"] == 0.0105
    lag, unaccepted = dict(pair["secondary"], effect="eddy_lag"), dict(pair["secondary"], accepted=False)
    assert realscore.judge(clean, dict(pair, secondary=lag), 0.25)["false_alarm"]
    assert not realscore.judge(clean, dict(pair, secondary=unaccepted), 0.25)["false_alarm"]


def test_a_jittering_measured_path_becomes_its_real_legs_and_a_clean_path_is_kept_as_read():
    """0 -> +1000 -> -1000 -> +800 A/m with a 3 A/m back-and-forth on every sample (a dense 3 Hz record): three
    legs, each monotone; a path without jitter (and any path at frac 0) is returned as it is."""
    from mrhyst.data import loops

    legs = [np.linspace(0, 1000, 200), np.linspace(1000, -1000, 400)[1:], np.linspace(-1000, 800, 360)[1:]]
    clean = np.concatenate(legs)
    H = clean + 3.0 * (-1.0) ** np.arange(clean.size)
    h, b = realcores.monotone_legs(H, H * 1e-3, 0.01)
    segs = loops.segments(h)
    assert [s.direction for s in segs] == [1, -1, 1] and np.array_equal(b, h * 1e-3)
    assert h.size > 0.45 * H.size and h.max() == H.max() and h.min() == H.min()  # the turning points kept
    for H0 in (clean, np.r_[clean[:5], clean[4], clean[5:]]):
        assert realcores.monotone_legs(H0, H0, 0.01)[0] is H0
    assert realcores.monotone_legs(H, H, 0.0)[0] is H


def test_the_gadolinium_cores_are_three_legs_and_named_cores_are_counted_without_reading():
    src = {"nowicki_gd": str(ROOT / "data/external/gd-temperature-nowicki/loops.csv")}
    c = realcores.resolve({"sources": src, "cores": ["nowicki_gd_L0", "nowicki_gd_L15"]})
    assert realcores.n_cores(dict(c, sources={})) == 2  # the names alone
    from mrhyst.data import loops

    cores = realcores.cores_of(c)
    assert [x["core"] for x in cores] == ["nowicki_gd_L0", "nowicki_gd_L15"]
    assert [len(loops.segments(x["H"])) for x in cores] == [3, 5]  # L15 (+10 C) holds two cycles


def test_the_summary_counts_each_material_apart():
    rows = [{"core": "nowicki_gd_L10", "protocol": "hall", "fault": "eddy_lag", "named": True, "false_alarm": None,
             "size_ok": True, "material_T": None, "measurement_T": None, "left_T": None, "effect": "eddy_lag"},
            {"core": "nowicki_gd_L0", "protocol": "bh", "fault": "none", "named": None, "false_alarm": True,
             "size_ok": None, "material_T": None, "measurement_T": None, "left_T": None, "effect": "hall_offset"},
            {"core": "m130_27s_L2", "protocol": "bh", "fault": "hall_offset", "named": False, "false_alarm": None,
             "size_ok": None, "material_T": None, "measurement_T": None, "left_T": None, "effect": "unexplained"}]
    out = realscore.summary(rows)
    # the overall rates and the counts they are fractions of: a fault named 1 of 2, its size 1 of 1, a clean 1 of 1
    assert out["overall"]["counts"] == {"named": [1, 2], "size_within": [1, 1], "clean_false_alarm": [1, 1]}
    assert out["overall"]["named"] == 0.5
    s = out["sources"]
    assert s == {"m130_27s": {"n": 1, "named": 0.0, "clean_false_alarm": None},
                 "nowicki_gd": {"n": 2, "named": 1.0, "clean_false_alarm": 1.0}}


def test_the_section_is_resolved_once_and_survives_the_workflows_pickle(tmp_path, monkeypatch):
    """The rule file resolves the section at parse time and hands it on in params (Snakemake pickles them);
    generate() uses it as it is instead of resolving it a second time (issue 26's house list)."""
    import pickle

    c = cfg(seed=5)
    back = pickle.loads(pickle.dumps({"realcores": c}))["realcores"]
    assert back.as_dict() == c.as_dict() and back["seed"] == 5 and realcores.resolve(back) is back

    def twice(*a, **k):
        raise AssertionError("resolved again")

    monkeypatch.setattr(realcores, "frozen", twice)
    key = realcores.generate(back, tmp_path / "cases", tmp_path / "key.json")
    assert json.loads((tmp_path / "key.json").read_text())["config"]["seed"] == 5 and len(key) == 8
