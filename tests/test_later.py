"""A later sweep of the same damper against the model calibrated from the first (issue 26, mrhyst.diagnose.later,
rules later_* in workflow/rules/reference.smk): the change the rig put in is named with its size, the reference
diagnosis's figure and JSON are the same bytes twice, and the config section moves the sweep."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml
from mrhyst import cli
from mrhyst.config import load_config
from mrhyst.data.io import read_json, read_raw
from mrhyst.diagnose import later

ROOT = Path(__file__).resolve().parents[1]
RAW = ROOT / "data" / "raw" / "li_gong_rig.csv"
NLE = 3026.415  # the rig's coil (config rig; the sidecar of data/raw)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """data/raw's hall1 loop calibrated (`mrhyst fit --method lsm`, the diagnosis's physical form) and the rig's
    later sweep with the gap opened by Nd = 5e-4 (the size the config names)."""
    tmp = tmp_path_factory.mktemp("later")
    cfg = load_config(ROOT / "config.yaml")
    loop, cal = tmp / "loop.csv", tmp / "cal.json"
    assert cli.main(["convert", str(RAW), "--sensor", "hall1", "--out", str(loop)]) == 0
    assert cli.main(["fit", str(loop), "--method", "lsm", "--form", "physical", "--out", str(cal), "--quiet"]) == 0
    lc = later.later_config({"later": {"changes": {"air_gap": {"Nd": 5.0e-4}}}})
    csv = {p.stem: p for p in later.generate(cfg["rig"], lc, NLE, tmp / "sweeps")}["air_gap"]
    return cfg, cal, csv, tmp


def _run(study, out: Path):
    cfg, cal, csv, _ = study
    out.mkdir()
    later.diagnose_both(csv, cal, "hall1", cfg, out / "ref.json", out / "ref.png", out / "plain.json")
    return read_json(out / "ref.json"), read_json(out / "plain.json")


def test_the_opened_gap_is_named_with_its_size_and_twice_the_same_bytes(study):
    tmp = study[3]
    ref, plain = _run(study, tmp / "a")
    assert ref["mode"] == "reference" and ref["effect"] == "air_gap"
    size = ref["effect_size"]
    assert size["param"] == "Nd" and abs(size["value"] - 5.0e-4) <= 0.25 * 5.0e-4  # the rig's truth
    assert ref["rms_after_T"] < ref["rms_before_T"]
    _run(study, tmp / "b")
    for name in ("ref.json", "ref.png", "plain.json"):
        assert (tmp / "a" / name).read_bytes() == (tmp / "b" / name).read_bytes(), name
    assert (tmp / "a" / "ref.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    s = later.summary("air_gap", {"Nd": 5.0e-4}, read_json(study[1]), ref, plain)
    assert s["reference"]["summary"].startswith("verdict: air_gap")
    assert [m["param"] for m in s["plain"]["absorbed"]] == ["Ms", "a", "alpha", "c", "k"]
    cal = read_json(study[1])["params"]
    alpha = next(m for m in s["plain"]["absorbed"] if m["param"] == "alpha")
    assert alpha["calibrated"] == cal["alpha"] and alpha["refit"] == plain["fit_before"]["ja_params"]["alpha"]
    rec = read_json(tmp / "sweeps" / "settings.json")  # what later_generate ran, the truth the report shows
    assert rec["truth"]["air_gap"] == {"Nd": 5.0e-4} and rec["settings"]["seed"] == 2020
    rows = later.collect(study[1], tmp / "sweeps" / "settings.json",
                         {"air_gap": (tmp / "a" / "ref.json", tmp / "a" / "plain.json", tmp / "a" / "ref.png")})
    assert rows == [dict(s, figure=str(tmp / "a" / "ref.png"))]  # what the report reads: the summary and the figure


def test_the_hotter_core_scales_the_truths_ms_only_and_the_config_moves_the_sweep(tmp_path):
    cfg = load_config(ROOT / "config.yaml")
    rig = cfg["rig"]
    hot = later.rig_after(rig, "hall1", "core_temperature", {"Ms_ratio": 0.9})
    assert list(hot["sensors"]) == ["hall1"] and "variants" not in hot
    t0, t1 = rig["sensors"]["hall1"]["truth"], hot["sensors"]["hall1"]["truth"]
    assert t1["Ms"] == pytest.approx(0.9 * t0["Ms"], rel=1e-15)
    assert {k: t1[k] for k in t1 if k != "Ms"} == {k: t0[k] for k in t0 if k != "Ms"}
    assert rig["sensors"]["hall1"]["truth"]["Ms"] == t0["Ms"]  # the config itself untouched
    gap = later.rig_after(rig, "hall1", "air_gap", {"Nd": 1e-3})
    assert gap["sensors"]["hall1"]["effects"]["air_gap"] == {"Nd": 1e-3}
    with pytest.raises(ValueError, match="later.changes"):
        later.rig_after(rig, "hall1", "hall_offset", {"offset_T": 1e-3})
    with pytest.raises(ValueError, match="later.sensor"):
        later.rig_after(copy.deepcopy(rig), "hall9", "air_gap", {"Nd": 1e-3})
    # the section's values run: a smaller Ms ratio lowers the sweep's peak by about that ratio
    peaks = []
    for ratio, sub in ((0.95, "a"), (0.85, "b")):
        lc = later.later_config({"later": {"changes": {"core_temperature": {"Ms_ratio": ratio}}}})
        paths = {p.stem: p for p in later.generate(rig, lc, NLE, tmp_path / sub)}
        raw = read_raw(paths["core_temperature"])
        v = np.asarray(raw.volts["hall1"], dtype=float)
        peaks.append(float(np.max(v) - v[0]))
    assert 0.85 / 0.95 * 0.95 < peaks[1] / peaks[0] < 1.0


# --------------------------------------------------------------------------------------------------
# the rules' scripts run the config they are given (issue 22: one owner per default) and record it
# --------------------------------------------------------------------------------------------------
def test_later_generate_and_calibrate_rules_run_the_config_they_are_given(tmp_path):
    from test_settings import NS, script, write_config

    nle = tmp_path / "nle.json"
    nle.write_text('{"n_over_le": 3026.415}')
    volts = {}
    for seed in (2020, 7):
        cfg = yaml.safe_load(Path(write_config(tmp_path, later={"seed": seed})).read_text())
        out = tmp_path / f"s{seed}"
        csvs = [str(out / f"{c}.csv") for c in cfg["later"]["changes"]]
        script(tmp_path, "later_generate.py", input=NS(nle=str(nle)), output=NS(csv=csvs, json=[], settings=""),
               params=NS(config={"rig": cfg["rig"], "later": cfg["later"]}))
        volts[seed] = read_raw(csvs[0]).volts["hall1"]
        assert read_json(out / "settings.json")["settings"]["seed"] == seed  # the output records what ran
        # the first sweep is the rig's own, whatever later.seed: the bytes of data/raw's shipped sweep
        assert (out / "first.csv").read_bytes() == RAW.read_bytes()
        assert (out / "first.json").read_bytes() == RAW.with_suffix(".json").read_bytes()
    assert not np.array_equal(volts[2020], volts[7])  # the noise is the seed's
    assert np.max(np.abs(volts[2020] - volts[7])) < 5e-3  # and only the noise: 1 mT at 5 V/T
    forms = {}
    for form in ("paper", "physical"):
        cfg = yaml.safe_load(Path(write_config(tmp_path, diagnose={"form": form})).read_text())
        out = tmp_path / f"cal_{form}.json"
        script(tmp_path, "later_calibrate.py", input=NS(csv=str(RAW), json=str(RAW.with_suffix(".json"))),
               output=NS(loop=str(tmp_path / f"loop_{form}.csv"), fit=str(out)),
               params=NS(sensor="hall1", config={k: cfg.get(k) for k in ("paper", "ja", "pso", "lsm",
                                                                       "identifiability", "metrics", "diagnose")}))
        forms[form] = read_json(out)
    assert {f: d["form"] for f, d in forms.items()} == {"paper": "paper", "physical": "physical"}
    assert forms["paper"]["params"] != forms["physical"]["params"]


def test_gdlaws_figure_rule_draws_the_figure_of_every_diagnosis_twice_the_same(study, tmp_path):
    """Rule gdlaws_figure draws a reference diagnosis as `--figure` does (here the later sweep's: the withheld Gd
    loop's needs the laws' fit, minutes)."""
    from test_settings import NS, script

    ref = study[3] / "a" / "ref.json"
    if not ref.exists():
        _run(study, study[3] / "a")
    pngs = []
    for k in range(2):
        out = tmp_path / f"g{k}.png"
        script(tmp_path, "gdlaws_figure.py", input=NS(diag=str(ref)), output=NS(png=str(out)), params=NS())
        pngs.append(out.read_bytes())
    assert pngs[0] == pngs[1] == (study[3] / "a" / "ref.png").read_bytes()
