"""The flexible base's solve (mrhyst.diagnose.everett.solve / edf_of; issue 23's speed goal): the weights are scipy's
nnls of the whole scaled, penalised system, the edf is the trace of that system's hat matrix on the active set."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.diagnose import everett
from scipy.optimize import nnls


def problem(seed, G, n, extra, degenerate):
    """A design like a sweep's (non-negative state averages, chi H), weights with zeros, noise; ``degenerate``: a
    repeated column and an all-zero one."""
    rng = np.random.default_rng(seed)
    D = everett.structure(G)[2]
    k = D.shape[1]
    X = np.column_stack([rng.uniform(-1.0, 1.0, (n, k - 1)), np.linspace(-1.0, 1.0, n)])
    if degenerate:
        X[:, 3], X[:, 5] = X[:, 4], 0.0
    w = rng.exponential(1e-2, k) * (rng.random(k) < 0.6)
    y = X @ w + rng.normal(0.0, 1e-3, n)
    ex = None
    if extra:
        col = rng.uniform(0.5, 1.5, n)[:, None]
        ex = np.column_stack([col, -col])
        y = y + 0.02 * col[:, 0]
    return X, y, D, ex, 10.0 ** rng.uniform(-3.0, -1.0)


def _stacked(X, y, D, ex, lam):
    Xf = X if ex is None else np.column_stack([X, ex])
    Df = D if ex is None else np.column_stack([D, np.zeros((D.shape[0], 2))])
    sc = np.sqrt(np.sum(Xf * Xf, axis=0))
    sc[sc == 0] = 1.0
    return Xf, np.vstack([Xf / sc, math.sqrt(lam) * Df / sc]), np.r_[y, np.zeros(D.shape[0])], sc


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from([4, 6, 10]), st.integers(20, 60), st.booleans(), st.booleans())
def test_the_weights_minimise_the_whole_stacked_system_as_scipys_nnls(seed, G, n, extra, degenerate):
    """The normal-equation solve (block principal pivoting) reaches scipy's nnls minimum of the scaled, penalised
    system, and its weights satisfy the optimality conditions: non-negative, zero gradient where positive, a
    non-negative gradient where zero."""
    X, y, D, ex, lam = problem(seed, G, n, extra, degenerate)
    Xf, M, b, sc = _stacked(X, y, D, ex, lam)
    w, _ = nnls(M, b, maxiter=50 * Xf.shape[1])
    coef, fitted, _ = everett.solve(X, y, D, lam, ex)
    v = coef * sc
    assert np.all(coef >= 0.0)
    ours, scipys = np.sum((M @ v - b) ** 2), np.sum((M @ w - b) ** 2)
    assert ours <= scipys * (1 + 1e-9) + 1e-30
    grad = M.T @ (M @ v - b)
    scale = np.max(np.abs(M.T @ b))
    assert np.all(grad >= -1e-8 * scale)
    assert np.all(np.abs(grad[v > 0]) <= 1e-8 * scale)
    assert np.allclose(fitted, Xf @ coef, rtol=0, atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from([4, 10]), st.integers(20, 60), st.booleans())
def test_a_start_set_changes_how_fast_not_what(seed, G, n, extra):
    """Any guess of the active set (the warm start of a fold or another lam) gives the same weights."""
    X, y, D, ex, lam = problem(seed, G, n, extra, False)
    coef, _, _ = everett.solve(X, y, D, lam, ex)
    guess = np.random.default_rng(seed).random(coef.size) < 0.5
    again, _, _ = everett.solve(X, y, D, lam, ex, start=guess)
    assert np.allclose(again, coef, rtol=1e-9, atol=1e-12 * np.max(np.abs(coef)))


def test_a_singular_gram_falls_back_to_scipys_nnls(monkeypatch):
    """Two equal columns without a penalty to tell them apart: the normal equations are singular on that pair, and
    the stacked system's nnls answers instead (a minimum all the same)."""
    calls = []
    monkeypatch.setattr(everett, "nnls", lambda *a, _f=everett.nnls, **k: (calls.append(1), _f(*a, **k))[1])
    rng = np.random.default_rng(3)
    X = rng.uniform(0.0, 1.0, (30, 4))
    X[:, 1] = X[:, 0]
    y = X @ np.array([0.5, 0.5, 0.2, 0.0])
    D = np.zeros((1, 4))
    coef, fitted, _ = everett.solve(X, y, D, 1e-3)
    assert calls == [1]  # the fallback answered
    assert np.all(coef >= 0.0)
    assert np.allclose(fitted, y, atol=1e-10)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from([4, 6, 10]), st.integers(20, 60), st.booleans(), st.booleans())
def test_the_edf_is_the_trace_of_the_data_rows_hat_matrix(seed, G, n, extra, degenerate):
    """The hat matrix of the penalised least squares on the active columns, [Xa; sqrt(lam) Da] = QR: its data rows'
    block Q1 Q1' has the trace ||Q1||^2 (a QR, no normal equations); a degenerate active set (a repeated column) has
    an edf between 0 and the number of active columns."""
    X, y, D, ex, lam = problem(seed, G, n, extra, degenerate)
    coef, _, edf = everett.solve(X, y, D, lam, ex, want_edf=True)
    act = coef > 0
    Xf = X if ex is None else np.column_stack([X, ex])
    Df = D if ex is None else np.column_stack([D, np.zeros((D.shape[0], 2))])
    sc = np.sqrt(np.sum(Xf * Xf, axis=0))
    sc[sc == 0] = 1.0
    assert 0.0 <= edf <= act.sum() + 1e-9
    Ma = np.vstack([Xf[:, act] / sc[act], math.sqrt(lam) * Df[:, act] / sc[act]])
    if np.linalg.matrix_rank(Ma) == act.sum():
        Q = np.linalg.qr(Ma)[0]
        assert edf == pytest.approx(float(np.sum(Q[: X.shape[0]] ** 2)), rel=1e-8)
    assert everett.edf_at(X, D, lam, coef, ex) == edf


def _cell_means_by_definition(H, lv, start, F):
    """Each coarse cell's mean state, hysteron by hysteron and sample by sample (the model's definition): fine
    levels between the coarse ones, up where H >= alpha, else down where H <= beta."""
    L = lv.size
    x = (np.arange(F * L) + 0.5) / F - 0.5
    lf = np.interp(x, np.arange(L), lv)
    lf[x < 0] = lv[0] + x[x < 0] * (lv[1] - lv[0])
    lf[x > L - 1] = lv[-1] + (x[x > L - 1] - (L - 1)) * (lv[-1] - lv[-2])
    sums, counts = np.zeros((H.size, L * (L + 1) // 2)), np.zeros(L * (L + 1) // 2)
    for i in range(F * L):
        for j in range(i + 1):
            a, b = lf[i], lf[j]
            s = -np.sign(a + b) if start == "demagnetised" else (-1.0 if start == "negative" else 1.0)
            cell = (i // F) * (i // F + 1) // 2 + j // F
            counts[cell] += 1
            for k, h in enumerate(H):
                s = 1.0 if h >= a else (-1.0 if h <= b else s)
                sums[k, cell] += s
    return sums / counts


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from([2, 4, 6]), st.sampled_from([1, 2, 4]),
       st.sampled_from(everett.STARTS), st.booleans())
def test_the_compiled_cell_states_are_the_models_definition(seed, L, F, start, stepped):
    """The compiled cell sums (issue 23's speed goal) give each cell's mean hysteron state exactly: a stepped path
    (levels repeated, H on a switching field) and a random walk, from each start state."""
    rng = np.random.default_rng(seed)
    H = np.cumsum(rng.normal(size=int(rng.integers(3, 40)))) * 20.0
    lv = np.sort(rng.normal(size=L)) * 20.0
    if stepped:
        H = np.round(H / 10.0) * 10.0
        lv = np.round(lv / 10.0) * 10.0 + 5.0 * np.arange(L)  # distinct, some on H's levels
    assert np.array_equal(everett.cell_states(H, lv, start, F), _cell_means_by_definition(H, lv, start, F))


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from([2, 5, 10, 13, 16]), st.integers(1, 60))
def test_the_pair_sums_are_the_product_with_the_pair_matrix(seed, G, n):
    """The base's columns, one per mirror pair: the gathered sums are the bytes of S @ P (cell means, and rows of
    zeros before the first sample)."""
    rng = np.random.default_rng(seed)
    P = everett.structure(G)[1]
    S = rng.integers(-16, 17, (n, P.shape[0])) / rng.choice([10.0, 16.0])
    S[: n // 3] = 0.0
    A = everett.pair_sums(S, G)
    assert A.flags["C_CONTIGUOUS"] and A.tobytes() == np.einsum("ij,jk->ik", S, P).tobytes()


def test_a_clipped_fit_treats_the_flagged_samples_as_censored_readings(monkeypatch):
    """Samples flagged at a rail read "B at or beyond the rail". A column only they can pin (a step where the data
    are clipped) stays 0 when they are left out of the fit, so the clipped model falls short of the rail there; with
    them as censored readings (fitted while the model falls short, free beyond the rail) base + clip meets every
    sample. The noise-free truth: a line plus a step of 0.3 from t = 0.7, clipped at 0.5."""
    t = np.linspace(0.0, 1.0, 21)
    X = np.column_stack([np.ones_like(t), t, (t > 0.7).astype(float)])
    y_true = X @ np.array([0.1, 0.5, 0.3])
    hi = 0.5
    y, cens = np.minimum(y_true, hi), y_true >= hi
    rows, fold = np.ones(t.size, dtype=bool), np.arange(t.size) % 5
    model = everett.Model(X, y, np.zeros((1, 3)), clip=(-np.inf, hi), cens=cens)
    assert model.stats(rows, 1e-12, fold)["rms_T"] < 1e-9
    monkeypatch.setattr(everett.Model, "_censored", lambda self, rows, tr, lam: tr)  # the flagged ones left out
    short = everett.Model(X, y, np.zeros((1, 3)), clip=(-np.inf, hi), cens=cens).stats(rows, 1e-12, fold)
    assert short["rms_T"] > 1e-2
