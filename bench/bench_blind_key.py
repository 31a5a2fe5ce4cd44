"""CPU and wall time of the blind benchmark's key (rule blind_generate): draws, reference fits, case files.

    NUMBA_NUM_THREADS=1 python bench/bench_blind_key.py OUT_DIR [--variant NAME] [--workers 2] [--compare KEY]

Writes OUT_DIR/cases and OUT_DIR/key.json from config.yaml's blind section (as the workflow does) and prints the
wall time, the CPU time of this process and of its worker processes, and the number of draws thrown away. With
``--compare`` it says whether the key is byte-identical to another key file (e.g. one made by an older commit:
run this script with PYTHONPATH pointing at that commit's workflow/). No timed test: compare runs made
back to back on the same machine.
"""

import argparse
import filecmp
import json
import resource
import time
from pathlib import Path

import yaml
from mrhyst import blind

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--variant", default=None, help="a blind.variants name (e.g. bipolar2)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--compare", default=None, help="another key.json to compare bytes with")
    a = ap.parse_args()
    cfg = yaml.safe_load((ROOT / "config.yaml").read_text())["blind"]
    cfg = {k: v for k, v in cfg.items() if k not in ("cases_per_job", "key_jobs")}  # workflow settings, as blind.smk
    cfg = blind.variant_config(cfg, a.variant) if a.variant else blind.variant_config(cfg)
    out = Path(a.out)
    t = time.time()
    key = blind.generate(cfg, out / "cases", out / "key.json", workers=a.workers)
    wall = time.time() - t
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    thrown = sum(c["absorbed_draws_before"] for c in key["cases"].values())
    print(f"{len(key['cases'])} cases, {thrown} draws thrown away; wall {wall:.1f} s, CPU {me.ru_utime:.1f} s "
          f"(this process) + {kids.ru_utime:.1f} s (workers)")
    if a.compare:
        same = filecmp.cmp(out / "key.json", a.compare, shallow=False)
        print(f"key {'identical to' if same else 'DIFFERS from'} {a.compare}")
        if not same:
            other = json.loads(Path(a.compare).read_text())["cases"]
            print(f"  {sum(other[i] != c for i, c in key['cases'].items() if i in other)} case entries differ")


if __name__ == "__main__":
    main()
