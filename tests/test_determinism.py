"""Determinism of the whole workflow (issue 6), with the small config of workflow_util.SMALL (every stage runs:
fits, profiles, tables, figures, diagnosis, blind, external, report), against the shared -c2 build of
conftest.small_built. One more build of the same config, in a copy of its own, shows all of it:

- a run stopped by Ctrl-C, resumed, and that resumption killed by SIGKILL (no chance to clean up), is completed by
  a rerun (after SIGKILL: `snakemake --unlock` first; profiles/default sets rerun-incomplete), and what it leaves
  is byte-identical to the uninterrupted reference. The kill points are states of the run (gate jobs), not times;
- that copy runs one job at a time throughout (the interrupted runs' gate job holds one of their two cores, the
  final rerun is -c1), the reference two at a time, in another directory: so neither a rerun, nor the directory,
  nor the number of cores changes a byte (tables, JSON, CSV, figures, notebooks, report).
"""

import os
import signal
import subprocess
import sys
import time

import pytest
from workflow_util import small_copy, snakemake, tree_digest

pytestmark = pytest.mark.slow


def _diff(a: dict, b: dict) -> list[str]:
    return sorted(set(a) ^ set(b)) + sorted(k for k in set(a) & set(b) if a[k] != b[k])


@pytest.fixture(scope="module")
def reference(small_built):
    """The shared small build (conftest.small_built), made at -c2."""
    wd, digest = small_built
    for f in ("results/report/report.html", "results/tables/table1.csv", "results/figures/fig08.png",
              "results/blind/score.json", "results/diagnosis/group1.json"):
        assert f in {"results/" + k for k in digest}, f
    return wd, digest


# Jobs that block until the test releases them: the kill points are states of the run, not times. They are added to
# the copy's Snakefile only (outside results/, so the digests are unaffected), with a high priority so that they
# start first, and asked for as extra targets: a run that waits on its gate cannot have finished.
GATE_RULE = """

rule test_gate:
    priority: 100
    output:
        "gate/{name}.released",
    shell:
        "touch gate/{wildcards.name}.started; while [ ! -e gate/{wildcards.name}.release ]; do sleep 0.05; done; "
        "touch {output}"
"""


def _progress(wd) -> tuple:
    """What the run has made so far: its outputs (count, newest mtime) and Snakemake's own bookkeeping. A job's
    temporary file (or folder) can vanish between the listing and the stat: the walk is then taken again."""
    while True:
        try:
            stamps = [f.stat().st_mtime_ns for d in ("results", ".snakemake") if (wd / d).exists()
                      for f in (wd / d).rglob("*") if f.is_file()]
            return len(stamps), max(stamps, default=0)
        except FileNotFoundError:
            continue


def _wait_for(paths, proc, wd, stall=1800):
    """Until every path exists. A loaded machine only slows the run down, so there is no deadline on the whole
    wait (a fixed 600 s timed out under load): it fails when the run ends first, or when it makes no progress
    (no output, no bookkeeping written) for ``stall`` seconds, longer than any one job of the small study."""
    seen, since, last_check = None, time.monotonic(), 0.0
    while not all(p.exists() for p in paths):
        assert proc.poll() is None, "the run ended before it reached the kill point"
        now = time.monotonic()
        if now - last_check > 5.0:
            last_check, prog = now, _progress(wd)
            if prog != seen:
                seen, since = prog, now
            assert now - since < stall, f"no progress for {stall} s waiting for {paths}"
        time.sleep(0.05)


def _run_and_kill(wd, gate: str, mid_way: str, sig) -> None:
    """Start `all` plus the gate job; once the gate job runs and `mid_way` exists, send `sig` to the whole
    process group (as a terminal's Ctrl-C does, or a node failure's SIGKILL)."""
    env = dict(os.environ, NUMBA_NUM_THREADS="1", MPLBACKEND="agg")
    cmd = [sys.executable, "-m", "snakemake", "--directory", str(wd), "--snakefile", str(wd / "Snakefile"),
           "-c2", "--max-threads", "1", "all", f"gate/{gate}.released"]  # a 2-thread job would wait on the gate
    proc = subprocess.Popen(cmd, cwd=wd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    _wait_for([wd / "gate" / f"{gate}.started", wd / mid_way], proc, wd)
    os.killpg(proc.pid, sig)
    proc.wait(timeout=900)  # Ctrl-C: Snakemake stops its jobs and cleans up, slowly on a loaded machine


def test_killed_runs_resume_to_the_same_bytes(request, tmp_path):
    """Ctrl-C (SIGINT to the process group): Snakemake stops its jobs, deletes their partial outputs and releases
    its lock, and a plain rerun goes on. SIGKILL (a node or power failure): nothing can clean up; the lock stays
    (Snakemake cannot tell a dead run from a live one, so `snakemake --unlock` is the one extra command) and the
    unfinished outputs stay marked incomplete, which the default profile's rerun-incomplete rebuilds. One run is
    stopped by Ctrl-C early, its resumption is killed by SIGKILL once the report's data exist, and the final rerun
    ends with the same bytes as the uninterrupted reference. Every job ran alone (the gate holds the second core;
    the final rerun is -c1): the comparison with the -c2 reference is also the one-core-against-two check. The
    reference is asked for only when it is needed, so that another worker can build it meanwhile (pytest-xdist)."""
    wd = small_copy(tmp_path / "killed")
    with open(wd / "Snakefile", "a") as f:
        f.write(GATE_RULE)
    (wd / "gate").mkdir()

    _run_and_kill(wd, "early", "results/loops/group1.csv", signal.SIGINT)
    left = tree_digest(wd / "results")
    assert "report/report.html" not in left and 0 < len(left)

    _run_and_kill(wd, "later", "results/report/report_data.json", signal.SIGKILL)
    left2 = tree_digest(wd / "results")
    assert "report/report.html" not in left2 and len(left) < len(left2)
    assert {"tables/table1.csv", "blind/score.json", "report/report_data.json"} <= set(left2)  # one job at a time
    p = snakemake(wd, "-c2", "all")
    assert p.returncode != 0 and "--unlock" in p.stderr
    assert snakemake(wd, "--unlock").returncode == 0

    p = snakemake(wd, "-c1", "all")
    assert p.returncode == 0, p.stderr[-4000:]
    _, expected = request.getfixturevalue("reference")
    assert len(left) < len(left2) < len(expected)
    assert _diff(expected, tree_digest(wd / "results")) == []
    p = snakemake(wd, "-c2", "all")
    assert p.returncode == 0 and "Nothing to be done" in p.stdout + p.stderr
