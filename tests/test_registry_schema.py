"""Issue 22: the config schema's effect and model-form vocabularies are tested against the registries, so that
they cannot drift apart (a new effect is one registry entry, and this test names the schema lines it needs);
the registries refuse a malformed entry; random streams are keyed by names."""

import re

import numpy as np
import pytest
import yaml
from mrhyst.blind import openworld
from mrhyst.config import SCHEMA_PATH
from mrhyst.diagnose import modelform
from mrhyst.model import effects as fx
from mrhyst.model import streams


@pytest.fixture(scope="module")
def schema():
    return yaml.safe_load(SCHEMA_PATH.read_text())


def _diag(schema):
    return schema["properties"]["diagnose"]["properties"]


def test_blind_class_enum_is_none_the_registry_and_the_open_world(schema):
    enum, pattern = (x.get("enum") or x.get("pattern") for x in schema["$defs"]["blindclass"]["anyOf"])
    assert set(enum) == {"none", *fx.REGISTRY, *openworld.MECHANISMS}, (
        f"$defs.blindclass enum must be [none, {', '.join(fx.REGISTRY)}, {', '.join(openworld.MECHANISMS)}]")
    groups = re.fullmatch(r"\^\((.*)\)\\\+\((.*)\)\$", pattern)
    assert groups and [set(g.split("|")) for g in groups.groups()] == [set(fx.REGISTRY)] * 2, (
        f"$defs.blindclass pattern must join ({'|'.join(fx.REGISTRY)}) twice with \\+")


def test_effect_map_lists_each_effect_with_its_one_parameter(schema):
    props = schema["$defs"]["effect_map"]["properties"]
    assert set(props) == set(fx.REGISTRY)
    for name, e in fx.REGISTRY.items():
        assert props[name]["required"] == [e.param] and set(props[name]["properties"]) == {e.param}, name


def test_blind_magnitude_keys_are_the_ones_the_effects_draws_read(schema, config):
    mag = schema["properties"]["blind"]["properties"]["magnitude"]
    keys = {k for e in fx.REGISTRY.values() for k in e.draw_keys}
    assert set(mag["required"]) == set(mag["properties"]) == keys
    # and each draw runs on the project's config reading nothing else (a missing key would raise KeyError)
    case = {"sigma_T": 1.5e-4, "peak_T": 0.1, "truth": {"alpha": 1e-3}, "duration_s": 5.0, "sensitivity_V_per_T": 5.0}
    for e in fx.REGISTRY.values():
        m = {k: config["blind"]["magnitude"][k] for k in e.draw_keys}
        params, _ = e.draw(np.random.default_rng(0), m, case)
        assert set(params) == {e.param}


def test_model_form_candidates_enum_is_the_model_form_registry(schema):
    mf = _diag(schema)["model_form"]
    assert set(mf["properties"]["candidates"]["items"]["enum"]) == set(modelform.REGISTRY)
    assert set(mf["default"]["candidates"]) <= set(modelform.REGISTRY)


def test_shared_coordinates_and_needs_name_what_exists(schema):
    for name, e in fx.REGISTRY.items():
        assert set(e.needs) <= set(fx.NEEDS), name
        if e.shared is not None:
            assert e.shared.lo_key in _diag(schema), (name, e.shared.lo_key)
        for other in e.confused_with:
            assert other in fx.REGISTRY, (name, other)


def test_a_malformed_effect_is_refused():
    ok = dict(name="bad", param="p", stage="zero", doc="", signal=lambda B, v, t: B, coord="p")
    with pytest.raises(ValueError, match="coordinate of its own"):
        fx.register(fx.Effect(**dict(ok, coord=None)))
    with pytest.raises(ValueError, match="needs must be among"):
        fx.register(fx.Effect(**ok, needs={"a thermometer": "none in the file"}))
    assert "bad" not in fx.REGISTRY


def test_streams_are_keyed_by_name_not_position():
    """Recorded values (not hash(), which Python salts per process): the same on every machine and run; the
    stream of a name is the same whatever else exists, and differs between names and seeds."""
    assert streams.name_key("hall_offset") == 15968593459836837945
    assert streams.stream(7, 1, "air_gap").uniform(size=2).tolist() == [0.0018986790567279144, 0.5044380599407958]
    a = streams.stream(7, 1, "air_gap").uniform(size=3)
    assert np.array_equal(a, streams.stream(7, 1, "air_gap").uniform(size=3))
    assert not np.array_equal(a, streams.stream(7, 1, "hall_offset").uniform(size=3))
    assert not np.array_equal(a, streams.stream(8, 1, "air_gap").uniform(size=3))


class _Langevin:
    """A toy model-form candidate: the anhysteretic Langevin curve alone, B = mu0 (H + Ms L(H / a)) (no loop)."""

    name, doc, n_params = "toy_langevin", "toy: anhysteretic Langevin curve, no hysteresis", 2

    def __init__(self, prob):
        self.prob, self.H = prob, prob.sw.n_over_le * prob.sw.current
        self.lo, self.hi = prob.lo[:2].copy(), prob.hi[:2].copy()
        self.steps = np.array([1e-7, 1e-7])

    def forward(self, X):
        X = np.atleast_2d(X)
        x = self.H[None, :] / np.exp(X[:, 1:2])
        with np.errstate(divide="ignore", invalid="ignore"):
            L = np.where(np.abs(x) < 1e-4, x / 3.0, 1.0 / np.tanh(x) - 1.0 / x)
        B = 4e-7 * np.pi * (self.H[None, :] + np.exp(X[:, 0:1]) * L)
        return B, np.all(np.isfinite(B), axis=1)

    def starts(self, base, rng, k):
        return np.clip(base.u[:2] + rng.normal(0.0, 0.3, (k, 2)), self.lo, self.hi)

    def params(self, x):
        return {"Ms": float(np.exp(x[0])), "a": float(np.exp(x[1]))}


def test_a_registered_model_form_candidate_is_fitted_and_leaves_the_others_as_they_were():
    """One registry entry makes a model-form candidate: fitted beside the others, and the Preisach candidate
    (which draws random starts) gives the same bytes with or without it before it in the list."""
    from mrhyst import diagnose as dg
    from mrhyst import rig
    from mrhyst.diagnose.candidates import fit_plain
    from mrhyst.model import ja

    truth, nle = np.array([1.357e6, 2.6882e4, 1.4697e-4, 0.4199, 5.6943e3]), 3026.4
    current = ja.paper_current_path()
    t = rig.sample_times(current.size, 0.1)
    B = rig.observe(truth, current, t, nle)[0] + 1.5e-4 * np.random.default_rng(5).standard_normal(current.size)
    cfg = dg.resolve_config({"n_random": 300, "model_form": {"n_starts": 3, "max_iter": 60, "preisach_grid": 16}})
    prob = dg.Problem(dg.sweep_from_arrays(current, t, B, nle, cfg=cfg), cfg)
    base = fit_plain(prob, [0])[0]
    alone = modelform.fit_all(prob, base, 0)
    modelform.register(modelform.ModelForm("toy_langevin", lambda p, mf: _Langevin(p), _Langevin.doc))
    try:
        prob.cfg = dict(cfg, model_form=dict(cfg["model_form"], candidates=["toy_langevin", "preisach"]))
        both = modelform.fit_all(prob, base, 0)
    finally:
        modelform.unregister("toy_langevin")
    prob.cfg = dict(cfg, model_form=dict(cfg["model_form"], candidates=["preisach"]))
    only = modelform.fit_all(prob, base, 0)
    assert np.array_equal(both["preisach"]["x"], only["preisach"]["x"])
    assert both["preisach"]["bic"] == only["preisach"]["bic"] == alone["preisach"]["bic"]
    # a curve without hysteresis cannot follow a J-A loop as J-A does
    assert both["toy_langevin"]["n_params"] == 2 and both["toy_langevin"]["rms_T"] > 3 * base.rms
