"""Rule report_data end to end on a tiny input (issue 22's list: only its settings block was tested): its script
runs on hand-made tables, the committed raw sweep and a loop converted from it, with a config whose Fig. 6 peak
differs from config.yaml's; every number checked is computed here from the files, not by mrhyst.report.collect."""

from __future__ import annotations

import hashlib
import json
import runpy
from pathlib import Path
from types import SimpleNamespace as NS

import numpy as np
import pandas as pd
import yaml
from mrhyst import cli

ROOT = Path(__file__).resolve().parents[1]
RAW = ROOT / "data" / "raw" / "li_gong_rig.csv"


def _inputs(tmp: Path) -> NS:
    loop = tmp / "group1.csv"
    assert cli.main(["convert", str(RAW), "--sensor", "hall1", "--out", str(loop)]) == 0
    cur = np.array([0.0, 1.0, 2.0, 1.0, 0.0, -1.0, -2.0, -1.0, 0.0])
    pd.DataFrame({"current_A": cur, "B_paper_T": np.tanh(cur) / 20, "B_physical_T": np.tanh(cur) / 21}).to_csv(
        tmp / "fig2.csv", index=False)
    tables = {}
    for k in ("table1", "table2", "table3", "seed_spread", "identifiability"):
        tables[k] = tmp / f"{k}.csv"
        tables[k].write_text("group,method,J_T\ngroup1,lsm,0.0005\n")
    for k, v in (("nle", {"n_over_le": 3026.4}), ("paper_check", {"checked": 1}), ("selected", []),
                 ("forms", {"form_fitted": "physical"})):
        (tmp / f"{k}.json").write_text(json.dumps(v))
    empty: list = []
    return NS(raw=[str(RAW)], raw_json=[str(RAW.with_suffix(".json"))], nle=str(tmp / "nle.json"),
              fig2=str(tmp / "fig2.csv"), loops=[str(loop)], forms=str(tmp / "forms.json"),
              paper_check=str(tmp / "paper_check.json"), selected=str(tmp / "selected.json"),
              diagnosis=empty, blind=empty, blind_variants=empty, external=empty, external_models=empty,
              external_diag=empty, realcores=empty, aftercare=empty, aftercare_diag=empty, gdlaws=empty,
              variant_tables=empty, later_cal=empty, later_settings=empty, later_ref=empty, later_plain=empty,
              later_figs=empty,
              **{k: str(v) for k, v in tables.items()})


def _run(tmp: Path, inp: NS, peak: float) -> dict:
    cfg = yaml.safe_load((ROOT / "config.yaml").read_text())
    cfg["paper"]["peak_B_T"]["group1"] = peak
    path = tmp / f"config_{peak}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    out = tmp / f"report_data_{peak}.json"
    par = NS(groups=["group1"], commit="abc123", versions={"numpy": "x"}, has_diagnosis=False, has_blind=False,
             has_external=False, variants=[])
    sm = NS(input=NS(config=str(path), **vars(inp)), output=[str(out)], params=par, config=cfg,
            log=[str(tmp / "report_data.log")], wildcards=NS(), threads=1)
    runpy.run_path(str(ROOT / "workflow" / "scripts" / "report_data.py"), init_globals={"snakemake": sm})
    return json.loads(out.read_text()), path


def test_report_data_rule_runs_and_shows_the_config_it_was_given(tmp_path):
    inp = _inputs(tmp_path)
    loop = pd.read_csv(inp.loops[0])
    measured = float(loop.loc[loop["saturated"] == 0, "B_T"].max())
    got = {}
    for peak in (0.09, 0.08):
        data, path = _run(tmp_path, inp, peak)
        got[peak] = data
        assert data["provenance"]["config_sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
        assert data["provenance"]["commit"] == "abc123" and data["nle"] == {"n_over_le": 3026.4}
        f6 = data["fig6"]["group1"]
        assert f6["paper_peak_T"] == peak and f6["peak_T"] == measured
        assert abs(f6["peak_rel_diff"] - (measured - peak) / peak) < 1e-12
        assert data["fig2"]["forms"]["paper"]["peak_T"] == np.tanh(2.0) / 20
        assert data["table1"] == [{"group": "group1", "method": "lsm", "J_T": 0.0005}] and data["selected"] == []
        sweep = data["provenance"]["measurements"]["sweeps"][0]
        assert sweep["sha256_csv"] == hashlib.sha256(RAW.read_bytes()).hexdigest() and sweep["n_samples"] == 53
        assert data["diagnosis"] is None and data["blind"] is None and data["gdlaws"] is None and data["later"] is None
    assert got[0.09]["fig6"]["group1"]["peak_rel_diff"] != got[0.08]["fig6"]["group1"]["peak_rel_diff"]
