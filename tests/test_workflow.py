"""The Snakemake workflow end to end: targets, idempotence, bad config, cluster profile."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from workflow_util import ROOT, make_copy, snakemake, tree_digest

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """fig2 + fig6 built once in a copy."""
    wd = make_copy(tmp_path_factory.mktemp("wf"))
    p = snakemake(wd, "-c2", "fig2", "fig6")
    assert p.returncode == 0, p.stderr[-3000:]
    return wd


def test_named_targets_build_their_figures(built):
    for f in ("results/figures/fig02.png", "results/figures/fig06.png", "results/sim/n_over_le.json",
              "results/loops/group1.csv", "results/loops/group2.csv"):
        assert (built / f).stat().st_size > 0, f
    # data/raw is input: never rewritten
    for f in ("li_gong_rig.csv", "li_gong_rig.json"):
        assert (built / "data/raw" / f).read_bytes() == (ROOT / "data/raw" / f).read_bytes()


def test_second_run_has_nothing_to_do(built):
    p = snakemake(built, "-c2", "fig2", "fig6")
    assert p.returncode == 0
    assert "Nothing to be done" in p.stdout + p.stderr


def test_other_name_of_the_same_interpreter_has_nothing_to_do(built):
    """Built with `<venv>/bin/python3 -m snakemake` (or python); the other name of the same venv's interpreter
    (as the `snakemake` console script's shebang may be) must not see changed rule code and rebuild."""
    here = Path(sys.executable)
    other = here.parent / ("python" if here.name != "python" else "python3")
    if not other.exists():
        pytest.skip(f"no {other.name} beside {here}")
    env = dict(os.environ, NUMBA_NUM_THREADS="1", MPLBACKEND="agg")
    p = subprocess.run([str(other), "-m", "snakemake", "-n", "-c1", "fig2", "fig6"], cwd=built, capture_output=True,
                       text=True, env=env)
    assert p.returncode == 0, p.stderr[-3000:]
    assert "Nothing to be done" in p.stdout + p.stderr


def test_forced_rebuild_gives_the_same_bytes(built):
    before = tree_digest(built / "results")
    p = snakemake(built, "-c1", "-F", "fig2", "fig6")
    assert p.returncode == 0, p.stderr[-3000:]
    after = tree_digest(built / "results")
    assert before.keys() == after.keys()
    changed = [k for k in before if before[k] != after[k]]
    assert changed == []


def test_bad_config_is_one_line_and_nonzero(tmp_path):
    wd = make_copy(tmp_path, {"ja": {"sbsteps": 3}})
    p = snakemake(wd, "-n", "fig2")
    assert p.returncode != 0
    lines = [ln for ln in p.stderr.splitlines() if "error" in ln.lower()]
    known = ", ".join(sorted(yaml.safe_load((ROOT / "workflow/mrhyst/schemas/config.schema.yaml").read_text())
                             ["properties"]["ja"]["properties"]))
    assert lines == [f"error: config.yaml: ja: unknown key(s) sbsteps (known: {known})"]
    wd2 = make_copy(tmp_path / "b", {"nle": {"bracket": [1.0e+5, 1.0e+2]}})
    p = snakemake(wd2, "-n", "fig2")
    assert p.returncode != 0 and "nle.bracket: lower" in p.stderr
    assert not (wd2 / "results").exists()


def test_slurm_profile_dry_run(tmp_path):
    wd = make_copy(tmp_path)
    p = snakemake(wd, "--profile", str(wd / "workflow/profiles/slurm"), "-n", "fig2", "fig6")
    assert p.returncode == 0, p.stderr[-3000:]
    out = p.stdout + p.stderr
    assert "rule plot_fig02" in out and "rule convert" in out
    assert not (wd / "results").exists()


def test_slurm_profile_bundles_blind_cases_and_studies_are_valid(tmp_path, config):
    """The cluster studies of the README are valid configs of the stated size; the slurm profile bundles
    blind_diagnose jobs (blocks of 10 cases) and the main benchmark's job of leftover cases (blind_diagnose_rest) 5 to a
    cluster job
    (checked on a 15-per-class override, dry run)."""
    import math

    import yaml
    from mrhyst.blind import case_ids
    from mrhyst.config import check_config
    from workflow_util import _merge

    for name, check in (("blind_1e4.yaml", lambda c: len(case_ids(c["blind"])) >= 10_000),
                        ("seeds_100.yaml", lambda c: sorted(c["pso"]["seeds"]) == list(range(100))),
                        ("cluster_selftest.yaml",
                         lambda c: len(case_ids(c["blind"])) == 14 and c["pso"]["seeds"] == [0, 1])):
        merged = yaml.safe_load((ROOT / "config.yaml").read_text())
        _merge(merged, yaml.safe_load((ROOT / "workflow/studies" / name).read_text()))
        check_config(merged, source=name)
        assert check(merged), name
    wd = make_copy(tmp_path)
    (wd / "study.yaml").write_text("blind: {n_per_class: 15, cases_per_job: 10}\n")
    p = snakemake(wd, "blind", "-n", "--profile", str(wd / "workflow/profiles/slurm"), "--configfile", "study.yaml")
    assert p.returncode == 0, p.stderr[-3000:]
    out = p.stdout + p.stderr
    from mrhyst.blind import split_blocks, variant_config

    bcfg = dict(config["blind"], n_per_class=15)  # blind.counts sets the compound/open-world classes
    k = 10  # study.yaml's cases_per_job
    parts = [split_blocks(case_ids(variant_config(bcfg, v)), k) for v in [None, *bcfg["variants"]]]
    blocks, ones = sum(len(b) for b, _ in parts), sum(len(r) for _, r in parts)
    assert blocks * 10 + ones == sum(len(case_ids(variant_config(bcfg, v))) for v in [None, *bcfg["variants"]])
    assert parts[0][1] and parts[1][1]  # both benchmarks have leftover cases: one job each
    assert re.search(rf"^blind_diagnose\s+{blocks}$", out, flags=re.M)
    assert re.search(r"^blind_diagnose_rest\s+1$", out, flags=re.M)
    assert re.search(r"^blind_diagnose_rest_bipolar2\s+1$", out, flags=re.M)
    # the blocks and the main benchmark's leftovers are bundled; the variant's leftovers are one job of their own
    assert out.count("Group job blind_batch") == math.ceil((blocks + 1) / 5)
    assert not (wd / "results").exists()


def test_slurm_profile_needs_no_edits_and_asks_one_cpu_per_cluster_job():
    """The profile runs unedited where the default partition will do (no partition, no account), and a bundle
    of blind cases is a one-CPU job: Snakemake sums the resources of a group's parallel members unless `cores`
    bounds them (50 cases would ask for 50 CPUs and 100 GB). Its time limit, the members' runtimes summed, stays
    within a day. tests/cluster/slurm_selftest.sh checks the same on a real SLURM (squeue's CPUs column)."""
    import yaml

    prof = yaml.safe_load((ROOT / "workflow/profiles/slurm/config.v8+.yaml").read_text())
    assert not {"slurm_partition", "slurm_account"} & set(prof["default-resources"])
    assert prof["cores"] == 1
    per_block = max(prof["set-resources"][r]["runtime"] for r in ("blind_diagnose", "blind_diagnose_rest"))
    assert per_block * prof["group-components"]["blind_batch"] <= 24 * 60
    script = ROOT / "tests/cluster/slurm_selftest.sh"
    assert subprocess.run(["bash", "-n", str(script)]).returncode == 0


def _dry_jobs(wd: Path, *targets: str) -> dict:
    """{rule: count} of the jobs a dry run would execute."""
    p = snakemake(wd, "-n", "-c1", *targets, "--quiet", "rules")  # targets first: --quiet takes several
    assert p.returncode == 0, p.stderr[-3000:]
    jobs = {}
    for line in (p.stdout + p.stderr).splitlines():
        m = re.match(r"^\s*([a-z_0-9]+)\s+(\d+)\s*$", line)
        if m and m.group(1) != "total":
            jobs[m.group(1)] = int(m.group(2))
    return jobs


def test_config_edit_reruns_exactly_the_jobs_it_concerns(tmp_path):
    """Scripts read their config through a rule param, so an edit to config.yaml reruns the jobs whose sections
    changed (never a stale result) and only those: an unrelated section or one more PSO seed reruns nothing."""
    import yaml

    wd = make_copy(tmp_path / "wf", {"lsm": {"max_iterations": 20}})
    targets = ("fig2", "results/fits/group1_lsm.json")
    p = snakemake(wd, "-c2", *targets)
    assert p.returncode == 0, p.stderr[-3000:]
    assert _dry_jobs(wd, *targets) == {}
    base = (wd / "config.yaml").read_text()

    def edited(change) -> dict:
        cfg = yaml.safe_load(base)
        change(cfg)
        (wd / "config.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
        try:
            return _dry_jobs(wd, *targets)
        finally:
            (wd / "config.yaml").write_text(base)

    assert edited(lambda c: c["fig2"].update(di_A=0.02)) == {"simulate_fig2": 1, "plot_fig02": 1, "fig2": 1}
    assert edited(lambda c: c["lsm"].update(ftol=1e-10)) == {"fit_lsm": 1}
    jobs = edited(lambda c: c["ja"].update(substeps=3))  # everything integrates J-A
    assert {"infer_nle", "simulate_fig2", "fit_lsm"} <= set(jobs), jobs
    assert edited(lambda c: c["diagnose"].update(n_starts=3)) == {}  # no diagnosis among these targets
    assert edited(lambda c: c["pso"].update(seeds=[0, 1, 2, 99])) == {}  # a new seed adds fits, reruns none


def test_a_labs_own_sweep_runs_unchanged(tmp_path):
    """A lab's sweep in data/raw with its own sensor name, coil and one group (a measured sweep, not the rig's):
    the workflow parses (later.sensor is the rig's channel, not data/raw's), builds no rig variant (they remake the
    rig's sweep), fits the loop in the sweep's own coil, and the later demo still names the rig's opened gap (it
    calibrates on the rig's own first sweep, not on the lab's)."""
    import json

    wd = make_copy(tmp_path / "wf")
    raw = (wd / "data/raw/li_gong_rig.csv").read_text().splitlines()
    head = raw[0].split(",")
    keep = [i for i, c in enumerate(head) if c != "hall2_V"]
    rows = [",".join(r.split(",")[i] for i in keep) for r in raw]
    (wd / "data/raw/lab.csv").write_text("\n".join(rows).replace("hall1_V", "probe1_V") + "\n")
    side = json.loads((wd / "data/raw/li_gong_rig.json").read_text())
    side.update(provenance="measured: a lab's bench", coil_turns_per_m=1500.0,
                sensors={"probe1": side["sensors"]["hall1"]})
    (wd / "data/raw/lab.json").write_text(json.dumps(side))
    cfg = yaml.safe_load((wd / "config.yaml").read_text())
    cfg["groups"] = {"group1": {"raw": "data/raw/lab", "sensor": "probe1"}}
    (wd / "config.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    jobs = _dry_jobs(wd, "all")
    assert "rig_variant" not in jobs and jobs.get("fit_lsm") == 1, jobs
    p = snakemake(wd, "-c2", "results/fits/group1_lsm.json", "results/later/diag/air_gap_reference.json")
    assert p.returncode == 0, p.stderr[-3000:]
    fit = json.loads((wd / "results/fits/group1_lsm.json").read_text())
    assert fit["n_over_le"] == pytest.approx(1500.0) and "coil_turns_per_m" in fit["h_source"]
    assert json.loads((wd / "results/later/diag/air_gap_reference.json").read_text())["effect"] == "air_gap"
