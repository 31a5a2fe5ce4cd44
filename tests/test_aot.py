"""The ahead-of-time J-A module (mrhyst.model.aot, issue 26's warm fit): the bytes of numba's JIT kernel for any
sets, forms, step counts and paths; read only under its own key; a console-script fit with it loads no numba and
writes the bytes of a fit without it; a fit without it builds it once in the background (the in-process
``cli.main(argv)`` never does); a failed build changes nothing but leaves its reason. The build needs a C compiler
and setuptools (numba.pycc): where it fails, the tests that need a module skip and say why."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.model import aot, ja

ROOT = Path(__file__).resolve().parents[1]
PY = [sys.executable, "-m", "mrhyst"]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """(the AOT kernels, the JIT kernels), the module compiled into a temporary folder from this tree's source."""
    from mrhyst.model import aot_build

    try:
        p = aot_build.compile_to(tmp_path_factory.mktemp("aot"), f"{aot.NAME}.test.so")
        return aot.load(p), aot.jit()
    except Exception as e:  # noqa: BLE001  no C compiler, no setuptools, pycc gone from numba
        pytest.skip(f"the ahead-of-time module cannot be built here ({type(e).__name__}: {e})")


def _sets(rng, n):
    """n classic sets spread over the fitted ranges; some fail (the pole of Eq. 8: alpha large, k small), some are
    outside the domain (NaN, Ms <= 0, c >= 1): their own lanes and every lane beside them must match too."""
    P = np.column_stack([10 ** rng.uniform(4.5, 6.8, n), 10 ** rng.uniform(1.0, 5.0, n),
                         rng.uniform(-0.05, 0.05, n) * rng.choice([0.0, 0.01, 1.0, 20.0], n),
                         rng.uniform(0.0, 1.0, n), 10 ** rng.uniform(0.5, 5.0, n)])
    bad = rng.random((n, 5)) < 0.04
    P[bad] = rng.choice([np.nan, np.inf, -1.0, 0.0, 1.0], bad.sum())
    return np.ascontiguousarray(P)


def _path(rng, kind):
    """A field path (A/m): the paper's 53-sample loop, a minor loop inside a major one, or a random walk with
    repeated values (dH = 0 intervals)."""
    peak = 10 ** rng.uniform(3.0, 5.0)
    if kind == 0:
        return ja.paper_current_path() * peak / 2.0
    if kind == 1:
        return np.concatenate([np.linspace(0, peak, 15), np.linspace(peak, -0.3 * peak, 11)[1:],
                               np.linspace(-0.3 * peak, 0.5 * peak, 7)[1:], np.linspace(0.5 * peak, -peak, 13)[1:]])
    return np.round(np.cumsum(rng.normal(0.0, peak / 8, int(rng.integers(2, 60)))), -2)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.integers(0, 2**32 - 1), st.integers(1, 40), st.sampled_from([0, 1, 2]), st.sampled_from([0, 1, 2]),
       st.booleans(), st.booleans(), st.integers(1, 5))
def test_the_module_gives_the_jit_kernels_bytes(built, seed, n, kind, path, total, physical, substeps):
    """Any n (a block of 16 or not), any variant kind, both dM_an forms and J-A forms, any step count, start
    magnetisations: the lane constants and every B sample (NaN where failed) are the JIT kernel's bytes."""
    A, J = built
    rng = np.random.default_rng(seed)
    P, H, M0 = _sets(rng, n), np.ascontiguousarray(_path(rng, path)), rng.uniform(-1e5, 1e5, n)
    if kind == 2:
        P[::3, 2] = 1.0 / np.maximum(P[::3, 3], 1e-3)  # alpha c >= 1: outside Venkataraman's domain
    Cj, vj = J.lane_constants(kind, P, total)
    Ca, va = A.lane_constants(kind, P, total)
    assert Ca.tobytes() == Cj.tobytes() and va.tobytes() == vj.tobytes()
    out = [np.full((-(-n // ja.LANES) * ja.LANES, H.size), 7.0) for _ in range(2)]
    J.batch(Cj, vj, M0, H, substeps, physical, out[0])
    A.batch(Cj, vj, M0, H, substeps, physical, out[1])
    assert out[1].tobytes() == out[0].tobytes()


def test_the_fixed_check_sees_both_ok_and_failed_sets(built):
    """The build's own check (aot_build.same_bytes) passes, and its batch exercises both outcomes."""
    from mrhyst.model import aot_build

    A, J = built
    assert aot_build.same_bytes(A, J)
    P, H, M0 = aot_build._check_batch()
    Cm, valid = J.lane_constants(0, P, True)
    out = np.empty((32, H.size))
    J.batch(Cm, valid, M0, H, 2, False, out)
    ok = ~np.isnan(out[:21, -1])
    assert 0 < ok.sum() < 21 and not valid.all()


def test_the_key_follows_the_source_and_numbas_settings(monkeypatch, tmp_path):
    """Another kernel source or another numba CPU setting is another file name; the cache folder (where the file
    is) and the thread count are not part of the key."""
    for name in aot.SOURCES:
        (tmp_path / name).write_bytes((aot._HERE / name).read_bytes())
    monkeypatch.setattr(aot, "_HERE", tmp_path)
    monkeypatch.delenv("NUMBA_CPU_NAME", raising=False)
    k0 = aot.key()
    assert k0 is not None and aot.key() == k0
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert aot.key() == k0 and aot.path().parent == tmp_path / "elsewhere" / "mrhyst_aot"
    monkeypatch.setenv("NUMBA_NUM_THREADS", "1")  # threads at run time: the same machine code
    assert aot.key() == k0
    monkeypatch.setenv("NUMBA_CPU_NAME", "generic")
    assert aot.key() != k0
    monkeypatch.delenv("NUMBA_CPU_NAME")
    with open(tmp_path / "ja_jit.py", "a") as f:
        f.write("\n# an edit\n")
    assert aot.key() != k0


def test_a_corrupt_or_disabled_module_leaves_the_jit_kernels(monkeypatch, tmp_path):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    p = aot.path()
    p.parent.mkdir(parents=True)
    p.write_bytes(b"\x7fELF not really")
    assert aot._load() is None
    p.unlink()
    assert aot._load() is None  # none built
    monkeypatch.setenv(aot.ENV, "0")
    monkeypatch.setattr(aot, "_KERNELS", aot.jit())
    assert not aot.build_in_background()  # off: never built


def _env(cache, **kw):
    return dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT / "workflow"), **kw)


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    p = tmp_path_factory.mktemp("loop") / "loop.csv"
    subprocess.run(PY + ["convert", str(ROOT / "data" / "raw" / "li_gong_rig.csv"), "--sensor", "hall1", "--out",
                         str(p)], check=True, capture_output=True)
    return p


def _fit(loop, out, env):
    """A console-script fit (python -m mrhyst: the process entry) with -X importtime; the modules it imported."""
    r = subprocess.run([sys.executable, "-X", "importtime", "-m", "mrhyst", "fit", str(loop), "--method", "lsm",
                        "--out", str(out), "--quiet"], env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    return {ln.split("|")[-1].strip() for ln in r.stderr.splitlines() if ln.startswith("import time:")}


def _wait_for(paths, seconds=240.0):
    t0 = time.monotonic()
    while not any(p.exists() for p in paths) and time.monotonic() - t0 < seconds:
        time.sleep(0.5)
    return [p for p in paths if p.exists()]


def _gone(lock, seconds=30.0):
    """Whether the build's lock file is gone within ``seconds`` (the build removes it last)."""
    t0 = time.monotonic()
    while lock.exists() and time.monotonic() - t0 < seconds:
        time.sleep(0.2)
    return not lock.exists()


def test_a_fit_builds_it_once_then_runs_without_numba_and_writes_the_same_bytes(built, loop, tmp_path, monkeypatch):
    """The first console fit (JIT, numba loaded) starts a build in the background; the next fit loads no numba
    and writes the first one's bytes; an in-process cli.main(argv) fit never starts a build."""
    from mrhyst import cli

    cache = tmp_path / "cache"
    env = _env(cache)
    mods = _fit(loop, tmp_path / "jit.json", env)
    assert "numba" in mods
    p = Path(subprocess.run([sys.executable, "-c", "from mrhyst.model import aot; print(aot.path())"], env=env,
                            capture_output=True, text=True, check=True).stdout.strip())
    failed = Path(f"{p}.failed")
    assert _wait_for([p, failed]) == [p], failed.read_text() if failed.exists() else "no build in 240 s"
    assert _gone(Path(f"{p}.lock"))
    mods = _fit(loop, tmp_path / "aot.json", env)
    assert not any(m.split(".")[0] in ("numba", "llvmlite") for m in mods), sorted(m for m in mods if "numba" in m)
    for ext in (".json", ".curve.csv"):
        assert (tmp_path / f"aot{ext}").read_bytes() == (tmp_path / f"jit{ext}").read_bytes()
    p.unlink()
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(cache))
    monkeypatch.setattr(aot, "_KERNELS", aot.jit())
    assert cli.main(["fit", str(loop), "--method", "lsm", "--out", str(tmp_path / "in.json"), "--quiet"]) == 0
    assert sorted(x.name for x in p.parent.iterdir()) == []  # nothing built, no lock taken


def test_a_failed_build_changes_nothing_and_is_not_retried(built, loop, tmp_path):
    """No working C compiler (CC=false): the fit's exit, output and bytes are those of a fit without the module,
    the build leaves its reason in <file>.failed, and the next fit starts no build (no lock)."""
    cache = tmp_path / "cache"
    env = _env(cache, CC="false")
    _fit(loop, tmp_path / "a.json", env)
    p = Path(subprocess.run([sys.executable, "-c", "from mrhyst.model import aot; print(aot.path())"], env=env,
                            capture_output=True, text=True, check=True).stdout.strip())
    failed = Path(f"{p}.failed")
    assert _wait_for([failed, p]) == [failed]
    assert failed.read_text().strip() and not p.exists()
    assert _gone(Path(f"{p}.lock"))
    _fit(loop, tmp_path / "b.json", env)
    assert not Path(f"{p}.lock").exists()
    for ext in (".json", ".curve.csv"):
        assert (tmp_path / f"a{ext}").read_bytes() == (tmp_path / f"b{ext}").read_bytes()
