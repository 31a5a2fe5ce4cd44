"""mrhyst.paper.tables: Table 2 measures on hand-computed examples, Table 3 lookup, the tables, the paper check."""

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from mrhyst.paper import tables as metrics


# ---------------------------------------------------------------- Eq. (15) and Table 2
def test_rms_hand_example():
    assert metrics.rms([0.0, 0.0], [3.0, 4.0]) == pytest.approx(math.sqrt(12.5))
    assert metrics.rms([0.0, 0.0, 9.0], [3.0, 4.0, 0.0], valid=[True, True, False]) == pytest.approx(math.sqrt(12.5))


def test_error_measures_hand_example():
    Bm = [0.0, 0.1, 0.2, 0.1]
    Bd = [0.01, 0.1, 0.19, 0.12]  # |e| = 0.01, 0, 0.01, 0.02
    m = metrics.error_measures(Bm, Bd)
    assert m["max_abs_T"] == pytest.approx(0.02)
    assert m["mean_abs_T"] == pytest.approx(0.01)
    assert m["rms_T"] == pytest.approx(math.sqrt((1e-4 + 0 + 1e-4 + 4e-4) / 4))
    assert m["peak_T"] == pytest.approx(0.2)
    # 'peak' (default): |e| / max|B_m|
    assert m["relative"] == "peak"
    assert m["max_rel"] == pytest.approx(0.1)
    assert m["mean_rel"] == pytest.approx(0.05)
    # pointwise over |B_m| >= 5 % of the peak: the B = 0 start is left out -> 0, 0.05, 0.2
    assert m["n_pointwise"] == 3
    assert m["max_rel_pointwise"] == pytest.approx(0.2)
    assert m["mean_rel_pointwise"] == pytest.approx((0 + 0.05 + 0.2) / 3)


def test_relative_error_at_B_zero_is_defined():
    """The virgin start B_m = 0 at 0 A: the peak definition is finite there, the pointwise one excludes it."""
    m = metrics.error_measures([0.0, 0.05, 0.1], [0.002, 0.05, 0.1])
    assert m["max_rel"] == pytest.approx(0.002 / 0.1)  # finite although B_m = 0 at the sample
    assert m["max_rel_pointwise"] == 0.0  # the B = 0 sample is not in the pointwise set
    m = metrics.error_measures([0.0, 0.004, 0.1], [0.0, 0.003, 0.1], relative="pointwise", floor_frac=0.05)
    assert m["n_pointwise"] == 1  # 0.004 < 5 % of 0.1: excluded too
    assert m["max_rel"] == 0.0
    z = metrics.error_measures([0.0, 0.0], [0.001, 0.0])  # an all-zero loop: undefined -> None, not NaN
    assert z["max_rel"] is None and z["mean_rel_pointwise"] is None


def test_error_measures_rejects_bad_input():
    with pytest.raises(ValueError):
        metrics.error_measures([0.0, 1.0], [0.0])
    with pytest.raises(ValueError):
        metrics.error_measures([0.0, 1.0], [0.0, 1.0], relative="percent")


@given(arrays(np.float64, st.integers(1, 60), elements=st.floats(-1.0, 1.0)),
       arrays(np.float64, 60, elements=st.floats(-1.0, 1.0)))
@settings(max_examples=100, deadline=None)
def test_rms_between_mean_abs_and_sqrt_max_mean(bm, bd):
    """mean|e| <= RMS <= sqrt(max|e| mean|e|) <= max|e|: the inequalities the paper check uses."""
    bd = bd[: bm.size]
    m = metrics.error_measures(bm, bd)
    tol = 1e-12
    assert m["mean_abs_T"] <= m["rms_T"] + tol
    assert m["rms_T"] <= math.sqrt(m["max_abs_T"] * m["mean_abs_T"]) + tol
    assert m["rms_T"] <= m["max_abs_T"] + tol


# ---------------------------------------------------------------- Table 3
def test_j_at_iteration_and_after_stop():
    h = [5.0, 4.0, 3.0]
    assert metrics.j_at_iteration(h, 2) == (4.0, False)
    assert metrics.j_at_iteration(h, 3) == (3.0, False)
    assert metrics.j_at_iteration(h, 20) == (3.0, True)  # converged before: stays at its final value
    v = metrics.table3_values(list(np.linspace(1, 0.5, 30)), (20, 50))
    assert v["it20"] == pytest.approx(np.linspace(1, 0.5, 30)[19]) and not v["it20_after_stop"]
    assert v["it50"] == 0.5 and v["it50_after_stop"]
    with pytest.raises(ValueError):
        metrics.j_at_iteration([], 1)


# ---------------------------------------------------------------- fits -> tables
def _fit(group, method, seed, J, scale=1.0, setting=None):
    p = {"Ms": 1e6 * scale, "a": 3e4, "alpha": 1e-3, "c": 0.5, "k": 6e3}
    return {"group": group, "method": method, "setting": setting or ("paper" if method == "pso" else "lsm"),
            "seed": seed, "params": p, "rms_T": J, "history": [2 * J] * 10 + [J] * (90 if method == "pso" else 5),
            "metrics": {"max_abs_T": 3 * J, "max_rel": 0.03, "mean_abs_T": 0.8 * J, "mean_rel": 0.01,
                        "relative": "peak"}}


@pytest.fixture
def fits():
    out = [_fit("group1", "pso", s, 1e-4 * (1 + s), scale=1 + 0.1 * s) for s in range(11)]
    out += [_fit("group1", "lsm", None, 5e-4)]
    out += [_fit("group1", "pso", s, 2e-4 * (1 + s), setting="clerc") for s in range(4)]
    return out


def test_median_seed_selection(fits):
    sel = metrics.select_median(fits)
    assert sel[("group1", "pso", "paper")]["seed"] == 5  # 11 seeds: the 6th smallest J
    assert sel[("group1", "pso", "clerc")]["seed"] == 1  # 4 seeds: lower median
    assert sel[("group1", "lsm", "lsm")]["rms_T"] == 5e-4


def test_tables_paper_beside_ours(fits, config):
    sel = metrics.select_median(fits)
    paper = config["paper"]
    t1 = metrics.table1(sel, paper)
    row = t1[(t1.setting == "paper") & (t1.quantity == "Ms")].iloc[0]
    assert row.paper == paper["table1"]["group1"]["pso"]["Ms"]
    assert row.ours == pytest.approx(1.5e6)
    assert row["diff"] == pytest.approx(row.ours - row.paper)
    assert row.rel_diff == pytest.approx(row["diff"] / row.paper)
    # the clerc setting is compared with the paper's PSO values
    assert t1[(t1.setting == "clerc") & (t1.quantity == "k")].iloc[0].paper == paper["table1"]["group1"]["pso"]["k"]
    t2 = metrics.table2(sel, paper)
    r = t2[(t2.method == "lsm") & (t2.quantity == "mean_abs_T")].iloc[0]
    assert r.paper == paper["table2"]["group1"]["lsm"]["mean_abs_T"] and r.ours == pytest.approx(4e-4)
    t3 = metrics.table3(sel, paper)
    r = t3[(t3.method == "lsm") & (t3.quantity == "J_it50_T")].iloc[0]
    assert r.ours == 5e-4 and bool(r.after_stop)  # LSM history of 15 iterations
    r = t3[(t3.setting == "paper") & (t3.quantity == "J_it20_T")].iloc[0]
    assert r.ours == pytest.approx(6e-4) and not bool(r.after_stop)


def test_seed_spread_and_make_tables(fits, config, tmp_path):
    import json

    sp = metrics.seed_spread_table(fits)
    r = sp[(sp.setting == "paper") & (sp.quantity == "Ms")].iloc[0]
    assert (r["min"], r["median"], r["max"]) == pytest.approx((1e6, 1.5e6, 2e6))
    assert r.rel_range == pytest.approx(1e6 / 1.5e6) and r.n_seeds == 11 and r.median_seed == 5
    paths = []
    for i, f in enumerate(fits):
        p = tmp_path / f"f{i}.json"
        p.write_text(json.dumps(f))
        paths.append(p)
    box = {"lo": {q: 0.0 for q in metrics.PARAM_NAMES}, "hi": {**fits[5]["params"], "Ms": 4e6}}
    prof = {"group": "group1", "method": "pso", "setting": "paper", "x_opt": fits[5]["params"], "J_opt_T": 6e-4,
            "box": box,
            "threshold": 1.1, "condition_rel": 1e3,
            "params": {q: {"range_lo": None, "range_hi": 2.0, "range_open_lo": True, "range_open_hi": False,
                           "rel_width": None, "rel_se_curvature": 0.1, "J_min_T": 6e-4}
                       for q in metrics.PARAM_NAMES}}
    (tmp_path / "prof.json").write_text(json.dumps(prof))
    out = metrics.make_tables(paths, config["paper"], tmp_path / "tables", profile_paths=[tmp_path / "prof.json"])
    assert set(out) == {"table1", "table2", "table3", "seed_spread", "identifiability"}
    idt = pd.read_csv(out["identifiability"])
    assert len(idt) == 5 and idt.seed_rel_range.iloc[0] == pytest.approx(1e6 / 1.5e6)
    assert list(idt.x_opt_at_box_edge) == [False, True, True, True, True]  # Ms inside, the rest at hi
    before = {k: p.read_bytes() for k, p in out.items()}
    out2 = metrics.make_tables(paths, config["paper"], tmp_path / "tables", profile_paths=[tmp_path / "prof.json"])
    assert {k: p.read_bytes() for k, p in out2.items()} == before


# ---------------------------------------------------------------- the paper's numbers
def test_paper_consistency_findings(config):
    f = metrics.paper_consistency_findings(config["paper"])
    by = {(x["check"], x.get("group"), x.get("method"), x.get("iteration")): x for x in f}
    # Table 3 PSO J (0.146e-3) below Table 2 mean abs error (1.0e-3): impossible for one fit
    x = by[("rms_vs_mean_abs", "group1", "pso", "it50")]
    assert not x["ok"] and x["ratio"] == pytest.approx(0.146)
    assert "impossible" in x["text"]
    # group 2 LSM: J 6.33e-3 above even the max abs error 3.3e-3
    x = by[("rms_vs_max_abs", "group2", "lsm", "it50")]
    assert not x["ok"] and "exceeds the max abs error" in x["text"]
    # the relative errors are |e| / peak
    for g in ("group1", "group2"):
        for m in ("lsm", "pso"):
            assert by[("relative_error_denominator", g, m, None)]["ok"]
    assert all(isinstance(x["text"], str) and x["text"] for x in f)
    # Table 3's PSO values would fit Table 2 if they were RMS / sqrt(53); the LSM values would not
    for g in ("group1", "group2"):
        assert by[("rms_over_sqrtN_reading", g, "pso", None)]["ok"]
        assert not by[("rms_over_sqrtN_reading", g, "lsm", None)]["ok"]
    # every table-2/3 pair is inconsistent in at least one direction
    for g in ("group1", "group2"):
        for m in ("lsm", "pso"):
            pair = [by[(c, g, m, "it50")]["ok"] for c in ("rms_vs_mean_abs", "rms_vs_max_abs")]
            assert not all(pair)


def test_consistency_check_passes_consistent_numbers():
    paper = {"table2": {"g": {"pso": {"max_abs_T": 3e-3, "max_rel": 0.03, "mean_abs_T": 1e-3, "mean_rel": 0.01}}},
             "table3": {"g": {"pso": {"it20": 1.5e-3, "it50": 1.4e-3}}}, "peak_B_T": {"g": 0.1}}
    f = metrics.paper_consistency_findings(paper)
    assert all(x["ok"] for x in f if x["check"] != "rms_over_sqrtN_reading")
    assert not [x for x in f if x["check"] == "rms_over_sqrtN_reading"][0]["ok"]
