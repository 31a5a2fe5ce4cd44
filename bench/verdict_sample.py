"""Verdicts of a fixed sample of sweeps, for comparing two trees (a speed-up must not change a verdict).

`NUMBA_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python bench/verdict_sample.py run OUT [--cases DIR ...]`
`python bench/verdict_sample.py compare OUT_A OUT_B`

``run`` diagnoses data/raw's rig sweep (hall1, hall2), the 8 loops of data/external (M130-27s 0-2, Mn-Zn
ferrite 0-3, Hiperco 50) as B(H) loops, and every ``*.csv`` of each ``--cases`` directory (blind or real-cores
cases: a Hall sweep when a sidecar JSON is beside it, else a B(H) loop), each as the workflow's rules do (config
``diagnose`` of config.yaml, a B(H) loop's material fit from its ja/pso/lsm/external sections), and writes
each diagnosis to OUT/NAME.json and the process's CPU seconds per case to OUT/cpu.json (one warm-up diagnosis
first: numba's cache). ``compare`` prints, per case, whether the verdict (effect, ambiguous_with, secondary,
partial, the layers' verdict and budget base) is the same, the largest relative change of a named size
(effect_size, secondary's params, budget), whether the whole JSON is the same bytes (``search`` left out: it
counts model evaluations), and the CPU seconds of both runs. Printed, not asserted.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXTERNAL = ([("m130-27s-jamodel/loops.csv", i) for i in range(3)] + [("mnzn-ferrite-jamodel/loops.csv", i)
                                                                    for i in range(4)]
            + [("hiperco50-pyjam/loop.csv", None)])


def jobs(case_dirs):
    from mrhyst.data import io

    out = [(f"raw_{s}", "hall", ROOT / "data/raw/li_gong_rig.csv", s) for s in ("hall1", "hall2")]
    out += [(f"ext_{p.split('/')[0]}_{i}", "bh", ROOT / "data/external" / p, i) for p, i in EXTERNAL]
    for d in case_dirs:
        for csv in sorted(Path(d).glob("*.csv")):
            kind = "hall" if io.sidecar_path(csv).exists() else "bh"
            out.append((f"{Path(d).name}_{csv.stem}", kind, csv, "hall1" if kind == "hall" else None))
    return out


def run(out: Path, case_dirs) -> None:
    import yaml
    from mrhyst import diagnose as dg
    from mrhyst.materials.extsettings import loop_fit_settings

    conf = yaml.safe_load((ROOT / "config.yaml").read_text())
    cfg = dg.resolve_config(conf.get("diagnose"))
    material = loop_fit_settings({k: conf[k] for k in ("external", "ja", "pso", "lsm") if k in conf})
    out.mkdir(parents=True, exist_ok=True)

    def one(kind, path, arg, dest=None):
        if kind == "hall":
            return dg.diagnose_file(path, arg, out=dest, config=cfg)
        return dg.diagnose_bh_file(path, arg, out=dest, config=cfg, material=material)

    one("hall", ROOT / "data/raw/li_gong_rig.csv", "hall1")  # warm-up: numba's cache, imports
    cpu = {}
    for name, kind, path, arg in jobs(case_dirs):
        t0 = time.process_time()
        d = one(kind, path, arg, out / f"{name}.json")
        cpu[name] = time.process_time() - t0
        print(f"{name}: {d['effect']} ({cpu[name]:.2f} CPU s)", flush=True)
    (out / "cpu.json").write_text(json.dumps(cpu, indent=1))


def _sig(x, digits: int = 6):
    """Floats to ``digits`` significant digits: the partial and layers verdicts carry statistics (a BIC gain, an
    excess removed) whose last digits are no verdict (the edf by another exact formula moved a BIC gain by 1e-11)."""
    if isinstance(x, float):
        return float(f"{x:.{digits}g}")
    if isinstance(x, dict):
        return {k: _sig(v, digits) for k, v in x.items()}
    if isinstance(x, list):
        return [_sig(v, digits) for v in x]
    return x


def verdict(d: dict) -> tuple:
    lay = d.get("layers") or {}
    return (d["effect"], tuple(d.get("ambiguous_with") or ()), (d.get("secondary") or {}).get("effect"),
            json.dumps(_sig(d.get("partial")), sort_keys=True), json.dumps(_sig(lay.get("verdict")), sort_keys=True),
            (d.get("budget") or {}).get("base"))


def sizes(d: dict) -> dict:
    out = {}
    es = d.get("effect_size") or {}
    if isinstance(es.get("value"), (int, float)):
        out["effect_size"] = es["value"]
    for k, v in ((d.get("secondary") or {}).get("params") or {}).items():
        if isinstance(v, (int, float)):
            out[f"secondary.{k}"] = v
    for k, v in (d.get("budget") or {}).items():
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            out[f"budget.{k}"] = v
    return out


def rel(a, b) -> float:
    if a == b:
        return 0.0
    if not (math.isfinite(a) and math.isfinite(b)):
        return math.inf
    return abs(a - b) / max(abs(a), abs(b), 1e-300)


def compare(a: Path, b: Path) -> None:
    ca, cb = (json.loads((p / "cpu.json").read_text()) for p in (a, b))
    same_v = same_bytes = n = 0
    worst = (0.0, "")
    for name in ca:
        if name not in cb:
            continue
        da, db = (json.loads((p / f"{name}.json").read_text()) for p in (a, b))
        n += 1
        v = verdict(da) == verdict(db)
        same_v += v
        sa, sb = sizes(da), sizes(db)
        r = max([rel(sa[k], sb[k]) for k in sa if k in sb] + [0.0])
        if r > worst[0]:
            worst = (r, name)
        da.pop("search", None), db.pop("search", None)
        byt = json.dumps(da, sort_keys=True) == json.dumps(db, sort_keys=True)
        same_bytes += byt
        print(f"{name:34s} verdict {'same' if v else 'CHANGED'} {da['effect']:>18s} -> {db['effect']:<18s} "
              f"size change {r:.2e} bytes {'same' if byt else 'differ'}  CPU {ca[name]:6.2f} -> {cb[name]:6.2f} s")
        if not v:
            print("    ", verdict(da), "\n    ", verdict(db))
    print(f"{same_v} of {n} verdicts unchanged; {same_bytes} of {n} byte-identical (search counts left out); "
          f"largest relative size change {worst[0]:.2e} ({worst[1]}); CPU {sum(ca.values()):.1f} -> "
          f"{sum(cb[k] for k in ca if k in cb):.1f} s")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("out", type=Path)
    r.add_argument("--cases", nargs="*", default=[])
    c = sub.add_parser("compare")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    args = ap.parse_args(argv)
    if args.cmd == "run":
        run(args.out, args.cases)
    else:
        compare(args.a, args.b)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
