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
