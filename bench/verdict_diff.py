"""Verdicts of two trees on complete benchmark sets: a speed change may move numbers, never a verdict.

`NUMBA_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=TREE/workflow python bench/verdict_diff.py run RESULTS OUT
[--only blind blind_variants/bipolar2 ...]`
`python bench/verdict_diff.py compare A_DIR B_DIR`

``run`` diagnoses, with the tree on PYTHONPATH, every case of a built ``results/`` folder (RESULTS: a build's, whose
cases and keys it reads) as the workflow's rules do (config.yaml's ``diagnose`` section; a B(H) loop's material fit
from its ja/pso/lsm/external sections): results/blind/cases, results/blind_variants/NAME/cases,
results/realcores/cases, into OUT/<same folders>/diag/ID.json, and scores them against the keys (OUT/.../score.json);
then data/raw's two sweeps (OUT/raw/hall1.json, hall2) and the 8 loops of data/external (OUT/external/NAME_I.json).
CPU seconds per set go to OUT/cpu.json (one warm-up diagnosis first: numba's cache); a case whose diagnosis is
in OUT already is not diagnosed again (its CPU seconds are then not in the set's figure).

``compare`` reads two such folders (or a build's results/ for A: its blind, variants and realcores diagnoses are
where ``run`` puts them) and prints, per set, how many cases differ in verdict (effect, secondary effect,
ambiguous_with, next_measurement protocol and its ``also``) and in size (a named size moved > 5 %), each differing
case, the J-A model evaluations of both (the ``search`` block: a measure of the fitting work no machine load
moves) and the benchmark scores side by side. Exit 1 when a verdict differs. Printed, not asserted in tests.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXTERNAL = ([("m130-27s-jamodel/loops.csv", i) for i in range(3)]
            + [("mnzn-ferrite-jamodel/loops.csv", i) for i in range(4)] + [("hiperco50-pyjam/loop.csv", None)])
SIZE_TOL = 0.05


def bench_dirs(results: Path) -> list:
    """The benchmark folders below results/ that hold cases and a key: blind, blind_variants/NAME, realcores."""
    out = [Path("blind")] + sorted(p.relative_to(results) for p in (results / "blind_variants").glob("*") if p.is_dir())
    return [b for b in out + [Path("realcores")] if (results / b / "cases").is_dir()]


def run_bench(results: Path, out: Path, b: Path, cfg: dict) -> float:
    from mrhyst.blind import realcores, realscore, run
    from mrhyst.data import io

    csvs = sorted((results / b / "cases").glob("*.csv"))
    outs = [out / b / "diag" / f"{c.stem}.json" for c in csvs]
    (out / b / "diag").mkdir(parents=True, exist_ok=True)
    todo = [i for i, o in enumerate(outs) if not o.exists()]  # a run stopped half-way goes on where it stopped
    ci, oi = [csvs[i] for i in todo], [outs[i] for i in todo]
    t0 = time.process_time()
    if b.name == "realcores":
        realcores.diagnose_cases(ci, oi, cfg["diagnose"], log=lambda *a: None, material=cfg)
        tol = float(realcores.resolve(cfg.get("realcores"))["size_tol"])
        s = realscore.score(outs, results / b / "key.json", tol)
    else:
        from mrhyst import blind
        from mrhyst.blind.cases import variant_config
        from mrhyst.blind.settings import blind_settings

        run.diagnose_cases(ci, oi, cfg["diagnose"], log=lambda *a: None)
        bc = {k: v for k, v in cfg["blind"].items() if k not in ("cases_per_job", "key_jobs")}
        bcfg = blind_settings(variant_config(bc, None if b.name == "blind" else b.name))
        s = blind.score(outs, results / b / "key.json", bcfg, policy=blind.load_policy())
    cpu = time.process_time() - t0
    io.write_json(s, out / b / "score.json")
    return cpu


def run_real(out: Path, cfg: dict) -> dict:
    from mrhyst import diagnose as dg
    from mrhyst.data import io
    from mrhyst.materials.extsettings import loop_fit_settings

    settings, material = dg.resolve_config(cfg["diagnose"]), loop_fit_settings(cfg)
    cpu = {}
    for s in ("hall1", "hall2"):
        t0 = time.process_time()
        d = dg.diagnose_file(ROOT / "data/raw/li_gong_rig.csv", s, config=settings)
        io.write_json(d, out / "raw" / f"{s}.json")
        cpu[f"raw/{s}"] = time.process_time() - t0
    for p, i in EXTERNAL:
        t0 = time.process_time()
        d = dg.diagnose_bh_file(ROOT / "data/external" / p, i, config=settings, material=material)
        name = f"{p.split('/')[0]}_{i}"
        io.write_json(d, out / "external" / f"{name}.json")
        cpu[f"external/{name}"] = time.process_time() - t0
    return cpu


def cmd_run(a) -> int:
    import yaml
    from mrhyst import diagnose as dg
    from snakemake.utils import validate

    cfg = yaml.safe_load((ROOT / "config.yaml").read_text())
    validate(cfg, str(ROOT / "workflow/mrhyst/schemas/config.schema.yaml"))  # the schema's defaults, as the Snakefile
    results, out = Path(a.results), Path(a.out)
    (out / "raw").mkdir(parents=True, exist_ok=True)
    (out / "external").mkdir(parents=True, exist_ok=True)
    dg.diagnose_file(ROOT / "data/raw/li_gong_rig.csv", "hall1", config=cfg["diagnose"])  # warm-up
    cpu = {}
    for b in bench_dirs(results):
        if not a.only or str(b) in a.only:
            cpu[str(b)] = run_bench(results, out, b, cfg)
            print(b, f"{cpu[str(b)]:.1f} CPU s", flush=True)
    if not a.only or "real" in a.only:
        cpu.update(run_real(out, cfg))
    old = json.loads((out / "cpu.json").read_text()) if (out / "cpu.json").exists() else {}
    (out / "cpu.json").write_text(json.dumps({**old, **cpu}, indent=1))
    return 0


def verdict(d: dict) -> dict:
    nm = d.get("next_measurement") or {}
    return {"effect": d.get("effect"), "secondary": (d.get("secondary") or {}).get("effect"),
            "ambiguous_with": sorted(map(str, d.get("ambiguous_with") or [])),
            "next": nm.get("protocol"), "also": sorted(x.get("protocol") for x in nm.get("also") or [])}


def sizes(d: dict) -> dict:
    out = {}
    es = d.get("effect_size") or {}
    if isinstance(es, dict) and es.get("value") is not None:
        out["effect_size"] = es["value"]
    for k, v in ((d.get("secondary") or {}).get("params") or {}).items():
        if isinstance(v, (int, float)):
            out[f"secondary.{k}"] = v
    return out


def moved(a: dict, b: dict) -> list:
    return [k for k in a if k in b and not math.isclose(a[k], b[k], rel_tol=SIZE_TOL, abs_tol=1e-12)]


def evals(d: dict) -> int:
    return int((d.get("search") or {}).get("model_evaluations") or 0)


def compare_set(A: Path, B: Path) -> tuple:
    n = nv = ns = 0
    ev = [0, 0]  # J-A model evaluations of the diagnosis's fits (its ``search`` block): a load-free measure of work
    for pa in sorted(A.glob("*.json")):
        pb = B / pa.name
        if pa.name in ("score.json", "cpu.json") or not pb.exists():
            continue
        da, db = json.loads(pa.read_text()), json.loads(pb.read_text())
        n += 1
        ev[0], ev[1] = ev[0] + evals(da), ev[1] + evals(db)
        va, vb = verdict(da), verdict(db)
        if va != vb:
            nv += 1
            print(f"  VERDICT {pa.stem}: {va} -> {vb}")
        m = moved(sizes(da), sizes(db))
        if m and va["effect"] == vb["effect"]:
            ns += 1
            print(f"  size {pa.stem}: " + ", ".join(f"{k} {sizes(da)[k]:.4g} -> {sizes(db)[k]:.4g}" for k in m))
    return n, nv, ns, ev


def score_lines(a: dict, b: dict) -> list:
    out = []
    for part in ("overall", "open_world", "compound"):
        for k, v in (a.get(part) or {}).items():
            w = (b.get(part) or {}).get(k)
            if isinstance(v, (int, float)) and v != w:
                out.append(f"  {part}.{k}: {v} -> {w}")
    return out


def cmd_compare(a) -> int:
    A, B = Path(a.a), Path(a.b)
    bad = 0
    benches = sorted({p.parent.relative_to(root) for root in (A, B) for p in root.glob("**/diag") if p.is_dir()
                      and p.parent.name != "external" and "logs" not in p.parts}, key=str)
    sets = [(str(b), A / b / "diag", B / b / "diag") for b in benches] + [
        ("raw", A / "raw", B / "raw"), ("external", A / "external", B / "external")]
    for name, da, db in sets:
        if not da.is_dir() or not db.is_dir():
            print(f"{name}: missing in one of the two ({da}, {db})")
            continue
        n, nv, ns, ev = compare_set(da, db)
        bad += nv
        print(f"{name}: {n} cases, verdict differs {nv}, size moved > {SIZE_TOL:.0%} {ns}; model evaluations "
              f"{ev[0]} -> {ev[1]} ({ev[1] / max(ev[0], 1):.2f}x)")
        sa, sb = da.parent / "score.json", db.parent / "score.json"
        if sa.exists() and sb.exists():
            lines = score_lines(json.loads(sa.read_text()), json.loads(sb.read_text()))
            print("\n".join(lines) if lines else "  scores identical")
    return 1 if bad else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("results")
    r.add_argument("out")
    r.add_argument("--only", nargs="*", help="sets: blind, blind_variants/NAME, realcores, real")
    c = sub.add_parser("compare")
    c.add_argument("a")
    c.add_argument("b")
    a = ap.parse_args(argv)
    return cmd_run(a) if a.cmd == "run" else cmd_compare(a)


if __name__ == "__main__":
    sys.exit(main())
