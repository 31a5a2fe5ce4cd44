"""Rig variants (config rig.variants, issue 14): the same rig with one design choice changed."""

import numpy as np
import pytest
from mrhyst import rig
from mrhyst.data.io import raw_to_loop, read_raw


def test_variant_changes_only_the_truth_form(config):
    base = {k: v for k, v in config["rig"].items() if k != "variants"}
    v = rig.variant_config(config["rig"], "paper_truth")
    assert v["form"] == "paper" and base["form"] == "physical"
    assert {k: x for k, x in v.items() if k != "form"} == {k: x for k, x in base.items() if k != "form"}
    with pytest.raises(ValueError, match="no variant 'nope'"):
        rig.variant_config(config["rig"], "nope")
    with pytest.raises(ValueError, match="unknown key"):
        rig.variant_config({**config["rig"], "variants": {"x": {"noise": 1}}}, "x")


def test_paper_form_truth_keeps_the_peak_and_raises_the_remanence(tmp_path, config):
    """Same truth, coil, effects and noise seed: the paper form (no guard after the reversal) gives the same
    virgin ascent (peak within 1 %) but a higher B(0 A) after the descent, as the report's section 7b says."""
    out = {}
    for name, cfg in (("base", {k: v for k, v in config["rig"].items() if k != "variants"}),
                      ("paper", rig.variant_config(config["rig"], "paper_truth"))):
        path = tmp_path / f"{name}.csv"
        rig.generate_sweep(cfg, 3026.415, int(cfg["seed"]), path)
        raw = read_raw(path)
        out[name] = {s: raw_to_loop(raw, s)["B_T"].to_numpy() for s in sorted(cfg["sensors"])}
    for s in out["base"]:
        b, p = out["base"][s], out["paper"][s]
        assert np.max(p) == pytest.approx(np.max(b), rel=0.01)
        assert p[-1] > b[-1] + 5e-3
