"""The compiled LM step (issue 23: mrhyst.fit.lm._step, _jacobian_into) against the numpy forms they replace: the
same bytes, so no fit, verdict or committed number moves. Each check draws its own shapes, scales, frozen
coordinates, rows at their bounds and invalid probes; bench/README.md has the speed."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.fit import lm


def _problem(rng, N, m, D, k):
    """A random LM state of N rows (a few at a bound, some coordinates frozen) and its live entries (k each)."""
    act = rng.random((N, D)) < 0.7
    act[:, 0] = True
    J = rng.standard_normal((N, m, D)) * 10.0 ** rng.uniform(-6, 6, (1, 1, D))
    J[~act[:, None, :].repeat(m, axis=1)] = 0.0
    r = rng.standard_normal((N, m)) * 10.0 ** rng.uniform(-3, 3)
    G, A = lm._normal(J, r, True)
    X = rng.standard_normal((N, D))
    lo, hi = X - rng.uniform(0.0, 2.0, (N, D)), X + rng.uniform(0.0, 2.0, (N, D))
    at = rng.random((N, D)) < 0.2
    lo[at] = X[at]  # a coordinate at its lower bound: frozen when the gradient pushes out
    Dmax = np.where(rng.random((N, D)) < 0.5, 0.0, np.abs(rng.standard_normal((N, D))))
    live = np.repeat(rng.permutation(N)[: rng.integers(1, N + 1)], k)
    lam = 10.0 ** rng.uniform(-12, 8, live.size)
    return J, r, G, A, X, lo, hi, act, Dmax, lam, live


def _fun(rng, m, D):
    """Residuals that depend on every coordinate, not finite for some rows (the probe's check)."""
    W = rng.standard_normal((D, m))

    def fun(X, rows):
        R = np.tanh(X @ W) + 0.1 * X[:, :1] ** 2
        R[X[:, 0] > 1.5] = np.nan
        return R
    return fun


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 9), st.integers(1, 80), st.integers(2, 19), st.integers(1, 4), st.integers(0, 2**32 - 1))
def test_compiled_step_is_the_numpy_step(N, m, D, k, seed):
    rng = np.random.default_rng(seed)
    J, r, G, A, X, lo, hi, act, Dmax, lam, live = _problem(rng, N, m, D, k)
    fun = _fun(rng, m, D)
    D1, D2 = Dmax.copy(), Dmax.copy()
    a = lm._step(fun, X, r, J, G, A, D1, lam, lo, hi, act, live)
    b = lm._step_numpy(fun, X, r, J, G, A, D2, lam, lo, hi, act, live)
    assert a.tobytes() == b.tobytes() and D1.tobytes() == D2.tobytes()
    assert np.all((a >= lo[live]) & (a <= hi[live]))  # a trial point never leaves the box


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 9), st.integers(1, 80), st.integers(2, 19), st.integers(0, 2**32 - 1))
def test_jacobian_in_place_is_the_copied_one(N, m, D, seed):
    rng = np.random.default_rng(seed)
    J, r, G, A, X, lo, hi, act, Dmax, lam, live = _problem(rng, N, m, D, 1)
    fun = _fun(rng, m, D)
    steps = 10.0 ** rng.uniform(-9, -5, D)
    rows = np.unique(live)
    J1, G1, A1 = J.copy(), G.copy(), A.copy()
    lm._jacobian_into(fun, X, r, rows, act, hi, steps, J1, G1, A1)
    J2, G2, A2 = J.copy(), G.copy(), A.copy()
    J2[rows] = lm._jacobian(fun, X, r, rows, act, hi, steps)
    G2[rows], A2[rows] = lm._normal(J2[rows], r[rows], True)
    assert J1.tobytes() == J2.tobytes() and G1.tobytes() == G2.tobytes() and A1.tobytes() == A2.tobytes()


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 12), st.integers(1, 40), st.integers(0, 2**32 - 1))
def test_norm_is_numpys(n, D, seed):
    """numpy's pairwise sum of squares (8 accumulators from 8 terms on), the case a sequential sum gets wrong."""
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n, D)) * 10.0 ** rng.uniform(-8, 8, (n, D))
    assert np.array([lm._norm(x, q) for q in range(n)]).tobytes() == np.linalg.norm(x, axis=1).tobytes()


def test_clip_keeps_numpys_nan_and_signed_zeros():
    x = np.array([-0.0, 0.0, np.nan, 1.0, -1.0, 2.0, -np.inf, np.inf, 0.5, -0.0])
    lo = np.array([0.0, -0.0, 0.0, 1.0, -1.0, 1.0, -1.0, 0.0, 0.5, -1.0])
    hi = np.array([1.0, 1.0, 1.0, 1.0, 2.0, 1.5, 0.0, 1.0, 0.5, 1.0])
    out = np.array([lm._clip(a, b, c) for a, b, c in zip(x, lo, hi)])
    assert out.tobytes() == np.clip(x, lo, hi).tobytes()


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 40), st.integers(1, 300), st.integers(0, 2**32 - 1))
def test_compiled_cost_is_einsums(n, m, seed):
    """A row's cost in np.einsum's order; a row that overflows or holds a NaN: cost inf, residuals 0."""
    rng = np.random.default_rng(seed)
    r = rng.standard_normal((n, m)) * 10.0 ** rng.uniform(-200, 160, (n, 1))
    r[rng.random((n, m)) < 0.01] = np.nan
    a, ca = lm._eval_numpy(r.copy())
    b = r.copy()
    cb = lm._cost_rows(b)
    assert a.tobytes() == b.tobytes() and ca.tobytes() == cb.tobytes()


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 30), st.integers(1, 8), st.integers(1, 6), st.integers(0, 2**32 - 1))
def test_live_rows_and_their_attempts(N, D, k, seed):
    """The loop's bookkeeping against its numpy form: live rows, Jacobian rows (flags cleared), attempts' dampings."""
    rng = np.random.default_rng(seed)
    done, need, act = rng.random(N) < 0.3, rng.random(N) < 0.5, rng.random((N, D)) < 0.6
    nit, lam = rng.integers(0, 12, N), 10.0 ** rng.uniform(-12, 8, N)
    n1 = need.copy()
    live, jrows, n_free = lm._live(done, nit, 10, n1, act)
    expect = np.flatnonzero(~done & (nit < 10))
    assert live.tolist() == expect.tolist() and jrows.tolist() == expect[need[expect]].tolist()
    assert n_free == act[jrows].sum() and not n1[jrows].any() and (n1 == need & ~np.isin(np.arange(N), jrows)).all()
    rows, lr = lm._entries(live, k, lam)
    assert rows.tolist() == np.repeat(live, k).tolist()
    assert lr.tobytes() == (lam[rows] * np.tile(2.0 ** np.arange(k), live.size)).tobytes()
