"""Joint fits (one parameter set for several loops), the substep count chosen per fit, and the model
switch (issue 17, points 1-3)."""

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from mrhyst import cli
from mrhyst.data import io
from mrhyst.fit import accuracy, identify, joint

ROOT = Path(__file__).resolve().parent.parent
M130 = ROOT / "data" / "external" / "m130-27s-jamodel" / "loops.csv"
TRUE = {"Ms": 1.2e6, "a": 60.0, "alpha": 8e-5, "c": 0.3, "k": 40.0}


def closed_path(Hm, n=60):
    down = np.linspace(Hm, -Hm, n)
    return np.concatenate([down, down[-2::-1]])


def steady_loop(params, Hm, substeps=64):
    """B of the classic model's cyclic steady state on +Hm -> -Hm -> +Hm (the start state a closed loop gets)."""
    H = closed_path(Hm)
    B = np.zeros(H.size)
    x = identify.ja.as_param_array(params)
    for _ in range(4):  # the first pass starts from B[0]: iterate until B[0] is the model's own
        p = identify.Problem(H, B, np.ones(H.size, bool), **identify.problem_kw(
            form="physical", substeps=substeps, start="cyclic", cyclic_passes=4))
        B = p.model(x[None, :])[0][0]
    return H, B


@pytest.fixture(scope="module")
def three_loops(tmp_path_factory):
    rows = []
    for i, Hm in enumerate((80.0, 200.0, 600.0)):
        H, B = steady_loop(TRUE, Hm)
        rows.append(pd.DataFrame({"loop_index": i, "H_A_per_m": H, "B_T": B}))
    path = tmp_path_factory.mktemp("joint") / "loops.csv"
    io.write_csv(pd.concat(rows), path)
    return path


def test_joint_fit_recovers_the_shared_parameters(three_loops):
    r = identify.fit_file(three_loops, "lsm", start="cyclic", loop_index="all")
    for n, v in TRUE.items():
        assert r["params"][n] == pytest.approx(v, rel=2e-3), n
    assert [e["loop_index"] for e in r["per_loop"]] == [0, 1, 2]
    assert all(e["rms_rel"] < 1e-4 for e in r["per_loop"])
    # rms_T is the plain RMS over every sample, whatever the weighting
    ss = sum(e["rms_T"] ** 2 * e["n_valid"] for e in r["per_loop"])
    assert r["rms_T"] == pytest.approx(math.sqrt(ss / r["n_valid"]), rel=1e-9)
    assert r["integration_error_T"] <= r["integration_tol_T"]


def test_weight_none_is_the_plain_rms(three_loops):
    loops = io.read_loops(three_loops)
    cfg = identify.resolve_config(None)
    probs = [identify.problem_from_loop(lp, form="physical", substeps=8, start="cyclic", cfg=cfg)[0] for lp in loops]
    jp = joint.JointProblem(probs, weight="none")
    x = identify.ja.as_param_array(TRUE) * np.array([1.05, 0.9, 1.1, 1.0, 1.2])
    assert jp.cost(x[None, :])[0] == pytest.approx(jp.rms_all(x), rel=1e-12)
    r = jp.residuals(x)
    assert math.sqrt(np.mean(r**2)) == pytest.approx(jp.rms_all(x), rel=1e-12)
    ja = joint.JointProblem(probs, weight="amplitude")
    assert ja.w[2] < ja.w[1] < ja.w[0]  # the largest loop weighs least


def test_weight_own_is_the_sum_of_squared_ratios_to_each_loops_own_rms(three_loops):
    """J_own^2 = mean(s)^2 sum_i n_i (J_i / s_i)^2 / N: each loop counted by its RMS over its own fit's."""
    loops = io.read_loops(three_loops)
    cfg = identify.resolve_config(None)
    probs = [identify.problem_from_loop(lp, form="physical", substeps=8, start="cyclic", cfg=cfg)[0] for lp in loops]
    own = [1e-3, 4e-3, 2e-2]
    jp = joint.JointProblem(probs, weight="own", loop_rms=own)
    x = identify.ja.as_param_array(TRUE) * np.array([1.05, 0.9, 1.1, 1.0, 1.2])
    Ji = [p.cost(x[None, :])[0] for p in probs]
    n = [p.nv for p in probs]
    want = np.mean(own) * math.sqrt(sum(k * (J / s) ** 2 for k, J, s in zip(n, Ji, own)) / sum(n))
    assert jp.cost(x[None, :])[0] == pytest.approx(want, rel=1e-12)
    assert math.sqrt(np.mean(jp.residuals(x) ** 2)) == pytest.approx(want, rel=1e-12)
    for bad in (None, [1e-3, 4e-3], [1e-3, 0.0, 1e-2], [1e-3, float("nan"), 1e-2]):
        with pytest.raises(ValueError, match="needs one positive RMS per loop"):
            joint.JointProblem(probs, weight="own", loop_rms=bad)


def test_cli_joint_subset_and_bad_selection(three_loops, tmp_path, capsys):
    out = tmp_path / "fit.json"
    assert cli.main(["fit", str(three_loops), "--method", "lsm", "--start", "cyclic", "--loop-index", "0,2",
                     "--out", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["loop_index"] == [0, 2] and len(d["per_loop"]) == 2
    bad = tmp_path / "bad.json"
    for sel in ("0,0", "0,9", "a,b"):
        with pytest.raises(SystemExit) if sel == "a,b" else _null():
            assert cli.main(["fit", str(three_loops), "--method", "lsm", "--loop-index", sel, "--out", str(bad)]) == 2
        assert not bad.exists()
        assert len(capsys.readouterr().err.strip().splitlines()) == 1


class _null:
    def __enter__(self):
        return self

    def __exit__(self, *a):
        return False


def test_substeps_are_raised_until_the_step_error_is_within_tolerance():
    """The 217 A/m M130-27s loop: 0.093 T of step error at 2 substeps; the fit raises the count itself."""
    r = identify.fit_file(M130, "lsm", start="cyclic", loop_index=2)
    assert r["substeps_floor"] == 2 and r["substeps"] > 2
    assert r["integration_error_T"] <= r["integration_tol_T"] == pytest.approx(0.1 * r["noise_floor_T"])
    assert not r["warnings"]
    assert r["per_loop"][0]["rms_rel"] <= 0.015  # issue 17 goal for the top loop


@pytest.mark.parametrize("i", [0, 1])
def test_m130_lower_loops_within_one_percent(i):
    r = identify.fit_file(M130, "lsm", start="cyclic", loop_index=i)
    assert r["per_loop"][0]["rms_rel"] <= 0.01 and not r["warnings"]


def test_m130_joint_beats_the_peer_joint_fit():
    """One classic J-A set for the three M130 loops: every loop below JAmodel's joint fit (27 / 8.9 / 6.4 %)."""
    r = identify.fit_file(M130, "lsm", start="cyclic", loop_index="all")
    rel = [e["rms_rel"] for e in r["per_loop"]]
    assert all(a < b for a, b in zip(rel, (0.27, 0.089, 0.064))), rel
    assert not r["warnings"]


def test_noise_floor_of_white_noise():
    rng = np.random.default_rng(1)
    H = closed_path(100.0, 400)
    B = np.tanh(H / 50.0) + 1e-3 * rng.standard_normal(H.size)
    assert accuracy.noise_floor(H, B, None, None, 3.5) == pytest.approx(1e-3, rel=0.15)
    assert accuracy.tolerance(0.0, 0.1, 1e-6) == 1e-6


def test_unknown_model_is_one_error_line(tmp_path, capsys):
    out = tmp_path / "fit.json"
    assert cli.main(["fit", str(M130), "--method", "lsm", "--loop-index", "0", "--model", "nope",
                     "--out", str(out)]) == 2
    assert "model must be one of" in capsys.readouterr().err and not out.exists()


EXTRA = {"K_an": 300.0, "psi": 0.2, "t": 0.5, "n_a": -0.05, "n_alpha": -0.05, "n_k": 0.3}  # a variant's own parameters


@pytest.mark.parametrize("model", identify.model_choices())
def test_fit_with_each_model_variant_refits_its_own_loop(model, tmp_path):
    """--model plumbing: a noise-free closed loop made by the variant is fitted back by the same variant
    (from a start 20 % off in every classic parameter) to a negligible RMS, in the variant's own box."""
    names = identify.model_names(model)
    x = np.array([TRUE.get(n, EXTRA.get(n)) for n in names], dtype=float)
    H = closed_path(300.0)
    B = np.zeros(H.size)
    for _ in range(4):
        p = identify.Problem(H, B, np.ones(H.size, bool), **identify.problem_kw(
            form="physical", substeps=64, start="cyclic", cyclic_passes=4, variant=model))
        B = p.model(x[None, :])[0][0]
    path = tmp_path / "loop.csv"
    io.write_csv(pd.DataFrame({"H_A_per_m": H, "B_T": B}), path)
    x0 = x.copy()
    x0[:5] *= np.array([1.2, 0.8, 1.2, 1.0, 0.8])
    r = identify.fit_loop(io.read_loop(path), "lsm", start="cyclic", model=model, starts=[("off", x0)])
    assert r["model"] == model and tuple(r["params"]) == names
    assert set(names) <= set(r["box"]) and all(lo < hi for lo, hi in r["box"].values())
    assert r["per_loop"][0]["rms_rel"] < 1e-3, r["per_loop"][0]["rms_rel"]


def test_m130_joint_anisotropic_every_loop_within_five_percent():
    """Issue 17 goal: one parameter set of the mixed-anhysteretic (anisotropic) J-A for the three M130-27s loops,
    every loop <= 5 % of its peak (measured 1.33 / 2.24 / 3.01 %; JAmodel's joint fit: 27 / 8.9 / 6.4 %)."""
    r = identify.fit_file(M130, "lsm", start="cyclic", loop_index="all", model="anisotropic")
    assert all(e["rms_rel"] <= 0.05 for e in r["per_loop"]), [e["rms_rel"] for e in r["per_loop"]]
    assert not r["warnings"] and set(r["params"]) >= {"K_an", "psi", "t"}


FERRITE = ROOT / "data" / "external" / "mnzn-ferrite-jamodel" / "loops.csv"


# each loop's own RMS (T) from the workflow's multi-start per-loop search (results/external/mnzn_ferrite.json;
# lower than a single LSM on loop 0 and 3): the stricter reference
FERRITE_OWN_BEST_T = (2.730e-4, 4.144e-4, 1.6049e-3, 4.4134e-3)


def test_ferrite_joint_fit_follows_every_loop_within_twice_its_own_per_loop_rms():
    """Issue 17 goal: one parameter set for the four Mn-Zn ferrite loops (8-80 A/m), every loop's joint RMS
    within 2x of its own per-loop RMS. The amplitude variant (a, alpha, k scaled by the loop's peak field) with
    weight own and reweighting rounds reaches it (measured 1.86 / 1.83 / 1.85 / 1.84x against single-LSM own
    fits); the classic J-A does not (4.0 / 4.2 / 4.3 / 2.0x): one k and one anhysteretic cannot follow the
    Rayleigh-region loops' coercivity and susceptibility."""
    # as `mrhyst fit loops.csv --loop-index all --method lsm --start cyclic --model M --joint-weight own`: each
    # loop fitted alone first (its own RMS), then jointly in ja.joint_rounds reweighting rounds
    ratios = {}
    for model in ("ja", "amplitude"):
        r = identify.fit_file(FERRITE, "lsm", form="physical", start="cyclic", loop_index="all", model=model,
                              joint_weight="own")
        assert r["joint_weight"] == "own" and not r["warnings"], r["warnings"]
        own = r["joint_loop_rms_T"]
        assert len(r["joint_rounds"]) == 8 and len(own) == 4
        rms = [e["rms_T"] for e in r["per_loop"]]
        ratios[model] = [v / s for v, s in zip(rms, own)]
        if model == "amplitude":
            assert max(v / s for v, s in zip(rms, FERRITE_OWN_BEST_T)) < 2.0, rms
    assert max(ratios["amplitude"]) < 2.0, ratios
    assert max(ratios["ja"]) > 3.0, ratios
