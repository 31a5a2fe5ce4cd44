"""Determinism of the whole workflow (issue 6), in repository copies with the small config of
workflow_util.SMALL (every stage runs: fits, profiles, tables, figures, diagnosis, blind, external, report):

- a forced rebuild gives byte-identical results/ (tables, JSON, CSV, figures, notebooks, report), at -c2 and
  at -c1, so neither a rerun nor the number of cores changes a byte;
- a run killed mid-way, by Ctrl-C or by SIGKILL (no chance to clean up), is completed by a rerun (after
  SIGKILL: `snakemake --unlock` first; profiles/default sets rerun-incomplete), and what it leaves is
  byte-identical to an uninterrupted run.
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
def reference(tmp_path_factory):
    wd = small_copy(tmp_path_factory.mktemp("ref"))
    p = snakemake(wd, "-c2", "all")
    assert p.returncode == 0, p.stderr[-4000:]
    digest = tree_digest(wd / "results")
    for f in ("results/report/report.html", "results/tables/table1.csv", "results/figures/fig08.png",
              "results/blind/score.json", "results/diagnosis/group1.json"):
        assert f in {"results/" + k for k in digest}, f
    return wd, digest


@pytest.mark.parametrize("cores", ["-c2", "-c1"])
def test_forced_rebuild_is_byte_identical(reference, cores):
    wd, before = reference
    p = snakemake(wd, cores, "-F", "all")
    assert p.returncode == 0, p.stderr[-4000:]
    assert _diff(before, tree_digest(wd / "results")) == []


# A job that blocks until the test releases it: the kill point is a state of the run, not a time. It is added to
# the copy's Snakefile only (outside results/, so the digests are unaffected) and asked for as a second target.
GATE_RULE = """

rule test_gate:
    priority: 100
    output:
        "gate/released",
    shell:
        "touch gate/started; while [ ! -e gate/release ]; do sleep 0.05; done; touch {output}"
"""
# an early artefact with many jobs after it: once it exists and the gate job runs, the run is mid-way
MID_WAY = "results/loops/group1.csv"


def _wait_for(paths, proc, timeout=600):
    deadline = time.monotonic() + timeout
    while not all(p.exists() for p in paths):
        assert proc.poll() is None, "the run ended before it reached the kill point"
        assert time.monotonic() < deadline, f"timed out waiting for {paths}"
        time.sleep(0.05)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL], ids=["ctrl-c", "sigkill"])
def test_killed_run_resumes_to_the_same_bytes(reference, tmp_path, sig):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it): Snakemake stops its jobs, deletes
    their partial outputs and releases its lock, and a plain rerun completes. SIGKILL (a node or power
    failure): nothing can clean up; the lock stays (Snakemake cannot tell a dead run from a live one, so
    `snakemake --unlock` is the one extra command) and the unfinished outputs stay marked incomplete, which the
    default profile's rerun-incomplete rebuilds. Either way the end result is byte-identical.

    The kill is deterministic: the run is asked for `all` and for a gate job that blocks until released, and it
    is killed once the gate job runs and MID_WAY exists, so the run cannot have finished (it waits on the gate)
    and has done part of its work."""
    _, expected = reference
    wd = small_copy(tmp_path / "killed")
    with open(wd / "Snakefile", "a") as f:
        f.write(GATE_RULE)
    (wd / "gate").mkdir()
    env = dict(os.environ, NUMBA_NUM_THREADS="1", MPLBACKEND="agg")
    cmd = [sys.executable, "-m", "snakemake", "--directory", str(wd), "--snakefile", str(wd / "Snakefile"),
           "-c2", "all", "gate/released"]
    proc = subprocess.Popen(cmd, cwd=wd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    _wait_for([wd / "gate" / "started", wd / MID_WAY], proc)
    os.killpg(proc.pid, sig)
    proc.wait(timeout=120)
    left = tree_digest(wd / "results")
    assert "report/report.html" not in left and len(left) < len(expected)
    if sig == signal.SIGKILL:
        p = snakemake(wd, "-c2", "all")
        assert p.returncode != 0 and "--unlock" in p.stderr
        assert snakemake(wd, "--unlock").returncode == 0
    p = snakemake(wd, "-c2", "all")
    assert p.returncode == 0, p.stderr[-4000:]
    assert _diff(expected, tree_digest(wd / "results")) == []
    p = snakemake(wd, "-c2", "all")
    assert p.returncode == 0 and "Nothing to be done" in p.stdout + p.stderr
