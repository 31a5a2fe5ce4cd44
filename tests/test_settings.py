"""One owner per default (issue 22, item 1): a flag given > the --config file > the schema, resolved once at the
boundary (every `mrhyst` command, every rule script) into frozen settings; what an output records is what ran.

Each command and rule is run three ways: a value set in the config only (it must hold: the flags default to
"not given"), the same value by flag, and the config's value with a flag against it (the flag wins). What ran is
checked from the output's numbers, not only from the label it records (the issue measured `diagnose.form:
paper` in a config recorded as paper while the physical form was fitted)."""

import copy
import dataclasses
import json
import pickle
import runpy
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml
from mrhyst import cli
from mrhyst.config import ConfigError, defaults
from mrhyst.diagnose.settings import DiagnoseSettings, resolve_config
from mrhyst.fit.settings import FitSettings
from mrhyst.fit.settings import resolve_config as fit_resolve

ROOT = Path(__file__).resolve().parent.parent
RAW = ROOT / "data" / "raw" / "li_gong_rig.csv"
# a quick diagnosis (fewer random starts, one seed, no model-form candidates, no series): what is compared here is
# which settings ran, not the verdict
FAST = {"budget_seeds": 1, "n_random": 300, "n_random_deep": 0, "series": False,
        "model_form": {"candidates": [], "n_starts": 1, "max_iter": 10, "preisach_grid": 40}}


def write_config(tmp_path, **sections) -> str:
    """config.yaml (the project's) with ``sections`` merged in at the top level (one level deep)."""
    full = yaml.safe_load((ROOT / "config.yaml").read_text())
    for name, values in sections.items():
        full[name] = {**full.get(name, {}), **values}
    p = tmp_path / f"config_{len(list(tmp_path.glob('config_*.yaml')))}.yaml"
    p.write_text(yaml.safe_dump(full))
    return str(p)


def run(*argv) -> None:
    assert cli.main([str(a) for a in argv]) == 0, argv


# --------------------------------------------------------------------------------------------------
# the settings objects
# --------------------------------------------------------------------------------------------------
def test_settings_are_frozen_typed_and_checked():
    s = resolve_config({"form": "paper", "regions": {"low_frac": 0.25}})
    assert isinstance(s, DiagnoseSettings) and s.form == "paper" and s["form"] == "paper"
    assert s.regions["low_frac"] == 0.25 and s.regions["high_frac"] == 0.666667  # the rest: the schema's
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.form = "physical"
    with pytest.raises(TypeError):
        s.regions["low_frac"] = 0.5  # nested values are read-only too
    assert isinstance(s.model_form["candidates"], tuple)
    assert {f.name: f.type for f in dataclasses.fields(s)}["bic_margin"] is float
    assert set(s) == set(defaults("diagnose"))  # one field per schema key, no second list of names
    with pytest.raises(ConfigError, match="regions: low_frac"):
        resolve_config({"regions": {"low_frac": 0.8}})  # semantic check (low < high) when made
    with pytest.raises(ConfigError, match="form"):
        s.replace(form="curved")
    assert resolve_config(s) is s and resolve_config(s, form="physical").form == "physical"
    assert s.as_dict()["model_form"]["candidates"] == list(defaults("diagnose")["model_form"]["candidates"])
    for obj in (s, fit_resolve(ROOT / "config.yaml")):  # a worker process or a deep copy gets the same settings
        assert pickle.loads(pickle.dumps(obj)) == obj and copy.deepcopy(obj) == obj


def test_fit_settings_flags_over_config_over_schema():
    f = fit_resolve({"ja": {"form": "paper"}, "pso": {"seeds": [4, 5]}})
    assert isinstance(f, FitSettings) and f.ja.form == "paper" and f["pso"]["seeds"] == (4, 5)
    assert f.ja.substeps == defaults("ja")["substeps"] and f.paper == {}
    g = f.replace(ja={"form": "physical"})
    assert g.ja.form == "physical" and g.pso is f.pso and f.ja.form == "paper"
    assert fit_resolve(None).paper is None and "paper" not in fit_resolve(None)


# --------------------------------------------------------------------------------------------------
# mrhyst diagnose (the measured case) and the rule diagnose
# --------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def diagnoses(tmp_path_factory):
    """data/raw group 1 diagnosed by `mrhyst diagnose` with diagnose.form / diagnose.seed set in --config only,
    by flag only, and against the config by flag; the rule script diagnose.py with the same config."""
    tmp = tmp_path_factory.mktemp("diag")
    paper_cfg = write_config(tmp, diagnose={**FAST, "form": "paper", "seed": 3})
    plain_cfg = write_config(tmp, diagnose=FAST)
    out = {}
    for name, argv in {"config_paper": ["--config", paper_cfg],
                       "flag_paper": ["--config", plain_cfg, "--form", "paper", "--seed", "3"],
                       "flag_physical": ["--config", paper_cfg, "--form", "physical", "--seed", "0"]}.items():
        run("diagnose", RAW, "--sensor", "hall1", *argv, "--out", tmp / f"{name}.json")
        out[name] = json.loads((tmp / f"{name}.json").read_text())
    cfg = yaml.safe_load(Path(paper_cfg).read_text())
    script(tmp, "diagnose.py", input=NS(csv=str(RAW)), output=[str(tmp / "rule.json")],
           params=NS(config=cfg, sensor="hall1"))
    out["rule"] = json.loads((tmp / "rule.json").read_text())
    script(tmp, "blind_diagnose.py", input=NS(csv=[str(RAW)]), output=[str(tmp / "blind.json")],
           params=NS(config=cfg))
    out["blind_rule"] = json.loads((tmp / "blind.json").read_text())
    return out


def test_diagnose_config_value_holds_without_a_flag(diagnoses):
    d, flag = diagnoses["config_paper"], diagnoses["flag_paper"]
    assert d["settings"]["form"] == d["input"]["form"] == "paper" and d["input"]["seed"] == 3
    # it fitted the paper form: the same numbers as `--form paper --seed 3`, not the physical form's
    assert d["rms_before_T"] == flag["rms_before_T"] and d["fit_before"] == flag["fit_before"]
    assert d["rms_before_T"] != diagnoses["flag_physical"]["rms_before_T"]


def test_diagnose_flag_overrides_the_config(diagnoses):
    d = diagnoses["flag_physical"]
    assert d["settings"]["form"] == d["input"]["form"] == "physical" and d["input"]["seed"] == 0
    assert d["rms_before_T"] != diagnoses["config_paper"]["rms_before_T"]


@pytest.mark.parametrize("rule", ["rule", "blind_rule"])
def test_diagnose_rules_run_the_config_they_are_given(diagnoses, rule):
    """Rules diagnose and blind_diagnose (a blind case is any lab's file: hall1 of data/raw here)."""
    d = diagnoses[rule]
    assert d["settings"] == diagnoses["config_paper"]["settings"] and d["input"]["seed"] == 3
    assert d["rms_before_T"] == diagnoses["config_paper"]["rms_before_T"]


def test_external_diagnose_rule_runs_and_records_the_config_it_is_given(tmp_path):
    """Rule external_diagnose: a config's diagnose.form holds in every loop's row, and the output records the
    settings that ran (a one-loop B(H) file, so the rule's row is the CLI's diagnosis of that loop)."""
    from bh_loops import write_ja_loop

    f = tmp_path / "loop.csv"
    write_ja_loop(f, seed=5)
    paper_cfg = write_config(tmp_path, diagnose={**FAST, "series": True, "form": "paper"})  # the rule draws
    run("diagnose", f, "--config", paper_cfg, "--quiet", "--out", tmp_path / "cli.json")
    cli_d = json.loads((tmp_path / "cli.json").read_text())
    out = NS(json=str(tmp_path / "ext.json"), figs=str(tmp_path / "figs"))
    script(tmp_path, "external_diagnose.py", input=NS(csv=str(f)), output=out,
           params=NS(config=yaml.safe_load(Path(paper_cfg).read_text())), wildcards=NS(source="toy"))
    ext = json.loads((tmp_path / "ext.json").read_text())
    assert ext["settings"]["form"] == cli_d["settings"]["form"] == "paper"
    assert [r["rms_before_T"] for r in ext["loops"]] == [cli_d["rms_before_T"]]


# --------------------------------------------------------------------------------------------------
# mrhyst fit and the rule fit
# --------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    p = tmp_path_factory.mktemp("loop") / "loop.csv"
    run("convert", RAW, "--sensor", "hall1", "--out", p)
    return p


def fit(tmp_path, loop, *argv) -> dict:
    out = tmp_path / f"fit_{len(list(tmp_path.glob('fit_*.json')))}.json"
    run("fit", loop, *argv, "--out", out)
    return json.loads(out.read_text())


def test_fit_config_form_and_start_hold_and_flags_override(tmp_path, loop):
    cfg = write_config(tmp_path, ja={"form": "physical"}, pso={"start": {"loop": "first_sample", "bh": "fit"}})
    a = fit(tmp_path, loop, "--method", "lsm", "--config", cfg)
    assert a["form"] == "physical" and a["start"] == "first_sample"
    b = fit(tmp_path, loop, "--method", "lsm", "--config", cfg, "--form", "paper", "--start", "demagnetised")
    assert b["form"] == "paper" and b["start"] == "demagnetised"
    c = fit(tmp_path, loop, "--method", "lsm", "--form", "physical", "--start", "first_sample")
    assert c["rms_T"] == a["rms_T"] and c["params"] == a["params"]  # what ran: the same as the flags' run
    assert b["rms_T"] != a["rms_T"]


def test_fit_config_seed_and_setting_hold_and_flags_override(tmp_path, loop):
    small = {"n_particles": 6, "iterations": 2, "seeds": [7], "cli_setting": "clerc"}
    cfg = write_config(tmp_path, pso=small)
    a = fit(tmp_path, loop, "--method", "pso", "--config", cfg)
    assert a["seed"] == 7 and a["setting"] == "clerc"
    b = fit(tmp_path, loop, "--method", "pso", "--config", cfg, "--seed", "2", "--pso-setting", "paper")
    assert b["seed"] == 2 and b["setting"] == "paper"
    c = fit(tmp_path, loop, "--method", "pso", "--config", write_config(tmp_path, pso={**small, "seeds": [0]}),
            "--seed", "7")
    assert c["history"] == a["history"]  # seed 7 by flag draws what seed 7 from the config drew


def test_fit_rule_runs_the_config_it_is_given(tmp_path, loop):
    cfg = yaml.safe_load(Path(write_config(tmp_path, ja={"form": "physical"})).read_text())
    out = tmp_path / "rule_fit.json"
    script(tmp_path, "fit.py", input=NS(loop=str(loop), nle=3026.4), output=[str(out)],
           params=NS(config=cfg, seeds=[0], method="lsm", setting=None), wildcards=NS(group="group1"))
    r = json.loads(out.read_text())
    assert r["form"] == "physical" and r["group"] == "group1"


# --------------------------------------------------------------------------------------------------
# mrhyst simulate
# --------------------------------------------------------------------------------------------------
def test_simulate_config_holds_and_flags_override(tmp_path):
    args = ["simulate", "--Ms", 1.36e6, "--a", 2.7e4, "--alpha", 1.5e-4, "--c", 0.42, "--k", 5.7e3,
            "--n-over-le", 3026.4]
    cfg = write_config(tmp_path, simulate={"form": "physical", "i_max_A": 1.5})
    run(*args, "--config", cfg, "--out", tmp_path / "cfg.csv")
    run(*args, "--form", "physical", "--i-max", 1.5, "--out", tmp_path / "flag.csv")
    run(*args, "--config", cfg, "--form", "paper", "--out", tmp_path / "over.csv")
    run(*args, "--out", tmp_path / "schema.csv")  # the schema's: paper form, 2 A
    import pandas as pd

    cfg_, flag, over, schema = (pd.read_csv(tmp_path / f"{n}.csv") for n in ("cfg", "flag", "over", "schema"))
    assert cfg_.equals(flag) and cfg_["current_A"].max() == pytest.approx(1.5)
    assert over["current_A"].max() == pytest.approx(1.5) and not np.allclose(over["B_T"], cfg_["B_T"])
    assert schema["current_A"].max() == pytest.approx(defaults("simulate")["i_max_A"])


# --------------------------------------------------------------------------------------------------
# mrhyst blind generate (blind.seed, blind.n_per_class)
# --------------------------------------------------------------------------------------------------
def test_blind_generate_config_seed_holds_and_flag_overrides(tmp_path):
    blind = {"classes": ["none"], "n_per_class": 1, "counts": {}, "seed": 11,
             "reference": {"box": defaults("diagnose")["box"], "max_nfev": 10, "open_starts": 1, "open_keep": 1}}
    cfg = write_config(tmp_path, blind=blind)
    run("blind", "generate", "--config", cfg, "--cases", tmp_path / "a", "--key", tmp_path / "a.json")
    run("blind", "generate", "--config", cfg, "--cases", tmp_path / "b", "--key", tmp_path / "b.json", "--seed", 12,
        "--n-per-class", 2)
    a, b = (json.loads((tmp_path / f"{n}.json").read_text()) for n in "ab")
    assert a["settings"]["seed"] == 11 and len(a["cases"]) == 1
    assert b["settings"]["seed"] == 12 and len(b["cases"]) == 2


# --------------------------------------------------------------------------------------------------
# rule scripts, run as Snakemake runs them (a `snakemake` object in their globals)
# --------------------------------------------------------------------------------------------------
class NS(SimpleNamespace):
    pass


def script(tmp_path, name, *, input, output, params, wildcards=None):
    sm = SimpleNamespace(input=input, output=output, params=params, wildcards=wildcards or NS(),
                         log=[str(tmp_path / f"{name}.log")], threads=1)
    runpy.run_path(str(ROOT / "workflow" / "scripts" / name), init_globals={"snakemake": sm})
