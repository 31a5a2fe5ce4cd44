"""The open-world confound of issue 23 (item 3): a Hall gain that rises with |B| on one 0 -> max -> 0 sweep,
diagnosed by two mrhyst trees (before / after), counting how often it is named ``thermal_drift`` and whether
that verdict carries ``model_form`` in ``ambiguous_with`` and a ``next_measurement``.

The cases are the blind benchmark's own ``hall_nonlinear`` open-world class (config ``blind``, drawn with
mrhyst.blind.cases as `blind generate` draws them, one rng per seed), written as raw sweeps and diagnosed by
``python -m mrhyst diagnose`` with PYTHONPATH set to each tree, one case at a time (one core).

    python bench/confound_gain_drift.py --seeds 10 [--gain 0.03 0.15] [--protocol bipolar2]
        [--before /work/main/workflow] [--after workflow] [--out rows.json]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from mrhyst import config as mconfig
from mrhyst import rig
from mrhyst.blind import cases


def make_cases(folder: Path, n: int, cls: str, gain: list | None = None, protocol: str | None = None) -> list[Path]:
    cfg = cases.variant_config(mconfig.resolve(Path(__file__).resolve().parents[1] / "config.yaml", ["blind"])["blind"])
    if gain is not None:  # a wider gain-error range than the benchmark's (config blind.openworld.hall_nonlinear)
        cfg = dict(cfg, openworld=dict(cfg.get("openworld") or {}, hall_nonlinear={"gain_error_at_peak": gain}))
    if protocol is not None:
        cfg = dict(cfg, protocol=protocol)
    current = cases.current_path(cfg)
    out, seed = [], 0
    while len(out) < n:
        spec = cases._draw_one(cls, "openworld", np.random.default_rng([20231126, seed]), cfg, current)
        seed += 1
        if spec is None:
            continue
        volts, t, cur, side = cases.simulate(spec, cfg)
        path = folder / f"{cls}_{seed:03d}.csv"
        rig.write_case(path, volts, t, cur, side)
        out.append(path)
    return out


def diagnose(path: Path, tree: str) -> dict:
    out = path.with_suffix(f".{abs(hash(tree)) % 10**6}.diag.json")
    env = dict(os.environ, PYTHONPATH=tree)
    p = subprocess.run([sys.executable, "-m", "mrhyst", "diagnose", str(path), "--sensor", "hall1", "--out", str(out)],
                       env=env, capture_output=True, text=True)
    if p.returncode != 0:
        return {"effect": "failed", "error": p.stderr.strip()}
    d = json.loads(out.read_text())
    return {"effect": d["effect"], "ambiguous_with": d.get("ambiguous_with") or [],
            "next_measurement": (d.get("next_measurement") or {}).get("protocol"),
            "separation_sigma": (d.get("next_measurement") or {}).get("separation_sigma"),
            "signatures": [s["kind"] for s in d.get("signatures") or []]}


def summary(rows: list[dict]) -> dict:
    drift = [r for r in rows if r["effect"] == "thermal_drift"]
    return {"n": len(rows), "thermal_drift": len(drift),
            "drift_with_model_form_ambiguous": sum("model_form" in r["ambiguous_with"] for r in drift),
            "drift_with_next_measurement": sum(r["next_measurement"] is not None for r in drift),
            "effects": {e: sum(r["effect"] == e for r in rows) for e in sorted({r["effect"] for r in rows})}}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--cls", default="hall_nonlinear")
    ap.add_argument("--before", default="/work/main/workflow")
    ap.add_argument("--after", default=str(Path(__file__).resolve().parents[1] / "workflow"))
    ap.add_argument("--out", default=None, help="JSON with every row and the summaries")
    ap.add_argument("--gain", type=float, nargs=2, default=None, help="gain error at the peak, range (hall_nonlinear)")
    ap.add_argument("--protocol", default=None, help="blind protocol: paper (0 -> max -> 0) or bipolar2")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        paths = make_cases(Path(tmp), a.seeds, a.cls, a.gain, a.protocol)
        res = {}
        for name, tree in (("before", a.before), ("after", a.after)):
            rows = [dict(diagnose(p, tree), case=p.stem) for p in paths]
            res[name] = {"summary": summary(rows), "rows": rows}
            print(name, json.dumps(res[name]["summary"]))
    if a.out:
        Path(a.out).write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
