"""One owner per default (issue 22, item 1), the rules tests/test_settings.py does not cover: a value in the config a
rule is given holds (no flag: the rules have none), and the output records what ran. Each test changes one value
in a config it writes, runs the rule's script on a tiny input, and checks that a figure depending on the value
moved and that the output records the value.

Also: a B(H) diagnosis fits its material with the --config's ja/pso/lsm/external sections, not the schema's."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from bh_loops import write_ja_loop
from mrhyst import cli
from mrhyst.config import defaults
from mrhyst.materials import external
from test_settings import FAST, NS, run, script, write_config

# a quick material fit of a B(H) loop (few starts, a short swarm); form paper: not the schema's physical
QUICK_MATERIAL = {"n_particles": 6, "iterations": 3, "lsm_starts": 1, "lsm_screen": 20, "lsm_max_iterations": 20,
                  "model_selection": False, "joint": False}


def _cfg(path) -> dict:
    return yaml.safe_load(Path(path).read_text())


# --------------------------------------------------------------------------------------------------
# mrhyst diagnose BH.csv and the rule realcores_diagnose: the material fit's settings
# --------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def bh(tmp_path_factory):
    """A small J-A B(H) loop diagnosed with the material's form (external.form) set in --config only, and the
    same without a config (the schema's physical form); the rule realcores_diagnose with that config."""
    tmp = tmp_path_factory.mktemp("bh")
    f = tmp / "loop.csv"
    write_ja_loop(f, seed=11)
    paper = write_config(tmp, diagnose=FAST, external={**QUICK_MATERIAL, "form": "paper"})
    plain = write_config(tmp, diagnose=FAST, external=QUICK_MATERIAL)
    out = {"file": f, "paper_cfg": paper}
    for name, cfg in (("paper", paper), ("plain", plain)):
        run("diagnose", f, "--config", cfg, "--quiet", "--out", tmp / f"{name}.json")
        out[name] = json.loads((tmp / f"{name}.json").read_text())
    (tmp / "rc").mkdir()
    script(tmp, "realcores_diagnose.py", input=NS(csv=str(f)), output=[str(tmp / "rc" / "rc_000.json")],
           params=NS(config=_cfg(paper)))
    out["rule"] = json.loads((tmp / "rc" / "rc_000.json").read_text())
    return out


def test_bh_diagnosis_fits_its_material_with_the_config(bh):
    d, plain = bh["paper"], bh["plain"]
    mf = d["input"]["material_fit"]
    assert mf["settings"]["external"]["form"] == "paper" and mf["settings"]["external"]["n_particles"] == 6
    assert plain["input"]["material_fit"]["settings"]["external"]["form"] == defaults("external")["form"]
    # what ran: the search of the loop with the config's sections (fit_path's search, the diagnosis's start),
    # done apart (the schema's form fits other numbers)
    lp = pd.read_csv(bh["file"])
    start = "cyclic" if d["input"]["closure"]["closed"] else "fit"  # an open record: its first state fitted
    direct = external.search_path(lp["H_A_per_m"].to_numpy(), lp["B_T"].to_numpy(), start=start,
                                  config=_cfg(bh["paper_cfg"]), depth=mf["search"], substeps=mf["substeps"])
    assert mf["search"] == defaults("diagnose")["bh"]["material_search"]
    assert mf["substeps"] == d["settings"]["substeps"]  # searched at the step count the diagnosis refits at
    assert mf["rms_T"] == direct["rms_T"] and mf["ja_params"] == direct["params"]
    assert mf["rms_T"] != plain["input"]["material_fit"]["rms_T"]


def test_realcores_diagnose_rule_runs_the_config_it_is_given(bh):
    r, cli = bh["rule"], bh["paper"]
    assert r["input"]["material_fit"] == cli["input"]["material_fit"]
    assert r["settings"] == cli["settings"] and r["rms_before_T"] == cli["rms_before_T"]


# --------------------------------------------------------------------------------------------------
# rule external_fit (external section over the schema)
# --------------------------------------------------------------------------------------------------
def test_external_fit_rule_runs_the_config_it_is_given(tmp_path):
    f = tmp_path / "loop.csv"
    write_ja_loop(f, seed=4)
    res = {}
    for form in ("paper", "physical"):
        cfg = _cfg(write_config(tmp_path, external={**QUICK_MATERIAL, "form": form, "seed": 3}))
        out = tmp_path / f"{form}.json"
        script(tmp_path, "external_fit.py", input=NS(csv=str(f)), output=[str(out)], params=NS(config=cfg),
               wildcards=NS(source="toy"))
        res[form] = json.loads(out.read_text())["loops"][0]
    for form, lp in res.items():
        assert lp["form"] == form and lp["pso_settings"]["seed"] == 3 and lp["pso_settings"]["n_particles"] == 6
    assert res["paper"]["rms_T"] != res["physical"]["rms_T"]


# --------------------------------------------------------------------------------------------------
# rules realcores_score and aftercare_score: the size tolerance (a hand-made key and diagnosis)
# --------------------------------------------------------------------------------------------------
def _write(path, obj) -> str:
    Path(path).write_text(json.dumps(obj))
    return str(path)


def test_realcores_score_rule_uses_the_config_size_tol(tmp_path):
    """An offset of 10 mT named with 11.5 mT: 15 % off, within size_tol 0.2, outside 0.1."""
    key = _write(tmp_path / "key.json", {"cases": {"rc_000": {"core": "toy", "protocol": "bh", "fault": "hall_offset",
                                                              "level": 0, "size": 0.010}}})
    (tmp_path / "diag").mkdir()
    diag = _write(tmp_path / "diag" / "rc_000.json", {"effect": "hall_offset", "effect_size": {"value": 0.0115},
                                                      "rms_before_T": 0.01})
    got = {}
    for tol in (0.2, 0.1):
        cfg = _cfg(write_config(tmp_path, realcores={"size_tol": tol}))
        out = NS(score=str(tmp_path / f"s{tol}.json"), table=str(tmp_path / f"t{tol}.csv"))
        script(tmp_path, "realcores_score.py", input=NS(diag=[diag], key=key), output=out, params=NS(config=cfg))
        got[tol] = json.loads(Path(out.score).read_text())
    assert got[0.2]["size_tol"] == 0.2 and got[0.2]["rows"][0]["size_ok"] is True
    assert got[0.1]["size_tol"] == 0.1 and got[0.1]["rows"][0]["size_ok"] is False


def test_aftercare_score_rule_uses_the_config_size_tol(tmp_path):
    """An eddy lag of 0.30 named 0.345: 15 % off."""
    key = _write(tmp_path / "key.json", {"cases": {"ac_000": {"change": "eddy_lag", "size": {"lag": 0.30}}}})
    diag = _write(tmp_path / "ac_000.json", {"effect": "eddy_lag", "effect_size": {"value": 0.345},
                                             "rms_before_T": 0.01, "rms_after_T": 0.001})
    got = {}
    for tol in (0.2, 0.1):
        cfg = _cfg(write_config(tmp_path, aftercare={"size_tol": tol}))
        out = tmp_path / f"s{tol}.json"
        script(tmp_path, "aftercare_score.py", input=NS(diag=[diag], key=key), output=[str(out)],
               params=NS(config=cfg))
        got[tol] = json.loads(out.read_text())
    assert got[0.2]["size_tol"] == 0.2 and got[0.2]["cases"][0]["size_ok"] is True
    assert got[0.1]["size_tol"] == 0.1 and got[0.1]["cases"][0]["size_ok"] is False


# --------------------------------------------------------------------------------------------------
# rule aftercare_generate (aftercare section: seed, n_per_change)
# --------------------------------------------------------------------------------------------------
def test_aftercare_generate_rule_runs_the_config_it_is_given(tmp_path):
    nle = _write(tmp_path / "nle.json", {"n_over_le": 3026.4})
    keys, dwell = {}, {5: 0.1, 6: 0.25}  # the rig's dwell from the config (rig.simulate_case has no default)
    for seed in (5, 6):
        cfg = _cfg(write_config(tmp_path, aftercare={"seed": seed, "n_per_change": 1, "dwell_s": dwell[seed]}))
        key = tmp_path / f"k{seed}" / "key.json"
        key.parent.mkdir()
        script(tmp_path, "aftercare_generate.py", input=NS(nle=nle), output=NS(key=str(key)), params=NS(config=cfg))
        keys[seed] = json.loads(key.read_text())
        t = np.loadtxt(sorted((key.parent / "cases").glob("*.csv"))[0], delimiter=",", skiprows=1, usecols=1)
        assert np.diff(t) == pytest.approx(dwell[seed]) and keys[seed]["settings"]["dwell_s"] == dwell[seed]
    for seed, k in keys.items():
        assert len(k["cases"]) == 6 and k["settings"]["seed"] == seed and k["settings"]["n_per_change"] == 1
    assert [c["size"] for c in keys[5]["cases"].values()] != [c["size"] for c in keys[6]["cases"].values()]
    assert np.isfinite([v for c in keys[5]["cases"].values() for v in c["truth"].values()]).all()


# --------------------------------------------------------------------------------------------------
# rule aftercare_diagnose (sections diagnose and reference over the schema)
# --------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def after_case(tmp_path_factory):
    """An after-use case (a Hall offset against Table 1's group1_pso) by the aftercare generator."""
    from mrhyst.blind import aftercare
    from mrhyst.diagnose.reference import load_reference

    tmp = tmp_path_factory.mktemp("after")
    base = _cfg(write_config(tmp, aftercare={"seed": 5, "n_per_change": 1}))
    ac = aftercare.aftercare_config(base)
    ref = load_reference(ac["reference"], base["paper"])
    key = aftercare.generate(ac, ref.params, 3026.4, tmp / "cases", tmp / "key.json")
    case = next(c for c, v in key["cases"].items() if v["change"] == "hall_offset")
    return tmp / "cases" / f"{case}.csv"


def test_aftercare_diagnose_rule_runs_the_config_it_is_given(tmp_path, after_case):
    """The case diagnosed against Table 1 with the noise floor's clip (diagnose.noise_clip) and the temperature
    box (reference.T_box_K) set in the config: the floor moves with the clip, both are recorded."""
    got = {}
    for clip in (1.5, 3.0):
        cfg = _cfg(write_config(tmp_path, aftercare={"seed": 5, "n_per_change": 1},
                                diagnose={"noise_clip": clip, "form": "paper"}, reference={"T_box_K": 12.0}))
        out = tmp_path / f"d{clip}.json"
        script(tmp_path, "aftercare_diagnose.py", input=NS(csv=[str(after_case)]), output=[str(out)],
               params=NS(config=cfg))
        got[clip] = json.loads(out.read_text())
    for clip, d in got.items():
        assert d["settings"]["diagnose"]["noise_clip"] == clip and d["settings"]["reference"]["T_box_K"] == 12.0
        # the reference's form ran (Table 1 sets: physical), not diagnose.form (paper): the settings record no form
        assert "form" not in d["settings"]["diagnose"] and d["input"]["form"] == "physical"
    assert got[1.5]["noise_floor_T"] != got[3.0]["noise_floor_T"]
    # `mrhyst diagnose --reference` with the same config: the same diagnosis
    run("diagnose", after_case, "--sensor", "hall1", "--reference", "table1:group1_pso", "--config",
        write_config(tmp_path, diagnose={"noise_clip": 1.5, "form": "paper"}, reference={"T_box_K": 12.0}), "--out",
        tmp_path / "c.json")
    cli_d = json.loads((tmp_path / "c.json").read_text())
    assert cli_d["settings"] == got[1.5]["settings"] and cli_d["noise_floor_T"] == got[1.5]["noise_floor_T"]


@pytest.mark.parametrize("flag", ["--form", "--seed"])
def test_reference_mode_refuses_a_flag_it_would_not_run(tmp_path, after_case, flag, capsys):
    """Reference mode runs the reference's J-A form and draws nothing at random: --form and --seed are refused
    (one line, exit 2), not silently ignored."""
    code = cli.main([str(a) for a in ("diagnose", after_case, "--sensor", "hall1", "--reference",
                                      "table1:group1_pso", flag, "paper" if flag == "--form" else "3",
                                      "--out", tmp_path / "x.json")])
    err = capsys.readouterr().err
    assert code == 2 and flag in err and len(err.strip().splitlines()) == 1 and not (tmp_path / "x.json").exists()


# --------------------------------------------------------------------------------------------------
# rule realcores_generate (section realcores over the schema)
# --------------------------------------------------------------------------------------------------
def test_realcores_generate_rule_runs_the_config_it_is_given(tmp_path):
    """One ferrite loop, B(H) cases only: bh_samples and the offset level set in the config are what the cases
    have, and the key records them."""
    ferrite = str(Path(__file__).resolve().parent.parent / "data/external/mnzn-ferrite-jamodel/loops.csv")
    rc = {"sources": {"mnzn_ferrite": ferrite}, "cores": ["mnzn_ferrite_L1"], "protocols": ["bh"],
          "bh_samples": 40, "faults": {"bh": {"hall_offset": [0.05], "sensor_saturation": [0.1]}}}
    cfg = _cfg(write_config(tmp_path, realcores=rc))
    script(tmp_path, "realcores_generate.py", input=NS(), output=NS(key=str(tmp_path / "key.json")),
           params=NS(config=cfg))
    key = json.loads((tmp_path / "key.json").read_text())
    assert key["config"]["bh_samples"] == 40 and key["config"]["protocols"] == ["bh"]
    assert {v["protocol"] for v in key["cases"].values()} == {"bh"}
    clean = next(c for c, v in key["cases"].items() if v["fault"] == "none")
    off = next(c for c, v in key["cases"].items() if v["fault"] == "hall_offset")
    a, b = (pd.read_csv(tmp_path / "cases" / f"{c}.csv") for c in (clean, off))
    assert 30 <= len(a) <= 40 and key["cases"][off]["level"] == 0.05  # the 129-sample loop thinned to ~bh_samples
    # the offset is the level times the clean loop's peak |B| (sign alternating by core: the first core's is +)
    assert float(np.mean(b["B_T"] - a["B_T"])) == pytest.approx(0.05 * float(np.max(np.abs(a["B_T"]))), rel=1e-6)


# --------------------------------------------------------------------------------------------------
# rules gdlaws_fit, gdlaws_diagnose, gdlaws_table (section gdlaws over the schema)
# --------------------------------------------------------------------------------------------------
def test_gdlaws_rules_run_the_config_they_are_given(tmp_path):
    """The withheld temperature (gdlaws.withheld_C: -10 C, the schema's is -20 C) and the sizes (samples_per_loop,
    diagnose_samples) set in the config: the laws are fitted on the other loops, the -10 C loop is the one
    diagnosed, and the table marks it."""
    root = Path(__file__).resolve().parent.parent / "data/external/gd-temperature-nowicki"
    cfg = _cfg(write_config(tmp_path, gdlaws={"withheld_C": -10.0, "samples_per_loop": 20, "diagnose_samples": 60},
                            diagnose={**FAST, "stderr_rho_max": 0.3}))  # the one cap of the stderr widening
    fit, loop, diag, table = (str(tmp_path / n) for n in ("fit.json", "withheld.csv", "diag.json", "gdlaws.csv"))
    script(tmp_path, "gdlaws_fit.py", input=NS(loops=str(root / "loops.csv")), output=[fit], params=NS(config=cfg))
    script(tmp_path, "gdlaws_diagnose.py", input=NS(loops=str(root / "loops.csv"), fit=fit),
           output=NS(loop=loop, diag=diag), params=NS(config=cfg))
    script(tmp_path, "gdlaws_table.py", input=NS(fit=fit, diag=diag, peer=str(root / "peer_rms.json")),
           output=[table], params=NS(config=cfg))
    seen = sorted(float(p["temperature_C"]) for p in json.loads(Path(fit).read_text())["per_loop"])
    assert -10.0 not in seen and -20.0 in seen and len(seen) == 5
    wid = json.loads(Path(fit).read_text())["stderr_widening"]  # the Gd laws' residual: rho ~0.6 uncapped
    assert wid["rho"] == 0.3 and abs(wid["factor"] - (1.3 / 0.7) ** 0.5) < 1e-12
    assert len(pd.read_csv(loop)) == 60
    t = pd.read_csv(table)
    assert t.loc[t["role"] == "withheld", "temperature_C"].tolist() == [-10.0]
    assert t.loc[t["temperature_C"] == -20.0, "role"].tolist() == ["fitted"]


# --------------------------------------------------------------------------------------------------
# rules tables and variant_tables (section metrics: Table 3's iterations)
# --------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def pso_fit(tmp_path_factory):
    """A 3-iteration PSO fit of data/raw's group 1 by the rule fit_pso's script (its J history: 3 values)."""
    from test_settings import RAW

    tmp = tmp_path_factory.mktemp("fits")
    loop = tmp / "loop.csv"
    run("convert", RAW, "--sensor", "hall1", "--out", loop)
    cfg = _cfg(write_config(tmp, pso={"n_particles": 6, "iterations": 3}))
    out = tmp / "group1_pso_s0.json"
    script(tmp, "fit.py", input=NS(loop=str(loop), nle=3026.4), output=[str(out)],
           params=NS(config=cfg, seeds=[0], method="pso", setting="paper"), wildcards=NS(group="group1"))
    return out


@pytest.mark.parametrize("rule", ["tables.py", "variant_tables.py"])
def test_table3_rules_run_the_config_iterations(tmp_path, pso_fit, rule):
    """metrics.iterations [1, 2] in the config (the schema's: 20, 50): Table 3 gives J after 1 and 2 iterations,
    the fit's own history values (the swarm's best can only fall)."""
    hist = json.loads(pso_fit.read_text())["history"]
    assert len(hist) == 3 and hist[2] <= hist[1] <= hist[0]
    cfg = _cfg(write_config(tmp_path, metrics={"iterations": [1, 2]}))
    names = ("table1", "table2", "table3", "seed_spread", "identifiability", "selected", "paper_check")
    out = NS(**{n: str(tmp_path / f"{n}.{'json' if n in ('selected', 'paper_check') else 'csv'}") for n in names})
    inp = NS(fits=[str(pso_fit)], profiles=[], nle=_write(tmp_path / "nle.json", {"n_over_le": 3026.4}))
    script(tmp_path, rule, input=inp, output=out, params=NS(config=cfg))
    t3 = pd.read_csv(out.table3)
    assert t3["quantity"].tolist() == ["J_it1_T", "J_it2_T"]
    assert t3["ours"].tolist() == pytest.approx(hist[:2], rel=1e-12)


# --------------------------------------------------------------------------------------------------
# rule simulate_fig2 (sections ja and fig2)
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("form", ["physical", "paper"])
def test_simulate_fig2_rule_runs_the_config_form(tmp_path, form):
    cfg = _cfg(write_config(tmp_path, ja={"form": form}, fig2={"substeps": 3}))
    out = tmp_path / "fig2.csv"
    script(tmp_path, "simulate_fig2.py", input=NS(nle=_write(tmp_path / "nle.json", {"n_over_le": 3026.4})),
           output=[str(out)], params=NS(config=cfg))
    df = pd.read_csv(out)
    assert np.array_equal(df["B_T"], df[f"B_{form}_T"])
    assert not np.allclose(df["B_paper_T"], df["B_physical_T"])  # the two forms differ: the choice is visible


# --------------------------------------------------------------------------------------------------
# rules blind_generate and blind_score, and `mrhyst blind score` (section blind)
# --------------------------------------------------------------------------------------------------
def test_blind_rules_and_score_command_run_the_config_they_are_given(tmp_path):
    """One clean case generated by the rule's script with blind.seed from the config (recorded in the key),
    diagnosed, and scored by the rule's script and by `mrhyst blind score` with blind.classes from the config:
    the score's classes and per-class table are the config's."""
    blind = {"classes": ["none"], "n_per_class": 1, "counts": {}, "seed": 17,
             "reference": {"box": defaults("diagnose")["box"], "max_nfev": 10, "open_starts": 1, "open_keep": 1}}
    cfg = _cfg(write_config(tmp_path, blind=blind, diagnose=FAST))
    (tmp_path / "cases").mkdir()
    key = str(tmp_path / "key.json")
    script(tmp_path, "blind_generate.py", input=NS(), output=NS(csv=[str(tmp_path / "cases" / "case_000.csv")],
                                                                key=key), params=NS(config=cfg))
    k = json.loads(Path(key).read_text())
    assert k["settings"]["seed"] == 17 and list(k["cases"]) == ["case_000"]
    diag = str(tmp_path / "case_000.json")
    script(tmp_path, "blind_diagnose.py", input=NS(csv=[str(tmp_path / "cases" / "case_000.csv")]), output=[diag],
           params=NS(config=cfg))
    two = write_config(tmp_path, blind={**blind, "classes": ["none", "hall_offset"]}, diagnose=FAST)
    script(tmp_path, "blind_score.py", input=NS(diag=[diag], key=key), output=[str(tmp_path / "s1.json")],
           params=NS(config=cfg))
    run("blind", "score", diag, "--key", key, "--config", two, "--out", tmp_path / "s2.json")
    s1, s2 = (json.loads((tmp_path / f"s{i}.json").read_text()) for i in (1, 2))
    assert s1["classes"] == ["none"] and list(s1["per_class"]) == ["none"]
    assert s2["classes"] == ["none", "hall_offset"] and sorted(s2["per_class"]) == ["hall_offset", "none"]
    assert s2["per_class"]["hall_offset"]["n"] == 0 and s1["per_class"]["none"] == s2["per_class"]["none"]


# --------------------------------------------------------------------------------------------------
# mrhyst fit --model, and fit --temperature-laws (sections ja and temperature_laws)
# --------------------------------------------------------------------------------------------------
def test_fit_config_model_holds_and_the_flag_overrides(tmp_path, pso_fit):
    loop = pso_fit.parent / "loop.csv"
    cfg = write_config(tmp_path, ja={"model": "amplitude"})
    res = {}
    for name, argv in {"config": ["--config", cfg], "flag": ["--config", cfg, "--model", "ja"]}.items():
        run("fit", loop, "--method", "lsm", *argv, "--quiet", "--out", tmp_path / f"{name}.json")
        res[name] = json.loads((tmp_path / f"{name}.json").read_text())
    assert res["config"]["model"] == "amplitude" and res["flag"]["model"] == "ja"
    assert len(res["config"]["params"]) > len(res["flag"]["params"]) == 5  # the variant's own parameters ran


def test_fit_temperature_laws_config_holds_and_flags_override(tmp_path):
    """Three Gd loops at 55 kA/m: temperature_laws.samples_per_loop and .start, and ja.form, from the config;
    --start and --form against them."""
    gd = Path(__file__).resolve().parent.parent / "data/external/gd-temperature-nowicki/loops.csv"
    cfg = write_config(tmp_path, ja={"form": "paper"},
                       temperature_laws={"samples_per_loop": 60, "start": "demagnetised"})
    base = ["fit", gd, "--method", "lsm", "--loop-index", "0,3,6", "--temperature-laws", "--config", cfg, "--quiet"]
    run(*base, "--out", tmp_path / "a.json")
    run(*base, "--start", "first_sample", "--form", "physical", "--out", tmp_path / "b.json")
    a, b = (json.loads((tmp_path / f"{n}.json").read_text()) for n in "ab")
    assert a["samples_per_loop"] == 60 and [p["n_samples"] for p in a["per_loop"]] == [60] * 3
    assert (a["start"], a["form"]) == ("demagnetised", "paper") and (b["start"], b["form"]) == ("first_sample",
                                                                                                 "physical")
    assert max(p["rms_T"] for p in a["per_loop"] + b["per_loop"]) < 0.05  # both fitted (1.6-1.8 % of 1 T)
    assert a["per_loop"][0]["rms_T"] != b["per_loop"][0]["rms_T"]


# --------------------------------------------------------------------------------------------------
# rule profile (section identifiability)
# --------------------------------------------------------------------------------------------------
def test_profile_rule_runs_the_config_it_is_given(tmp_path, pso_fit):
    """A coarse profile (identifiability: 3 grid points, one refinement, threshold 1.5; the schema's: 21 points,
    six refinements, 1.1) of the 3-iteration fit: its grids are that coarse and its level is 1.5 J_opt."""
    cfg = _cfg(write_config(tmp_path, identifiability={"n_grid": 3, "refine_rel": [0.1], "threshold": 1.5,
                                                       "max_iterations": 3}))
    out = tmp_path / "profile.json"
    script(tmp_path, "profile.py", input=NS(loop=str(pso_fit.parent / "loop.csv"), fits=[str(pso_fit)],
                                            nle=_write(tmp_path / "nle.json", {"n_over_le": 3026.4})),
           output=[str(out)], params=NS(config=cfg), wildcards=NS(group="group1"))
    r = json.loads(out.read_text())
    assert r["threshold"] == 1.5 and r["level_T"] == pytest.approx(1.5 * r["J_opt_T"], rel=1e-12)
    assert all(len(p["grid"]) <= 3 + 2 + 1 for p in r["params"].values())  # box points, x (1 +- 0.1), x


# --------------------------------------------------------------------------------------------------
# rules infer_nle (section nle) and rig_variant (section rig)
# --------------------------------------------------------------------------------------------------
def test_infer_nle_rule_runs_the_config_use(tmp_path):
    """nle.use: group2_lsm in the config (the schema's: mean): N/Le is that set's, and the output says so."""
    cfg = _cfg(write_config(tmp_path, nle={"use": "group2_lsm"}))
    out = tmp_path / "nle.json"
    script(tmp_path, "infer_nle.py", input=NS(), output=[str(out)], params=NS(config=cfg))
    r = json.loads(out.read_text())
    assert r["use"] == "group2_lsm" and r["n_over_le"] == r["per_set"]["group2_lsm"]
    assert r["n_over_le"] != pytest.approx(float(np.mean(list(r["per_set"].values()))), rel=1e-6)


def test_rig_variant_rule_runs_the_config_rig(tmp_path):
    """A variant that changes nothing runs the config's rig.form (paper here, the schema's: physical): the same
    sweep as a variant that sets the paper form on a physical rig, another than the physical form's."""
    nle = _write(tmp_path / "nle.json", {"n_over_le": 3026.4})
    rig_cfg = _cfg(write_config(tmp_path))["rig"]
    got = {}
    for name, form, variant in (("held", "paper", {}), ("paper", "physical", {"form": "paper"}),
                                ("physical", "physical", {})):
        rc = {**rig_cfg, "form": form, "variants": {"v": variant}}
        out = NS(csv=str(tmp_path / f"{name}.csv"), json=str(tmp_path / f"{name}.json"))
        script(tmp_path, "rig_variant.py", input=NS(nle=nle), output=out, params=NS(rig=rc), wildcards=NS(variant="v"))
        got[name] = pd.read_csv(out.csv)
    assert got["held"].equals(got["paper"]) and not got["held"].equals(got["physical"])


# --------------------------------------------------------------------------------------------------
# rule report_forms (sections ja and lsm)
# --------------------------------------------------------------------------------------------------
def test_report_forms_rule_runs_the_config_it_is_given(tmp_path, pso_fit):
    """ja.substeps 3 and lsm.max_iterations 2 in the config (the schema's: 2 and 100): the Table 1 sets are
    simulated with 3 substeps (recorded) and the refit in the other form stops after at most 2 iterations."""
    fit = json.loads(pso_fit.read_text())
    sel = _write(tmp_path / "selected.json", [{"group": "group1", "method": "pso", "setting": "paper", "seed": 0,
                                                "rms_T": fit["rms_T"], "path": str(pso_fit)}])
    out = {}
    for n in (2, 5):
        cfg = _cfg(write_config(tmp_path, ja={"substeps": 3}, lsm={"max_iterations": n}))
        o = tmp_path / f"forms{n}.json"
        script(tmp_path, "report_forms.py", input=NS(nle=_write(tmp_path / "nle.json", {"n_over_le": 3026.4}),
                                                     loops=[str(pso_fit.parent / "loop.csv")], selected=sel),
               output=[str(o)], params=NS(config=cfg, groups=["group1"]))
        out[n] = json.loads(o.read_text())
    assert out[2]["substeps"] == 3 and out[2]["form_fitted"] == _cfg(write_config(tmp_path))["ja"]["form"]
    assert out[2]["fits"][0]["refit_iterations"] <= 2 < out[5]["fits"][0]["refit_iterations"]


def test_fit_config_joint_weight_holds_and_the_flag_overrides(tmp_path):
    """A joint fit of two ferrite loops: ja.joint_weight amplitude from the config, none by flag; the joint
    objective weighs the loops differently, so the fits differ."""
    ferrite = Path(__file__).resolve().parent.parent / "data/external/mnzn-ferrite-jamodel/loops.csv"
    cfg = write_config(tmp_path, ja={"joint_weight": "amplitude"}, lsm={"max_iterations": 20})
    base = ["fit", ferrite, "--method", "lsm", "--loop-index", "0,1", "--config", cfg, "--quiet"]
    run(*base, "--out", tmp_path / "a.json")
    run(*base, "--joint-weight", "none", "--out", tmp_path / "b.json")
    a, b = (json.loads((tmp_path / f"{n}.json").read_text()) for n in "ab")
    assert a["joint_weight"] == "amplitude" and b["joint_weight"] == "none" and a["params"] != b["params"]


# --------------------------------------------------------------------------------------------------
# rule report_data: the settings the report shows (mrhyst.report.collect.report_settings)
# --------------------------------------------------------------------------------------------------
def test_report_shows_the_settings_that_ran(tmp_path):
    """The config's value where it gives one (ja.substeps 3), the schema's where it gives none (ja.auto, which
    config.yaml leaves out): before, the report showed the config's keys only."""
    from mrhyst.report.collect import report_settings

    cfg = _cfg(write_config(tmp_path, ja={"substeps": 3}))
    cfg["ja"].pop("auto", None)
    s = report_settings(cfg)
    assert s["ja"]["substeps"] == 3 and s["ja"]["auto"] == defaults("ja")["auto"]
    assert s["pso"]["iterations"] == cfg["pso"]["iterations"] and "seeds" not in s["pso"]
