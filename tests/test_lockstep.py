"""The fitting process's kernel memo (mrhyst.fit.problem.MEMO), independent fits in lockstep (mrhyst.fit.lockstep)
and a prefetch capped at one block: each gives the bytes of the plain computation."""

import copy

import numpy as np
import pytest
from mrhyst.fit import identify as idf
from mrhyst.fit import lockstep
from mrhyst.fit.prefetch import Prefetch
from mrhyst.fit.problem import MEMO
from mrhyst.model import ja
from scipy.optimize import least_squares

TRUTH = np.array([1.1e6, 1500.0, 1.2e-3, 0.25, 1800.0])


def _problem():
    H = ja.paper_current_path(2.0, 27) * 3000.0
    B, ok = ja.simulate_h(TRUTH, H, form="physical", substeps=2)
    assert ok
    B = B + 1e-4 * np.random.default_rng(3).standard_normal(B.size)
    return idf.Problem(H, B, np.ones(B.size, dtype=bool), **idf.problem_kw(form="physical", substeps=2))


def _starts(n):
    return [TRUTH * (1.0 + 0.2 * np.sin(np.arange(5) + i)) for i in range(n)]


def test_memo_gives_the_kernels_bytes():
    """A row asked again (alone or in another batch) is the kernel's own row, and the evaluation count is kept."""
    prob = _problem()
    X = np.array(_starts(3))
    B, ok = ja.simulate_h(X, prob.path, form="physical", substeps=2, dman=prob.dman, M0=prob.M0_fixed)
    first = prob.model(X)[0]
    again = prob.model(X[1:2])[0]
    assert first.tobytes() == B[:, prob.sel].tobytes() and again.tobytes() == B[1:2, prob.sel].tobytes()
    assert prob.n_evals == 4


def test_lockstep_fits_are_the_fits_one_by_one():
    """LSMs run in lockstep (their kernel calls batched) give the bytes of the same LSMs one after another."""
    prob = _problem()
    box = idf.box_for(idf.resolve_config(None), None, "lsm")[0]
    MEMO.rows.clear()
    alone = [idf.run_lsm(copy.copy(prob), box, x0, max_iterations=30) for x0 in _starts(4)]
    MEMO.rows.clear()
    calls = []
    orig = ja._integrate

    def counted(*a):
        calls.append(a[0].shape[0])
        return orig(*a)

    ja._integrate = counted
    try:
        together = lockstep.run_all([lambda x0=x0: idf.run_lsm(copy.copy(prob), box, x0, max_iterations=30)
                                     for x0 in _starts(4)])
    finally:
        ja._integrate = orig
    for a, b in zip(alone, together):
        assert a["x"].tobytes() == b["x"].tobytes() and a["history"] == b["history"]
        assert a["n_evals"] == b["n_evals"]
    assert max(calls) > 6  # rows of several fits in one kernel call


def test_lockstep_raises_a_threads_error():
    def bad():
        raise ValueError("boom")

    with pytest.raises(ValueError, match="boom"):
        lockstep.run_all([lambda: 1, bad])


def test_prefetch_capped_at_a_block_same_fit():
    """A Prefetch that evaluates a trial point with at most block - 1 of its Jacobian's points gives the fit of
    one that evaluates all of them."""
    T = np.linspace(0.0, 3.0, 40)

    def rows(X):
        return np.array([sum(x[k] * np.sin((k + 1) * T) for k in range(len(x))) - np.cos(T) for x in np.atleast_2d(X)])

    lo, hi = -np.ones(6), np.ones(6)
    out = []
    for block in (None, 4):
        sizes = []
        pf = Prefetch(lambda X, sizes=sizes: sizes.append(len(X)) or rows(X), lo, hi, block=block)
        res = least_squares(pf.fun, np.full(6, 0.3), bounds=(lo, hi), method="trf", jac=pf.jac, max_nfev=100)
        out.append((res.x.tobytes(), res.cost, res.nfev, res.njev, pf.evals, max(sizes)))
    assert out[0][:5] == out[1][:5] and out[1][5] <= 4
