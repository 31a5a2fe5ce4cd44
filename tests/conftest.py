import os
from pathlib import Path

import pytest
import yaml

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def root():
    return ROOT


@pytest.fixture(scope="session")
def config():
    return yaml.safe_load((ROOT / "config.yaml").read_text())


@pytest.fixture(scope="session")
def small_built(tmp_path_factory):
    """One repository copy with the small config (workflow_util.SMALL: every stage runs), built once with
    `snakemake -c2 all` and shared by every test that reads it (the report's checks, the determinism
    comparisons): (workdir, {path below results/: bytes}). Tests that build must use a copy of their own."""
    from workflow_util import small_copy, snakemake, tree_digest

    wd = small_copy(tmp_path_factory.mktemp("small_built"))
    p = snakemake(wd, "-c2", "all")
    assert p.returncode == 0, p.stderr[-4000:]
    return wd, tree_digest(wd / "results")
