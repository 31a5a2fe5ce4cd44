"""mrhyst.fit.identify: PSO (Eq. 14) and LSM on the objective of Eq. (15), the fit JSON, the box, traps.

Seeded throughout; no timing assertions. Small swarms where the property does not need the paper's
100 x 100 (one paper-setting fit costs ~0.3 s).
"""

import json
import logging
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.config import defaults
from mrhyst.data.io import InputError, read_loop
from mrhyst.fit import identify as idf
from mrhyst.model import ja

# the project's own copy (data/external, with its licence): a user's clone has no ../shared beside it
EXTERNAL = Path(__file__).resolve().parent.parent / "data" / "external"
NLE = 3026.4
SIGMA = 1.5e-4
HIPERCO = EXTERNAL / "hiperco50-pyjam" / "loop.csv"


def _small(cfg_pso=None, **kw):
    """A config mapping with a small swarm (tests only)."""
    pso = {"n_particles": 20, "iterations": 15}
    pso.update(cfg_pso or {})
    return {"pso": pso, **kw}


@pytest.fixture(scope="module")
def p_true(config):
    return ja.as_param_array(config["paper"]["table1"]["group1"]["pso"])


@pytest.fixture(scope="module")
def clean_loop(tmp_path_factory, p_true):
    path = tmp_path_factory.mktemp("loops") / "clean.csv"
    idf.synthetic_loop(p_true, n_over_le=NLE, sigma_T=0.0, path=path)
    return read_loop(path)


@pytest.fixture(scope="module")
def noisy_loop(tmp_path_factory, p_true):
    path = tmp_path_factory.mktemp("loops") / "noisy.csv"
    idf.synthetic_loop(p_true, n_over_le=NLE, sigma_T=SIGMA, seed=7, path=path)
    return path


# ---------------------------------------------------------------- config and box
def test_default_box_contains_every_table1_set_pm100(config):
    box = idf.default_box(None)
    t1 = config["paper"]["table1"]
    for g in t1:
        for m in t1[g]:
            p = ja.as_param_array(t1[g][m])
            lo = p * 1e-3  # the +-100 % box down to its floor
            hi = np.minimum(2.0 * p, [np.inf, np.inf, np.inf, 0.999, np.inf])
            assert np.all(box.lo <= lo), (g, m)
            assert np.all(box.hi >= hi), (g, m)
    # physical limits: Ms, a, k > 0; alpha >= 0; 0 <= c < 1
    assert box.lo[0] > 0 and box.lo[1] > 0 and box.lo[4] > 0 and box.lo[2] >= 0
    assert box.lo[3] >= 0 and box.hi[3] < 1


def test_paper_box_pm100_with_floor_and_c_cap(config):
    t = config["paper"]["table1"]["group1"]["pso"]
    box = idf.table_box(t)
    p = ja.as_param_array(t)
    np.testing.assert_allclose(box.lo, p * 1e-3)
    assert box.hi[3] == 0.999  # 2 c = 1.077 capped
    np.testing.assert_allclose(np.delete(box.hi, 3), np.delete(2 * p, 3))
    np.testing.assert_allclose(box.centre, p)  # LSM starts at the Table 1 value, not the clipped midpoint


@given(st.lists(st.floats(0.0, 1.0), min_size=5, max_size=5))
@settings(max_examples=50, deadline=None)
def test_box_maps_roundtrip(u):
    u = np.array(u)
    for box in (idf.default_box(None), idf.table_box({"Ms": 1e6, "a": 3e4, "alpha": 1e-3, "c": 0.4, "k": 5e3})):
        x = box.to_x(u)
        assert np.all(x >= box.lo) and np.all(x <= box.hi)
        np.testing.assert_allclose(box.to_u(x), u, atol=1e-12)


def test_box_for_group_and_errors(config):
    cfg = idf.resolve_config(config)
    assert cfg["pso"]["box"]["around"] == "pso"
    # one box per group, the same for both methods (issue 14): around the group's Table 1 PSO set
    box, src = idf.box_for(cfg, "group2", "lsm")
    box_p, _ = idf.box_for(cfg, "group2", "pso")
    np.testing.assert_allclose(box.centre, ja.as_param_array(config["paper"]["table1"]["group2"]["pso"]))
    for a in ("lo", "hi", "centre"):
        np.testing.assert_array_equal(getattr(box, a), getattr(box_p, a))
    assert "group2" in src and "shared" in src
    # the paper's literal reading, a stated variant: each method around its own Table 1 set
    box, src = idf.box_for(cfg.replace(pso={"box": {"around": "per_method"}}), "group2", "lsm")
    np.testing.assert_allclose(box.centre, ja.as_param_array(config["paper"]["table1"]["group2"]["lsm"]))
    assert "per method" in src
    with pytest.raises(InputError, match="group9"):
        idf.box_for(cfg, "group9", "pso")
    box, src = idf.box_for(cfg, None, "pso")
    assert src == "pso.default_box"


# ---------------------------------------------------------------- objective
def test_failed_candidates_get_large_finite_cost(clean_loop, p_true):
    prob, _ = idf.problem_from_loop(clean_loop, n_over_le=NLE, form="paper")
    bad = p_true.copy()
    bad[2] = 0.5  # alpha huge: alpha |Man - Mirr| >= k, the pole of Eq. (8)
    X = np.vstack([p_true, bad, p_true * [1, 1, 1, 0, 1] + [0, 0, 0, 1.2, 0]])  # c = 1.2: unphysical
    J = prob.cost(X)
    assert np.all(np.isfinite(J))
    assert J[0] < 1e-9
    assert J[1] == prob.fail_cost_T and J[2] == prob.fail_cost_T
    r = prob.residuals(bad)
    assert np.all(np.isfinite(r)) and np.allclose(r, prob.fail_cost_T)


@given(st.lists(st.floats(0.0, 1.0), min_size=5, max_size=5), st.sampled_from(["paper", "physical"]))
@settings(max_examples=60, deadline=None)
def test_cost_is_finite_everywhere_in_the_default_box(u, form):
    H = NLE * ja.paper_current_path()
    B, _ = ja.simulate(np.array([1.2e6, 2.7e4, 1.5e-4, 0.54, 5.7e3]), ja.paper_current_path(), NLE, form="paper",
                       substeps=8)
    prob = idf.Problem(H, B, np.ones(H.size, bool), **idf.problem_kw(form=form))
    box = idf.default_box(None)
    J = prob.cost(box.to_x(np.array(u))[None, :])
    assert np.isfinite(J[0]) and J[0] >= 0


def test_saturated_samples_are_left_out(tmp_path, p_true):
    df = idf.synthetic_loop(p_true, n_over_le=NLE)
    df["saturated"] = 0
    df.loc[[10, 11, 30], "saturated"] = 1
    df.loc[[10, 11, 30], "B_T"] = 5.0  # garbage at the flagged samples
    df.to_csv(tmp_path / "sat.csv", index=False)
    prob, info = idf.problem_from_loop(read_loop(tmp_path / "sat.csv"), n_over_le=NLE, form="paper")
    assert info["n_valid"] == 50
    assert prob.cost(p_true[None])[0] < 1e-9


# ---------------------------------------------------------------- LSM
def test_lsm_recovers_noise_free_parameters_from_a_nearby_start(clean_loop, p_true):
    prob, _ = idf.problem_from_loop(clean_loop, n_over_le=NLE, form="paper")
    box = idf.table_box(p_true)
    r = idf.run_lsm(prob, box, p_true * np.array([1.05, 0.95, 1.05, 0.97, 1.03]))
    assert r["J"] < 1e-9  # the CSV's 10 significant digits
    np.testing.assert_allclose(r["x"], p_true, rtol=1e-4)
    h = np.array(r["history"])
    assert np.all(np.diff(h) <= 0)  # TRF accepts only steps that lower the cost
    assert h[-1] == pytest.approx(r["J"])
    assert r["J_start"] > h[0]


def test_lsm_noisy_loop_fits_to_the_noise_level(noisy_loop, p_true):
    loop = read_loop(noisy_loop)
    prob, _ = idf.problem_from_loop(loop, n_over_le=NLE, form="paper")
    J_true = prob.cost(p_true[None])[0]
    r = idf.run_lsm(prob, idf.table_box(p_true), p_true * 1.1)
    # 5 parameters on 53 samples: J^2 ~ sigma^2 (1 - 5/53)
    assert 0.85 * J_true <= r["J"] <= J_true * 1.001
    assert 0.7 * SIGMA < r["J"] < 1.3 * SIGMA


def test_lsm_history_stops_at_max_iterations(noisy_loop, p_true):
    prob, _ = idf.problem_from_loop(read_loop(noisy_loop), n_over_le=NLE, form="paper")
    r = idf.run_lsm(prob, idf.table_box(p_true), p_true * 0.7, max_iterations=3)
    assert len(r["history"]) == 3 and r["status"] == -2


# ---------------------------------------------------------------- PSO
def test_pso_paper_setting_reaches_the_noise_level(noisy_loop, p_true, config):
    """The paper's full setting (100 x 100, w = 1, c1 = c2 = 2) on a noisy loop of known parameters."""
    prob, _ = idf.problem_from_loop(read_loop(noisy_loop), n_over_le=NLE, form="paper")
    J_true = prob.cost(p_true[None])[0]
    cfg = idf.resolve_config(config)
    r = idf.run_pso(prob, idf.table_box(p_true), seed=3, v_max_frac=cfg["pso"]["v_max_frac"])
    assert len(r["history"]) == 100
    assert np.all(np.diff(r["history"]) <= 0)
    assert r["J"] == pytest.approx(r["history"][-1])
    assert r["J"] <= 1.15 * J_true
    assert r["n_evals"] == 100 * 100 + 1


def test_pso_noise_free_gets_far_below_the_sigma_used_elsewhere(clean_loop, p_true):
    prob, _ = idf.problem_from_loop(clean_loop, n_over_le=NLE, form="paper")
    r = idf.run_pso(prob, idf.table_box(p_true), seed=0, n_particles=40, iterations=60)
    assert r["J"] < 0.5 * SIGMA


def test_pso_restores_the_global_rng_and_rejects_periodic(clean_loop, p_true):
    prob, _ = idf.problem_from_loop(clean_loop, n_over_le=NLE, form="paper")
    np.random.seed(123)
    before = np.random.get_state()[1].copy()
    idf.run_pso(prob, idf.table_box(p_true), seed=5, n_particles=10, iterations=3)
    assert np.array_equal(np.random.get_state()[1], before)
    with pytest.raises(InputError, match="bh_strategy"):
        idf.run_pso(prob, idf.table_box(p_true), bh_strategy="periodic", n_particles=5, iterations=2)


def test_pso_writes_no_report_log_and_leaves_root_logger_alone(tmp_path, monkeypatch, noisy_loop):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("LOG_CFG", raising=False)
    root = logging.getLogger()
    handlers, level = list(root.handlers), root.level
    idf.fit_file(noisy_loop, "pso", seed=1, config=_small())
    assert not list(tmp_path.rglob("report.log"))
    assert root.handlers == handlers and root.level == level
    assert "LOG_CFG" not in os.environ


# ---------------------------------------------------------------- fit JSON / fit_file
def test_same_seed_same_bytes_and_contract(tmp_path, noisy_loop, config):
    cfg = dict(config)
    cfg["pso"] = {**config["pso"], "n_particles": 20, "iterations": 15}
    a, b, c = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "c.json"
    kw = dict(n_over_le=NLE, config=cfg, group="group1")
    idf.fit_file(noisy_loop, "pso", seed=4, out=a, **kw)
    idf.fit_file(noisy_loop, "pso", seed=4, out=b, **kw)
    idf.fit_file(noisy_loop, "pso", seed=5, out=c, **kw)
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes() != c.read_bytes()
    d = json.loads(a.read_text())
    assert set(d["params"]) == set(ja.PARAM_NAMES)
    assert isinstance(d["rms_T"], float) and len(d["history"]) == 15
    assert d["rms_T"] == pytest.approx(d["history"][-1])
    assert d["metrics"]["rms_T"] == pytest.approx(d["rms_T"])
    assert d["form"] == "paper" and d["setting"] == "paper" and d["seed"] == 4
    assert d["integration_error_T"] < 1e-6
    assert d["box_source"].startswith("paper.table1.group1.pso")


def test_lsm_fit_file_reads_n_over_le_json(tmp_path, noisy_loop, config):
    (tmp_path / "nle.json").write_text(json.dumps({"n_over_le": NLE}))
    d = idf.fit_file(noisy_loop, "lsm", n_over_le=tmp_path / "nle.json", config=config, group="group1")
    assert d["n_over_le"] == NLE and d["seed"] is None
    assert d["start_params"] == pytest.approx(config["paper"]["table1"]["group1"]["pso"])  # the shared box's centre
    assert d["history"] and d["rms_T"] <= d["J_start_T"]
    assert d["rms_T"] < 2 * SIGMA


def test_pso_and_lsm_record_the_same_box(tmp_path, noisy_loop, config):
    """Issue 14: with a group both methods search one box, and each fit JSON records it as
    {"Ms": [lo, hi], ...} (ARCHITECTURE 4); the LSM optimum lies inside it."""
    cfg = dict(config)
    cfg["pso"] = {**config["pso"], "n_particles": 20, "iterations": 10}
    kw = dict(n_over_le=NLE, config=cfg, group="group1")
    p = idf.fit_file(noisy_loop, "pso", seed=0, out=tmp_path / "p.json", **kw)
    q = idf.fit_file(noisy_loop, "lsm", out=tmp_path / "q.json", **kw)
    bp = json.loads((tmp_path / "p.json").read_text())["box"]
    bq = json.loads((tmp_path / "q.json").read_text())["box"]
    assert bp == bq and set(bp) == set(ja.PARAM_NAMES)
    assert all(isinstance(v, list) and len(v) == 2 and v[0] < v[1] for v in bp.values())
    assert p["box_source"] == q["box_source"]
    for n, (lo, hi) in bq.items():
        assert lo <= q["params"][n] <= hi
    # the profile reads the recorded box back
    box = idf.box_from_record(q, ja.PARAM_NAMES)
    np.testing.assert_allclose(box.lo, [bq[n][0] for n in ja.PARAM_NAMES])


def test_fit_file_user_errors(noisy_loop):
    with pytest.raises(InputError, match="method"):
        idf.fit_file(noisy_loop, "ga")
    with pytest.raises(InputError, match="form"):
        idf.fit_file(noisy_loop, "lsm", form="jiles")
    with pytest.raises(InputError, match="setting"):
        idf.fit_file(noisy_loop, "pso", setting="nope", config=_small())


def test_third_party_bh_loop_hiperco_fits_sensibly():
    """data/external/hiperco50-pyjam (804 samples, starts at B = -0.096 T, not demagnetised):
    default box, physical form, M0 fitted as m0 = M0/Ms."""
    d = idf.fit_file(HIPERCO, "lsm")
    assert d["loop_kind"] == "bh" and d["form"] == "physical" and d["start"] == "fit"
    assert d["rms_T"] < 0.06  # 1.9 T loop; J-A misses the knee by a few %
    assert 1.5 < ja.MU0 * d["params"]["Ms"] < 2.5  # FeCo saturates near 2.3-2.4 T
    assert 10 < d["params"]["k"] < 200  # coercivity of the loop ~ 50 A/m
    assert -0.2 < d["m0"] < 0.0
    d2 = idf.fit_file(HIPERCO, "pso", config=_small({"n_particles": 20, "iterations": 10}))
    assert np.isfinite(d2["rms_T"]) and d2["rms_T"] < 1.0


def test_cyclic_start_bridges_the_closing_segment():
    H = np.concatenate([np.linspace(0, 500, 11), np.linspace(450, -500, 20)])
    prob = idf.Problem(H, np.zeros(H.size), np.ones(H.size, bool), **idf.problem_kw(form="paper", start="cyclic"))
    assert np.max(np.abs(np.diff(prob.path))) <= np.max(np.abs(np.diff(H))) + 1e-9
    np.testing.assert_array_equal(prob.path[prob.sel], H)


def test_cyclic_start_reaches_the_steady_state_of_a_closed_loop(p_true):
    """A closed major loop (tip -> -tip -> tip) of known parameters, taken from the model's own steady state:
    the cyclic start (first pass from the first sample's state, 3 passes) reproduces it to << the noise of any
    real measurement, where starting the first pass demagnetised would leave a visible transient."""
    Hmax = 4000.0
    branch = np.linspace(Hmax, -Hmax, 41)
    H_loop = np.concatenate([branch, branch[::-1][1:]])
    # steady state: run the loop many times from M = 0 (virgin curve to the tip first)
    warm = np.concatenate([np.linspace(0, Hmax, 21)] + [H_loop[1:]] * 8)
    B_all, ok = ja.simulate(p_true, warm, 1.0, form="paper", substeps=8)
    assert ok
    B_loop = B_all[-H_loop.size:]
    prob = idf.Problem(H_loop, B_loop, np.ones(H_loop.size, bool),
                       **idf.problem_kw(form="paper", start="cyclic", cyclic_passes=3))
    assert prob.M0_fixed == pytest.approx(B_loop[0] / ja.MU0 - H_loop[0])
    assert prob.cost(p_true[None])[0] < 1e-6 * np.max(np.abs(B_loop))


def test_fitted_m0_start_matches_a_remanent_start(p_true):
    """A loop that starts magnetised (M0 = 0.02 Ms) is fitted back with start='fit'."""
    I = ja.paper_current_path()
    M0 = 0.02 * p_true[0]
    B, ok = ja.simulate(p_true, I, NLE, M0=M0, form="paper", substeps=8)
    prob = idf.Problem(NLE * I, B, np.ones(I.size, bool), **idf.problem_kw(form="paper", start="fit"))
    box = idf.table_box(p_true).with_m0()
    r = idf.run_lsm(prob, box, np.append(p_true * 1.02, 0.0))
    assert r["J"] < 1e-8
    assert r["x"][5] == pytest.approx(0.02, rel=1e-3)


# ---------------------------------------------------------------- identifiability
def test_profile_brackets_the_truth_on_a_noisy_loop(noisy_loop, p_true):
    prob, _ = idf.problem_from_loop(read_loop(noisy_loop), n_over_le=NLE, form="paper")
    box = idf.table_box(p_true)
    pr = idf.profile(prob, box, p_true, n_grid=5, refine_rel=(0.05, 0.2), max_iterations=30)
    assert pr["J_opt_T"] <= prob.cost(p_true[None])[0]
    for i, name in enumerate(ja.PARAM_NAMES):
        p = pr["params"][name]
        assert p["J_min_T"] >= pr["J_opt_T"] * 0.999
        lo = box.lo[i] if p["range_lo"] is None else p["range_lo"]
        hi = box.hi[i] if p["range_hi"] is None else p["range_hi"]
        assert lo <= pr["x_opt"][name] <= hi
    # c and k are pinned by the loop's shape; the curvature error says so
    assert pr["params"]["c"]["rel_se_curvature"] < 0.2


def test_fresh_process_import_and_fit_leave_no_report_log(tmp_path, noisy_loop):
    """pyswarms' module-level reporters run at import: check in a fresh interpreter, cwd = tmp."""
    import subprocess
    import sys

    code = (
        "import logging; from mrhyst.fit import identify as i; "
        f"i.fit_file({str(noisy_loop)!r}, 'pso', config={{'pso': {{'n_particles': 8, 'iterations': 3}}}}); "
        "import pyswarms; r = logging.getLogger(); print(len(r.handlers), r.level)"
    )
    env = {k: v for k, v in os.environ.items() if k != "LOG_CFG"}
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["0", str(logging.WARNING)]
    assert out.stderr == ""
    assert not list(tmp_path.rglob("*.log"))


# ---------------------------------------------------------------- the CLI's default PSO converges (issue 14)
@pytest.fixture(scope="module")
def rig_shaped_loops(tmp_path_factory, config):
    """Plain J-A loops (physical form, the CLI's default) of both groups' shapes, the rig's truths at the
    study's N/Le, 0.15 mT noise; with the least-squares optimum J_ref (LSM started at the truth)."""
    out = {}
    d = tmp_path_factory.mktemp("cli_pso")
    for sensor, s in sorted(config["rig"]["sensors"].items()):
        path = d / f"{sensor}.csv"
        idf.synthetic_loop(s["truth"], n_over_le=NLE, sigma_T=SIGMA, seed=11, form="physical", path=path)
        loop = read_loop(path)
        prob, _ = idf.problem_from_loop(loop, form="physical")
        ref = idf.run_lsm(prob, idf.default_box(None), ja.as_param_array(s["truth"]), max_iterations=200)
        out[sensor] = (path, loop, ref["J"])
    return out


def test_cli_default_pso_comes_within_10_percent_of_lsm_for_every_seed(rig_shaped_loops):
    """`mrhyst fit --method pso` (default setting pso.cli_setting = converge: Clerc swarm on the log-scaled
    default box + least-squares polish), 10 seeds per loop: J <= 1.1 x the least-squares optimum."""
    pso = defaults("pso")
    setting = pso["cli_setting"]
    assert setting == "converge" and pso["settings"][setting]["polish"]
    for sensor, (_, loop, J_ref) in rig_shaped_loops.items():
        assert J_ref < 1.2 * SIGMA  # the reference is the optimum at the noise level
        ratios = []
        for seed in range(10):
            d = idf.fit_loop(loop, "pso", form="physical", seed=seed, setting=setting)
            assert d["polish"]["n_pso_iterations"] == 100 and d["rms_T"] == pytest.approx(d["history"][-1])
            ratios.append(d["rms_T"] / J_ref)
        assert max(ratios) <= 1.10, (sensor, ratios)


def test_paper_setting_alone_does_not_converge_on_the_same_loops(rig_shaped_loops):
    """Why the CLI default changed: the paper's w = 1, c1 = c2 = 2 misses the optimum by more than 10 % on
    these loops for some seed (it stays selectable as --pso-setting paper)."""
    worst = max(idf.fit_loop(loop, "pso", form="physical", seed=seed, setting="paper")["rms_T"] / J_ref
                for _, loop, J_ref in rig_shaped_loops.values() for seed in range(3))
    assert worst > 1.10


def test_cli_pso_setting_option(tmp_path, rig_shaped_loops):
    from mrhyst import cli

    path = rig_shaped_loops["hall2"][0]
    assert cli.main(["fit", str(path), "--method", "pso", "--seed", "3", "--out", str(tmp_path / "d.json")]) == 0
    d = json.loads((tmp_path / "d.json").read_text())
    assert d["setting"] == "converge" and d["polish"]["kept"]
    assert cli.main(["fit", str(path), "--method", "pso", "--pso-setting", "paper", "--out",
                     str(tmp_path / "p.json")]) == 0
    p = json.loads((tmp_path / "p.json").read_text())
    assert p["setting"] == "paper" and "polish" not in p and len(p["history"]) == 100
    assert cli.main(["fit", str(path), "--method", "pso", "--pso-setting", "nope", "--out",
                     str(tmp_path / "n.json")]) == 2
    assert not (tmp_path / "n.json").exists()


# ---------------------------------------------------------------- figures say where their data come from
def test_plotstyle_marks_rig_data_synthetic(tmp_path):
    import matplotlib

    matplotlib.use("agg")
    import matplotlib.pyplot as plt
    from mrhyst.report import plotstyle

    root = Path(__file__).resolve().parent.parent
    assert plotstyle.sidecar_synthetic(root / "data/raw/li_gong_rig.csv")  # the committed sweep is the rig's
    (tmp_path / "lab.json").write_text(json.dumps({"provenance": "bench 3, 2024-05-02"}))
    assert not plotstyle.sidecar_synthetic(tmp_path / "lab.csv")
    assert not plotstyle.sidecar_synthetic(tmp_path / "absent.csv")
    assert plotstyle.data_label(True) == "rig (synthetic)" and plotstyle.data_label(False, "Hall") == "measured (Hall)"
    fig, ax = plt.subplots(figsize=(4, 3))
    y0 = ax.get_position().y0
    t = plotstyle.mark_synthetic(fig)
    assert "SYNTHETIC" in t.get_text() and t in fig.texts
    # drawn in a strip added below the axes, so it covers no tick label
    assert fig.get_figheight() == pytest.approx(3.22) and ax.get_position().y0 > y0
    assert plotstyle.mark_synthetic(plt.figure(), False) is None
    plt.close("all")


def test_a_loop_file_is_fitted_in_its_own_h_the_sweeps_coil(tmp_path, p_true, config):
    """A lab's sweep with another coil (1500 turns/m where the paper's inferred N/Le is 3026): the loop's H column
    is its sidecar's coil x I, and a fit without n_over_le (as the workflow's fit rules run) takes H from it, records
    that N/Le, and finds the truth (before, the workflow forced the paper's N/Le on every sweep: a and k at the box
    edge, RMS 5x the noise)."""
    loop = tmp_path / "coil1500.csv"
    idf.synthetic_loop(p_true, n_over_le=1500.0, sigma_T=SIGMA, seed=3, form="paper", path=loop)
    d = idf.fit_file(loop, "lsm", n_over_le=None, config=config, group="group1")
    assert d["n_over_le"] == pytest.approx(1500.0, rel=1e-9) and "coil_turns_per_m" in d["h_source"]
    assert d["rms_T"] < 1.5 * SIGMA
