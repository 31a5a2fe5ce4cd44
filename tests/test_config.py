"""config.yaml is checked strictly: every mistake is one line naming the key and the problem."""

import copy

import pytest
import yaml
from mrhyst import config
from mrhyst.config import ConfigError, check_config, check_section, load_config, resolve
from mrhyst.fit import identify
from mrhyst.materials import external


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


# --------------------------------------------------------------------------------------------------
# one config: the schema is the one place of the defaults (issue 11.3)
# --------------------------------------------------------------------------------------------------
RESOLVED = ("ja", "pso", "lsm", "identifiability", "metrics", "external")


def _leaves_without_default(node, where):
    node = config._node(node)
    if "default" in node:
        return []
    props = node.get("properties")
    if not props:
        return [where]
    return [w for k, p in props.items() for w in _leaves_without_default(p, f"{where}.{k}")]


@pytest.mark.parametrize("section", RESOLVED)
def test_every_property_has_a_default(section):
    schema = config._schema()
    assert _leaves_without_default(schema["properties"][section], section) == []
    # and the defaults themselves pass the schema
    check_section(section, config.defaults(section))


def test_resolve_none_is_the_schema_defaults():
    out = resolve(None, RESOLVED)
    assert out == {sec: config.defaults(sec) for sec in RESOLVED}
    assert set(config.defaults()) >= set(RESOLVED)
    assert out["pso"]["settings"]["converge"]["polish"] is True and out["ja"]["substeps"] == 2
    out["pso"]["seeds"].append(99)  # a copy: the cached defaults stay as they are
    assert 99 not in config.defaults("pso")["seeds"]
    assert identify.resolve_config(None).as_dict() == {sec: config.defaults(sec) for sec in identify.SECTIONS}
    assert external.external_config(None).as_dict() == config.defaults("external")  # frozen settings


def _set_keys(given, resolved, where):
    if isinstance(given, dict) and not where.endswith("pso.settings"):
        for k, v in given.items():
            _set_keys(v, resolved[k], f"{where}.{k}")
    else:
        assert resolved == given, where


def test_resolve_config_yaml_keeps_its_values(root):
    path = root / "config.yaml"
    cfg = load_config(path)
    out = resolve(path, RESOLVED)
    for sec in RESOLVED:
        _set_keys(cfg[sec], out[sec], sec)
    assert out["pso"]["settings"] == cfg["pso"]["settings"]
    assert identify.resolve_config(path).as_dict()["paper"] == cfg["paper"]


def test_user_pso_settings_replace_the_builtin_set():
    out = resolve({"pso": {"settings": {"mine": {"w": 0.5, "c1": 1.0, "c2": 1.0}}, "box": {"c_max": 0.9}}}, ["pso"])
    assert out["pso"]["settings"] == {"mine": {"w": 0.5, "c1": 1.0, "c2": 1.0}}
    assert out["pso"]["box"] == {**config.defaults("pso")["box"], "c_max": 0.9}  # other mappings merge


@pytest.mark.parametrize("mutate,expect", [
    (lambda c: c["lsm"].__setitem__("ftoll", 1e-9), "lsm: unknown key(s) ftoll"),
    (lambda c: c["pso"]["box"].__setitem__("c_max", "high"), "pso.box.c_max: 'high' is not of type 'number'"),
    (lambda c: c["external"].__setitem__("seed", -1), "external.seed: -1 is less than the minimum of 0"),
    (lambda c: c["metrics"].__setitem__("iterations", [20, 0]), "metrics.iterations[1]: 0 is less than"),
    (lambda c: c["identifiability"].__setitem__("threshold", float("nan")),
     "identifiability.threshold: must be a finite number"),
])
def test_bad_config_file_is_one_line_naming_the_key(mutate, expect, root, tmp_path):
    cfg = yaml.safe_load((root / "config.yaml").read_text())
    mutate(cfg)
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(cfg))
    for call in (lambda: resolve(p, RESOLVED), lambda: identify.resolve_config(p)):
        with pytest.raises(ConfigError) as e:
            call()
        msg = str(e.value)
        assert "\n" not in msg and msg.startswith(f"{p}: ") and expect in msg
