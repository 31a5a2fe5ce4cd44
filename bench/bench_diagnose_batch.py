"""CPU seconds per blind diagnosis (issue 15): this tree against another (e.g. main), same cases, same run.

`NUMBA_NUM_THREADS=1 python bench/bench_diagnose_batch.py [--cases results/blind/cases] [--n 30]
[--before /path/to/other/clone/workflow] [--rounds 2]`

Takes a fixed set of ``--n`` blind case CSVs (every k-th of the sorted ``case_*.csv`` in ``--cases``, a built
benchmark's cases) and diagnoses them as rule ``blind_diagnose`` does (:func:`mrhyst.blind.diagnose_cases`,
config ``diagnose``), one process per tree with that tree's ``workflow`` first on PYTHONPATH, on one core
(NUMBA_NUM_THREADS, OPENBLAS_NUM_THREADS, OMP_NUM_THREADS = 1). Each process diagnoses one warm-up case first
(numba's cache load and compilation, not counted), then times every case by the process's CPU clock. The trees
alternate (before, after; then after, before; ...) so that a change of the machine's load hits both. Prints
CPU seconds per diagnosis of each tree and the ratio, the load average before and after, and whether the two
trees reached the same verdicts (effect, ambiguous_with, secondary, partial). Printed, not asserted: the
machine is shared and noisy.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VERDICT = ("effect", "ambiguous_with", "secondary", "partial")


def pick(cases_dir: Path, n: int) -> list[str]:
    csvs = sorted(str(p) for p in cases_dir.glob("case_*.csv"))
    if len(csvs) < n:
        sys.exit(f"{cases_dir}: {len(csvs)} case CSVs, need {n} (build the blind benchmark first)")
    step = len(csvs) // n
    return csvs[::step][:n]


def worker(csvs: list[str], outdir: str) -> None:
    """Runs inside the measured tree: time each diagnosis by CPU clock; one JSON line per case on stdout."""
    import yaml
    from mrhyst.blind.run import diagnose_cases

    cfg = yaml.safe_load((ROOT / "config.yaml").read_text())["diagnose"]
    quiet = lambda *a: None  # noqa: E731
    diagnose_cases(csvs[:1], [os.path.join(outdir, "warmup.json")], cfg, log=quiet)
    for csv in csvs:
        out = os.path.join(outdir, Path(csv).stem + ".json")
        c0, w0 = time.process_time(), time.perf_counter()
        diagnose_cases([csv], [out], cfg, log=quiet)
        c1, w1 = time.process_time(), time.perf_counter()
        d = json.loads(Path(out).read_text())
        print(json.dumps({"case": Path(csv).stem, "cpu": c1 - c0, "wall": w1 - w0,
                          "verdict": [d.get(k) for k in VERDICT]}), flush=True)


def run_tree(tree: str, csvs: list[str]) -> list[dict]:
    env = dict(os.environ, PYTHONPATH=tree, NUMBA_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               MKL_NUM_THREADS="1")
    with tempfile.TemporaryDirectory() as tmp:
        p = subprocess.run([sys.executable, __file__, "--worker", tmp, *csvs], env=env, capture_output=True,
                           text=True, cwd=ROOT)
    if p.returncode:
        sys.exit(f"{tree}: worker failed\n{p.stderr[-2000:]}")
    return [json.loads(line) for line in p.stdout.splitlines() if line.startswith("{")]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=str(ROOT / "results/blind/cases"))
    ap.add_argument("--n", type=int, default=30)
    ap.add_argument("--before", help="another tree's workflow/ directory (e.g. a clone of main)")
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("csvs", nargs="*", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        return worker(args.csvs, args.worker)
    csvs = pick(Path(args.cases), args.n)
    trees = {"after": str(ROOT / "workflow")}
    if args.before:
        trees = {"before": str(Path(args.before).resolve()), **trees}
    print(f"{len(csvs)} cases from {args.cases}; trees: {trees}")
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} cores "
          "(shared machine)")
    res = {name: [] for name in trees}
    for r in range(args.rounds):
        for name in (list(trees) if r % 2 == 0 else list(trees)[::-1]):
            rows = run_tree(trees[name], csvs)
            res[name].append(rows)
            cpu, wall = [x["cpu"] for x in rows], sum(x["wall"] for x in rows)
            print(f"round {r + 1} {name:<6}: {sum(cpu):7.2f} CPU s, {sum(cpu) / len(cpu):.3f} s per diagnosis "
                  f"(median {statistics.median(cpu):.3f}, max {max(cpu):.3f}); wall {wall:.2f} s", flush=True)
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    per = {name: sum(sum(x["cpu"] for x in rows) for rows in runs) / sum(len(rows) for rows in runs)
           for name, runs in res.items()}
    for name, v in per.items():
        print(f"{name:<6}: {v:.3f} CPU s per diagnosis over {args.rounds} round(s)")
    if "before" in per:
        print(f"after / before: {per['after'] / per['before']:.3f} ({100 * (1 - per['after'] / per['before']):.1f} % "
              "less CPU per diagnosis)")
        va = {x["case"]: x["verdict"] for x in res["after"][0]}
        diff = [x["case"] for x in res["before"][0] if va[x["case"]] != x["verdict"]]
        print(f"verdicts ({', '.join(VERDICT)}): {'identical' if not diff else 'differ in ' + ' '.join(diff)}")


if __name__ == "__main__":
    main()
