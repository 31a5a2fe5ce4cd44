"""CPU seconds per diagnosis, this tree against another, cases alternated in one session (issue 23's speed goals).

`NUMBA_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python bench/ab_cpu.py --before /path/to/other/workflow
[--rounds 3] [--repeats 2] [CASE ...]`

A CASE is ``rig:hall1`` (data/raw's sweep, a sensor), ``bh:PATH[:LOOP]`` (a third-party B(H) loop; a real-cores
B(H) case) or a Hall sweep's CSV (a blind or real-cores case, its sidecar beside it); default: the rig's hall1
and M130-27s loop 2. Each round runs one process per tree (before, then this one; the next round the other way
round), each diagnosing every case once to warm up (numba's cache) and then ``--repeats`` times, timed by the
process's CPU clock. Prints the minimum over all rounds and repeats per case and tree, and the ratio. The machine
is shared: the minimum is the steadier figure; printed, not asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT = ["rig:hall1", f"bh:{ROOT / 'data/external/m130-27s-jamodel/loops.csv'}:2"]

CHILD = r"""
import json, sys, time
from mrhyst import diagnose as dg
root, repeats, cases = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
def one(c):
    if c.startswith("rig:"):
        return dg.diagnose_file(root + "/data/raw/li_gong_rig.csv", c[4:])
    if c.startswith("bh:"):
        p, _, i = c[3:].partition(":")
        return dg.diagnose_bh_file(p, int(i) if i else None)
    return dg.diagnose_file(c, "hall1")
out = {}
for c in cases:
    one(c)
    t = []
    for _ in range(repeats):
        t0 = time.process_time()
        one(c)
        t.append(time.process_time() - t0)
    out[c] = min(t)
print(json.dumps(out))
"""


def run(tree: str, cases, repeats: int) -> dict:
    env = dict(os.environ, PYTHONPATH=tree, NUMBA_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               MPLBACKEND="agg")
    res = subprocess.run([sys.executable, "-c", CHILD, str(ROOT), str(repeats), *cases], env=env, check=True,
                         capture_output=True, text=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True, help="the other tree's workflow directory (put first on PYTHONPATH)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("cases", nargs="*")
    args = ap.parse_args(argv)
    cases = args.cases or DEFAULT
    trees = {"before": args.before, "this": str(ROOT / "workflow")}
    best = {k: {} for k in trees}
    for r in range(args.rounds):
        for name in (("before", "this") if r % 2 == 0 else ("this", "before")):
            for c, t in run(trees[name], cases, args.repeats).items():
                best[name][c] = min(t, best[name].get(c, t))
    for c in cases:
        b, a = best["before"][c], best["this"][c]
        print(f"{c}: before {b:.3f} CPU s, this tree {a:.3f} CPU s, ratio {a / b:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
