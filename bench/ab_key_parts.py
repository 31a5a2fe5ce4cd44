"""CPU seconds of the blind key's parts (rule blind_draw), this tree against another, alternated part by part.

`NUMBA_NUM_THREADS=1 python bench/ab_key_parts.py --before OTHER/workflow [--ref RESULTS] [PART ...]`

A PART is ``main:0`` .. ``main:2`` or ``VARIANT:K`` (a blind.variants name; every benchmark is split into
config blind.key_jobs parts, as the workflow splits it); default: all nine of config.yaml. Each part runs once per
tree in its own process (before, then this one), from config.yaml's blind section, and the CPU time of that process
(user + system) is printed with the ratio. With ``--ref`` (a results/ folder of a build, e.g.
/work/ref_build/results) it says whether this tree's part file is the bytes of that build's
results/blind[_variants/NAME]/draws/part_K.json. The machine is shared: compare the two columns of one run.
"""

from __future__ import annotations

import argparse
import filecmp
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
CHILD = """import sys, yaml
from mrhyst import blind
from mrhyst.blind import cases
v, p, out, conf = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
cfg = {k: x for k, x in yaml.safe_load(open(conf))["blind"].items() if k not in ("cases_per_job", "key_jobs")}
cfg = blind.variant_config(cfg, None if v == "main" else v)
cases.write_part(cfg, cases.key_parts(cfg, int(sys.argv[5]))[p], out)
"""


def _cpu_of(pythonpath: str, part: str, out: Path, jobs: int) -> float:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    v, p = part.split(":")
    subprocess.run([sys.executable, "-c", CHILD, v, p, str(out), str(ROOT / "config.yaml"), str(jobs)], check=True,
                   env=dict(os.environ, PYTHONPATH=pythonpath))
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True, help="the other tree's workflow/ folder")
    ap.add_argument("--ref", default=None, help="a build's results/ folder to compare this tree's parts with")
    ap.add_argument("parts", nargs="*")
    a = ap.parse_args()
    blind_cfg = yaml.safe_load((ROOT / "config.yaml").read_text())["blind"]
    jobs = int(blind_cfg.get("key_jobs") or 1)
    parts = a.parts or [f"{v}:{k}" for v in ["main", *sorted(blind_cfg.get("variants") or {})] for k in range(jobs)]
    tot = [0.0, 0.0]
    with tempfile.TemporaryDirectory() as tmp:
        for part in parts:
            cpu = [_cpu_of(pp, part, Path(tmp) / f"{side}.json", jobs)
                   for side, pp in (("before", a.before), ("after", str(ROOT / "workflow")))]
            tot = [tot[0] + cpu[0], tot[1] + cpu[1]]
            same = ""
            if a.ref:
                v, k = part.split(":")
                ref = Path(a.ref) / ("blind" if v == "main" else f"blind_variants/{v}") / "draws" / f"part_{k}.json"
                same = "  same bytes as --ref" if filecmp.cmp(Path(tmp) / "after.json", ref, shallow=False) \
                    else "  DIFFERS from --ref"
            print(f"{part}: before {cpu[0]:.1f} s, this tree {cpu[1]:.1f} s, ratio {cpu[1] / cpu[0]:.2f}{same}",
                  flush=True)
    print(f"all: before {tot[0]:.1f} s, this tree {tot[1]:.1f} s, ratio {tot[1] / tot[0]:.2f}")


if __name__ == "__main__":
    main()
