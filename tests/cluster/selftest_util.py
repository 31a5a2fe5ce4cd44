"""Helpers of tests/cluster/slurm_selftest.sh (kept in Python so the shell script stays readable).

    python selftest_util.py ports N          N free TCP ports, one per line (for slurmctld and slurmd)
    python selftest_util.py copy DEST        a fresh copy of the repository, as the workflow tests make one
    python selftest_util.py compare A B      results/ of two copies byte for byte (logs excluded); exit 1 on
                                             any difference, naming the first few files that differ
    python selftest_util.py jobs LOG         the job total of a Snakemake log ("total N" of its job stats)
"""

from __future__ import annotations

import re
import socket
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from workflow_util import make_copy, tree_digest  # noqa: E402


def free_ports(n: int) -> list[int]:
    """Ports the kernel hands out as free now; all sockets are held until every port is chosen."""
    socks = []
    try:
        for _ in range(n):
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            s.bind(("", 0))
            socks.append(s)
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()


def compare(a: Path, b: Path) -> int:
    da, db = tree_digest(a / "results"), tree_digest(b / "results")
    differ = sorted(set(da) ^ set(db)) + sorted(k for k in set(da) & set(db) if da[k] != db[k])
    if not da:
        print(f"compare: {a / 'results'} is empty", file=sys.stderr)
        return 1
    if differ:
        print(f"compare: {len(differ)} of {len(set(da) | set(db))} files differ: {', '.join(differ[:8])}",
              file=sys.stderr)
        return 1
    print(f"compare: {len(da)} files under results/ identical (logs excluded)")
    return 0


def job_total(log: Path) -> int:
    totals = re.findall(r"^total\s+(\d+)\s*$", log.read_text(errors="replace"), flags=re.M)
    if not totals:
        raise SystemExit(f"jobs: no job stats in {log}")
    return int(totals[0])


def main(argv: list[str]) -> int:
    cmd, *args = argv
    if cmd == "ports":
        print("\n".join(map(str, free_ports(int(args[0])))))
    elif cmd == "copy":
        make_copy(Path(args[0]))
    elif cmd == "compare":
        return compare(Path(args[0]), Path(args[1]))
    elif cmd == "jobs":
        print(job_total(Path(args[0])))
    else:
        raise SystemExit(f"unknown command {cmd}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
