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
    # what ran: the fit of the loop with the config's sections, done apart (the schema's form fits other numbers)
    lp = pd.read_csv(bh["file"])
    direct = external.fit_path(lp["H_A_per_m"].to_numpy(), lp["B_T"].to_numpy(), start="cyclic",
                               config=_cfg(bh["paper_cfg"]))
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
    keys = {}
    for seed in (5, 6):
        cfg = _cfg(write_config(tmp_path, aftercare={"seed": seed, "n_per_change": 1}))
        key = tmp_path / f"k{seed}" / "key.json"
        key.parent.mkdir()
        script(tmp_path, "aftercare_generate.py", input=NS(nle=nle), output=NS(key=str(key)), params=NS(config=cfg))
        keys[seed] = json.loads(key.read_text())
    for seed, k in keys.items():
        assert len(k["cases"]) == 6 and k["settings"]["seed"] == seed and k["settings"]["n_per_change"] == 1
    assert [c["size"] for c in keys[5]["cases"].values()] != [c["size"] for c in keys[6]["cases"].values()]
    assert np.isfinite([v for c in keys[5]["cases"].values() for v in c["truth"].values()]).all()
