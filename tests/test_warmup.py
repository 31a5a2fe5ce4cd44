"""Rule warmup (mrhyst.warmup): after its two groups, the calls the study's first jobs make compile nothing more.

Each group runs in its own process with an empty numba cache, as the rule's two jobs do; then a third process
makes the jobs' kinds of calls (the key's reference fit with an effect, the rig, an anisotropic J-A fit's model,
the batched LM with a mask) and must find every kernel in the cache: no file is added to it."""

import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow

JOBS = """
import numpy as np
from mrhyst import rig
from mrhyst.blind import reference as ref
from mrhyst.fit import lm
from mrhyst.model import ja
I = ja.paper_current_path(); t = rig.sample_times(I.size, 0.2)
P = np.array([1.0e6, 2.5e4, 1.0e-3, 0.3, 1.0e4])
B, _ = rig.observe(P, I, t, 2.0e4, [("eddy_lag", {"lag": 0.1})])
loop = ref.Loop(B, I, t, 2.0e4, 8)
ref.effect_fit(loop, "hall_offset", P, {"Ms": [1e3, 1e8], "a": [10, 1e7], "alpha": [0, 0.2], "c": [0, 0.99],
               "k": [1, 1e7]}, 20)
Q = np.array([[1.0e6, 300.0, 1e-4, 0.3, 200.0, 10.0, 0.2, 0.5]] * 3)
ja.simulate_h(Q, np.linspace(0, 1e3, 40), form="physical", substeps=3, model="anisotropic", M0=np.ones(3))
lm.least_squares_batch(lambda X, rows: X - 2.0, np.zeros((3, 2)), (-1.0, 5.0), [True, False], max_iter=4)
"""


def _run(code, cache):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), NUMBA_NUM_THREADS="1")
    p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr[-2000:]


def _files(cache):
    return sorted(str(p.relative_to(cache)) for p in cache.rglob("*.nbc"))


def test_after_the_warm_up_the_first_jobs_compile_nothing(tmp_path):
    cache = tmp_path / "numba"
    for group in ("ja", "variants"):
        _run(f"from mrhyst import warmup; warmup.warm({group!r})", cache)
    warmed = _files(cache)
    assert any("_aniso_sums" in f for f in warmed) and any("lm._probes" in f for f in warmed)
    _run(JOBS, cache)
    assert _files(cache) == warmed  # a kernel the jobs needed and the warm-up missed would add a file


def test_an_unknown_group_is_refused():
    from mrhyst import warmup

    with pytest.raises(ValueError, match="warm-up group"):
        warmup.warm("everything")
