import os
from pathlib import Path

import pytest
import yaml

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parent.parent

# The modules that read the shared small build (fixture small_built below).
SHARED_BUILD_MODULES = {"test_report.py", "test_determinism.py"}


def _module_of(nodeid: str) -> str:
    module = nodeid.split("::", 1)[0]
    return "small_built" if Path(module).name in SHARED_BUILD_MODULES else module


@pytest.hookimpl(optionalhook=True)  # a pytest-xdist hook; never called with -n0
def pytest_xdist_make_scheduler(config, log):
    """pytest-xdist (pyproject addopts: -n auto --dist loadfile) with one work unit per module, as loadfile, except
    that the modules that read the shared small build are ONE unit (one worker, one build). (xdist's loadgroup
    would do this with marks, but xdist 3.8 cannot rename pytest 9's node ids, so its groups are ignored.)"""
    from xdist.scheduler import LoadScopeScheduling

    class ModuleScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return _module_of(nodeid)

    return ModuleScheduling(config, log)


def pytest_collection_modifyitems(config, items):
    """The shared build's modules first: with xdist they are the longest unit (the build, then the determinism
    module's own build), so they start at once while the other worker takes the rest."""
    items.sort(key=lambda item: item.path.name not in SHARED_BUILD_MODULES)  # stable: modules stay whole


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
