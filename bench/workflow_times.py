"""Where a Snakemake run's wall time goes: per rule, from the run's own log (no re-run, no timed test).

    python bench/workflow_times.py SNAKEMAKE.LOG [--top 12]

Reads the "[date]" stamps Snakemake prints when it starts a job ("rule NAME:" ... "jobid: N") and when it
finishes it ("Finished jobid: N (Rule: NAME)"): per rule the job count, the summed job wall time (core-seconds
when every job is single-threaded), the median job and the span from its first start to its last finish; then
the run's total wall time and the busy-core average (summed job time / wall time). Stamps have one-second
resolution, so a rule of many sub-second jobs is shown to within a second per job.
"""

import argparse
import re
import statistics
from datetime import datetime

STAMP = re.compile(r"^\[(\w{3} \w{3} +\d+ \d\d:\d\d:\d\d \d{4})\]$")
START = re.compile(r"^(?:local)?(?:rule|checkpoint) (\w+):$")
JOBID = re.compile(r"^\s+jobid: (\d+)$")
FINISH = re.compile(r"^Finished jobid: (\d+) \(Rule: (\w+)\)$")


def parse(lines):
    """[(rule, start, end)] of every finished job (datetime stamps)."""
    now, pending, started, done = None, None, {}, []
    for line in lines:
        line = line.rstrip("\n")
        m = STAMP.match(line)
        if m:
            now = datetime.strptime(m.group(1), "%a %b %d %H:%M:%S %Y")
            continue
        m = START.match(line)
        if m:
            pending = (m.group(1), now)
            continue
        m = JOBID.match(line)
        if m and pending is not None:
            started[m.group(1)] = pending
            pending = None
            continue
        m = FINISH.match(line)
        if m and m.group(1) in started:
            rule, t0 = started.pop(m.group(1))
            done.append((rule, t0, now))
    return done


def table(done):
    """Rows (rule, jobs, summed s, median s, first start, last end), largest summed time first."""
    rules = {}
    for rule, t0, t1 in done:
        rules.setdefault(rule, []).append((t0, t1))
    rows = []
    for rule, spans in rules.items():
        d = [(t1 - t0).total_seconds() for t0, t1 in spans]
        rows.append((rule, len(d), sum(d), statistics.median(d), min(s[0] for s in spans), max(s[1] for s in spans)))
    return sorted(rows, key=lambda r: -r[2])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log")
    ap.add_argument("--top", type=int, default=0, help="only the N rules with the largest summed time")
    args = ap.parse_args(argv)
    with open(args.log) as f:
        done = parse(f)
    if not done:
        raise SystemExit(f"error: {args.log}: no finished Snakemake job found")
    rows = table(done)
    t0 = min(r[4] for r in rows)
    t1 = max(r[5] for r in rows)
    wall = (t1 - t0).total_seconds()
    busy = sum(r[2] for r in rows)
    print(f"{'rule':28s} {'jobs':>5s} {'sum s':>8s} {'median s':>9s} {'from s':>7s} {'to s':>7s}")
    for rule, n, s, med, a, b in rows[: args.top or None]:
        print(f"{rule:28s} {n:5d} {s:8.0f} {med:9.1f} {(a - t0).total_seconds():7.0f} {(b - t0).total_seconds():7.0f}")
    print(f"jobs {len(done)}; wall {wall:.0f} s ({int(wall // 60)} min {wall % 60:02.0f} s) from the first job's "
          f"start to the last one's end; summed job time {busy:.0f} s = {busy / wall:.2f} busy cores on average")


if __name__ == "__main__":
    main()
