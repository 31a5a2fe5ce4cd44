"""config.yaml is checked strictly: every mistake is one line naming the key and the problem."""

import copy

import pytest
import yaml
from mrhyst.config import ConfigError, check_config, load_config


def test_repository_config_is_valid(root):
    load_config(root / "config.yaml")


MUTATIONS = {
    "mistyped top-level key": (lambda c: c.__setitem__("psoo", {}), "(top level): unknown key(s) psoo"),
    "mistyped nested key": (lambda c: c["ja"].__setitem__("sbsteps", 2), "ja: unknown key(s) sbsteps"),
    "wrong type": (lambda c: c["ja"].__setitem__("substeps", "two"), "ja.substeps: 'two' is not of type"),
    "YAML 1.1 float read as a string": (lambda c: c["paper"]["fig2_params"].__setitem__("Ms", "1.6e6"),
                                        "paper.fig2_params.Ms: '1.6e6' is not of type 'number'"),
    "out of range": (lambda c: c["paper"]["table1"]["group1"]["pso"].__setitem__("c", 1.5), "greater than or equal"),
    "unknown form": (lambda c: c["ja"].__setitem__("form", "literal"), "ja.form: 'literal' is not one of"),
    "bracket lower > upper": (lambda c: c["nle"].__setitem__("bracket", [1.0e+5, 1.0e+2]), "nle.bracket: lower"),
    "box lower > upper": (lambda c: c["pso"]["default_box"]["lo"].__setitem__("k", 1.0e+9),
                          "pso.default_box: lower k"),
    "unknown PSO setting": (lambda c: c["pso"].__setitem__("setting", "fast"), "pso.setting: 'fast' is not one of"),
    "unknown effect": (lambda c: c["rig"]["sensors"]["hall1"]["effects"].__setitem__("hal_offset", {}),
                       "unknown key(s) hal_offset"),
    "sensor limits reversed": (lambda c: c["rig"]["sensors"]["hall1"].__setitem__("output_min_V", 3.2),
                               "output_min_V (3.2) must be below"),
    "mistyped diagnose key": (lambda c: c["diagnose"].__setitem__("bic_margn", 10.0),
                              "diagnose: unknown key(s) bic_margn"),
    "diagnose box reversed": (lambda c: c["diagnose"]["box"].__setitem__("Ms", [1.0e8, 1.0e3]),
                              "diagnose.box.Ms: lower (100000000.0) must be below upper"),
    "diagnose regions crossed": (lambda c: c["diagnose"]["regions"].__setitem__("low_frac", 0.9),
                                 "diagnose.regions: low_frac (0.9) must be below high_frac"),
    "blind class not in vocabulary": (lambda c: c["blind"]["classes"].append("hysteresis"),
                                      "blind.classes[16]: 'hysteresis' is not valid under any of the given"),
    "blind count as text": (lambda c: c["blind"].__setitem__("n_per_class", "20"), "blind.n_per_class: '20' is not"),
    "blind range reversed": (lambda c: c["blind"].__setitem__("dwell_s", [0.5, 0.05]),
                             "blind.dwell_s: lower (0.5) must not exceed upper"),
    "external source without path": (lambda c: c["external"]["sources"].__setitem__("x", {"start": "auto"}),
                                     "external.sources.x: 'path' is a required property"),
    "external unknown start": (lambda c: c["external"]["sources"]["hiperco50"].__setitem__("start", "virgin"),
                               "external.sources.hiperco50.start: 'virgin' is not one of"),
    "external PSO setting": (lambda c: c["external"].__setitem__("pso_setting", "fast"),
                             "external.pso_setting: 'fast' is not one of pso.settings"),
}


@pytest.mark.parametrize("case", sorted(MUTATIONS))
def test_bad_config_one_line(case, root):
    cfg = yaml.safe_load((root / "config.yaml").read_text())
    mutate, expect = MUTATIONS[case]
    bad = copy.deepcopy(cfg)
    mutate(bad)
    with pytest.raises(ConfigError) as e:
        check_config(bad)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("config.yaml: ")
    assert expect in msg


def test_not_yaml_and_missing_file(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("ja: {form: paper\n")
    with pytest.raises(ConfigError, match=r"not valid YAML \(line"):
        load_config(p)
    with pytest.raises(ConfigError, match="file not found"):
        load_config(tmp_path / "nope.yaml")
