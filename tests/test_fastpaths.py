"""The compiled fast paths of the diagnosis (issue 15) against the plain numpy forms they replace: the same
bytes, so no fit, verdict or committed number moves (bench/bench_diagnose_batch.py measures the speed)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.fit import lm
from mrhyst.model import anhysteretic as anh
from mrhyst.model import effects as fx
from mrhyst.model import ja

T = np.linspace(0.0, 4.0, 40)


def decay_model(X):
    """y = A exp(-t / tau) + C, batched over rows (A, ln tau, C)."""
    X = np.atleast_2d(X)
    return X[:, :1] * np.exp(-T[None, :] / np.exp(X[:, 1:2])) + X[:, 2:3]


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 30), st.integers(1, 120), st.integers(1, 12), st.integers(0, 2**32 - 1))
def test_compiled_normal_equations_are_einsums_bytes(n, m, D, seed):
    """lm._normal (J'r, J'J) sums in einsum's order: the same bytes, whatever the shapes and column scales."""
    rng = np.random.default_rng(seed)
    J = rng.standard_normal((n, m, D)) * 10.0 ** rng.uniform(-6, 6, (1, 1, D))
    r = rng.standard_normal((n, m)) * 10.0 ** rng.uniform(-3, 3)
    g, A = lm._normal(J, r, True)
    assert g.tobytes() == np.einsum("nmj,nm->nj", J, r).tobytes()
    assert A.tobytes() == np.einsum("nmi,nmj->nij", J, J).tobytes()
    assert lm._normal(J, r, False)[0].tobytes() == g.tobytes()


def _jacobian_numpy(fun, X, r, rows, act, hi, steps):
    """The numpy form of lm._jacobian (index pairs in Python, the probes by fancy indexing)."""
    pairs = [(i, j) for i in rows for j in np.flatnonzero(act[i])]
    J = np.zeros((len(rows), r.shape[1], X.shape[1]))
    if not pairs:
        return J
    ii, jj = np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
    h = steps[jj].copy()
    out = X[ii, jj] + h > hi[ii, jj]
    h[out] = -h[out]
    Xp = X[ii].copy()
    Xp[np.arange(ii.size), jj] += h
    rp, cp = lm._eval(fun, Xp, ii)
    col = (rp - r[ii]) / h[:, None]
    col[~np.isfinite(cp)] = 0.0
    pos = {i: k for k, i in enumerate(rows)}
    J[[pos[i] for i in ii], :, jj] = col
    return J


def _jacobian_into_numpy(fun, X, r, rows, act, hi, steps, J, G, A):
    """The numpy form of lm._jacobian_into: a Jacobian array per call, copied into J's rows, normal equations of
    the copies."""
    J[rows] = lm._jacobian(fun, X, r, rows, act, hi, steps)
    G[rows], A[rows] = lm._normal(J[rows], r[rows], True)


def _accept_python(live, k, Xn, rn, cn, X, r, cost, lam, need, done, nit, max_iter, ftol, lam_max):
    """The Python form of lm._accept, one attempt per row and iteration (the LM as it was written first)."""
    assert k == 1
    for q, i in enumerate(live):
        nit[i] += 1
        if cn[q] < cost[i]:
            rel = (cost[i] - cn[q]) / cost[i] if cost[i] > 0 else 0.0
            X[i], r[i], cost[i] = Xn[q], rn[q], cn[q]
            lam[i] = max(lam[i] / 3.0, 1e-12)
            need[i] = True
            done[i] = rel < ftol or cost[i] == 0.0
        else:
            lam[i] *= 2.0
            done[i] = lam[i] > lam_max


def test_lm_gives_the_bytes_of_its_numpy_form(monkeypatch):
    """The whole LM with its compiled pieces against the same LM with their numpy forms (einsum normal
    equations, numpy damping, fancy-indexed probes, a Python acceptance loop taking one step per row and
    iteration, where the compiled one tries several dampings per row in one model call): same x, cost and
    iterations to the last bit, with bounds, a frozen coordinate and an invalid start. The compiled step and the
    in-place Jacobian (issue 23) are replaced by their numpy forms too."""
    rng = np.random.default_rng(4)
    y = decay_model([2.0, np.log(0.7), 0.3])[0] + 0.01 * rng.standard_normal(T.size)
    starts = np.array([[1.0, 0.0, 0.0], [3.0, -1.0, 1.0], [-1.0, 0.0, 0.0], [0.5, 0.5, 0.05], [5.0, 3.0, 0.0]])
    fun = lambda X, rows: np.where(X[:, :1] < 0, np.nan, decay_model(X) - y)  # noqa: E731
    kw = dict(bounds=([-2.0, -3.0, -1.0], [5.0, 3.0, 0.1]), mask=[True, True, False], ftol=1e-14, max_iter=300)
    fast = lm.least_squares_batch(fun, starts, **kw)
    assert lm._attempts(len(starts)) == 3 and lm._attempts(1) == lm.MAX_ATTEMPTS  # several dampings at once
    monkeypatch.setattr(lm, "_normal", lambda J, r, need_A: (np.einsum("nmj,nm->nj", J, r),
                                                              np.einsum("nmi,nmj->nij", J, J)))
    monkeypatch.setattr(lm, "_damped", _damped_numpy)
    monkeypatch.setattr(lm, "_jacobian", _jacobian_numpy)
    monkeypatch.setattr(lm, "_accept", _accept_python)
    monkeypatch.setattr(lm, "_attempts", lambda n_live, lanes: 1)
    monkeypatch.setattr(lm, "_step", lm._step_numpy)
    monkeypatch.setattr(lm, "_jacobian_into", _jacobian_into_numpy)
    plain = lm.least_squares_batch(fun, starts, **kw)
    assert fast.x.tobytes() == plain.x.tobytes() and fast.cost.tobytes() == plain.cost.tobytes()
    assert list(fast.nit) == list(plain.nit) and fast.nfev > plain.nfev  # the same steps, more trial points
    assert np.isfinite(fast.cost[[0, 1, 3, 4]]).all() and not np.isfinite(fast.cost[2])
    start_cost = np.sum(fun(starts, None) ** 2, axis=1)
    assert np.all(fast.cost[[0, 1, 3, 4]] < 0.5 * start_cost[[0, 1, 3, 4]])  # it did fit (row 4 from the corner)
    assert np.all(fast.x[:, 2] == np.clip(starts[:, 2], -1.0, 0.1))  # the frozen coordinate never moved


def _damped_numpy(A, g, X, lo, hi, act, Dmax, lam):
    """The numpy form lm._damped replaced."""
    free = act & ~((X <= lo) & (g > 0)) & ~((X >= hi) & (g < 0))
    d = np.maximum(Dmax, np.einsum("nii->ni", A))
    scale = np.where(free, d, 0.0).max(axis=1, keepdims=True) + 1e-300
    eye = np.eye(X.shape[1])
    M = A + lam[:, None, None] * np.einsum("ni,ij->nij", d + 1e-12 * scale, eye)
    fr = free[:, :, None] & free[:, None, :]
    return free, d, np.where(fr, M, 0.0) + np.einsum("ni,ij->nij", (~free).astype(float), eye)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 20), st.integers(1, 12), st.integers(0, 2**32 - 1))
def test_compiled_damped_matrix_is_the_numpy_one(n, D, seed):
    """Free coordinates at and off their bounds, gradients of both signs, frozen ones, zero columns."""
    rng = np.random.default_rng(seed)
    J = rng.standard_normal((n, 30, D)) * 10.0 ** rng.uniform(-6, 6, (1, 1, D))
    J[:, :, rng.random(D) < 0.2] = 0.0
    A = np.einsum("nmi,nmj->nij", J, J)
    g = rng.standard_normal((n, D))
    lo, hi = -np.ones((n, D)), np.ones((n, D))
    X = rng.choice([-1.0, 1.0, 0.3], (n, D))
    act = rng.random((n, D)) < 0.8
    Dmax = np.where(rng.random((n, D)) < 0.5, 0.0, np.abs(rng.standard_normal((n, D))) * 10.0 ** rng.uniform(-6, 6))
    lam = 10.0 ** rng.uniform(-12, 10, n)
    for a, b in zip(lm._damped(A, g, X, lo, hi, act, Dmax, lam), _damped_numpy(A, g, X, lo, hi, act, Dmax, lam)):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _sets(rng, n):
    """n classic sets around the paper's, some outside the model's domain or not finite."""
    P = np.column_stack([10 ** rng.uniform(5.5, 6.5, n), 10 ** rng.uniform(3, 4.5, n), rng.uniform(-1e-3, 2e-3, n),
                         rng.uniform(0.0, 1.0, n), 10 ** rng.uniform(3, 4, n)])
    bad = rng.random((n, 5)) < 0.05
    P[bad] = rng.choice([np.nan, np.inf, -1.0, 0.0, 1.0, 2.0], bad.sum())
    return P


@settings(max_examples=30, deadline=None)
@given(st.sampled_from(sorted(anh.KIND)), st.booleans(), st.integers(1, 50), st.integers(0, 2**32 - 1))
def test_compiled_lane_constants_are_the_numpy_ones(model, total, n, seed):
    P = _sets(np.random.default_rng(seed), n)
    if model == "venkataraman":
        P[::3, 2] = 1.0 / np.maximum(P[::3, 3], 1e-3)  # alpha c >= 1: outside Venkataraman's domain
    C0, v0 = anh.lane_constants(model, P, total)
    C1, v1 = anh.lane_constants_compiled(anh.KIND[model], P, total)
    assert v0.tolist() == v1.tolist() and C0.tobytes() == C1.tobytes()


def test_kernel_batch_with_invalid_sets_matches_one_by_one():
    """The padding done inside the kernel call: any batch size, invalid sets among valid ones, one M0 each."""
    rng = np.random.default_rng(2)
    P = _sets(rng, 37)
    M0 = rng.uniform(-1e5, 1e5, 37)
    H = ja.paper_current_path() * 3026.4
    B, ok = ja.simulate_h(P, H, form="physical", substeps=2, M0=M0)
    for i in range(37):
        b, o = ja.simulate_h(P[i], H, form="physical", substeps=2, M0=M0[i])
        assert o == ok[i] and b.tobytes() == B[i].tobytes()
    assert ok.sum() > 20 and not ok.all()


@settings(max_examples=20, deadline=None)
@given(st.integers(1, 6), st.integers(1, 60), st.integers(0, 2**32 - 1))
def test_compiled_eddy_filter_is_the_recursion(n, m, seed):
    rng = np.random.default_rng(seed)
    B, lag = rng.standard_normal((n, m)), rng.uniform(0.0, 0.9, n)
    ref = np.empty_like(B)
    ref[:, 0] = B[:, 0]
    for j in range(1, m):
        ref[:, j] = B[:, j] + lag * (ref[:, j - 1] - B[:, j])
    assert fx.eddy_filter(B, lag).tobytes() == ref.tobytes()
    assert fx.eddy_filter(B[0], lag[0]).tobytes() == ref[0].tobytes()
    assert fx.eddy_filter(B.reshape(n, 1, m), lag[:, None]).tobytes() == ref.tobytes()


@settings(max_examples=15, deadline=None)
@given(st.integers(1, 12), st.integers(0, 2**32 - 1))
def test_compiled_hysteron_sum_is_einsums_bytes(n, seed):
    """Preisach's weighted sum over hysteron states (+-1) of the model-form candidate: einsum's bytes."""
    from mrhyst.diagnose.modelform import _hysteron_sum

    rng = np.random.default_rng(seed)
    ST = np.ascontiguousarray(rng.choice([-1.0, 1.0], (48 * 49, 53)))
    w = rng.random((n, 48 * 49)) * 10.0 ** rng.uniform(-30, 0, (n, 48 * 49))
    assert _hysteron_sum(w, ST).tobytes() == np.einsum("nh,hj->nj", w, ST).tobytes()
