"""mrhyst.fit.prefetch: scipy least_squares with each residual and its Jacobian's points in one batched call
gives the same fit, byte for byte, with fewer batched calls."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.fit.prefetch import Prefetch, fd_points
from scipy.optimize import least_squares

T = np.linspace(0.0, 3.0, 40)


def _rows(X):
    """A nonlinear model evaluated row by row: row i has the bytes of a lone evaluation of X[i]."""
    X = np.atleast_2d(X)
    y = 1.7 * np.exp(-0.8 * T) + 0.3 * np.sin(2.1 * T)
    return np.array([x[0] * np.exp(-x[1] * T) + x[2] * np.sin(x[3] * T) - y for x in X])


def _plain(x0, lo, hi, diff_step=None):
    calls = []

    def fun(x):
        calls.append(1)
        return _rows(x)[0]

    res = least_squares(fun, x0, bounds=(lo, hi), method="trf", x_scale="jac", ftol=1e-12, xtol=1e-12,
                        gtol=1e-12, diff_step=diff_step, max_nfev=200)
    return res, len(calls)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(0.1, 0.9), min_size=4, max_size=4), st.sampled_from([None, 1e-6]))
def test_same_fit_bytes_fewer_calls(u, diff_step):
    """Any start in the box, with and without a relative step: x, residuals, cost, nfev and njev are the bytes
    of the plain fit, the evaluations counted are the plain fit's, and there is one batched call per residual
    at most (the plain fit makes one per residual and one per Jacobian column)."""
    lo, hi = np.array([0.1, 0.1, 0.0, 0.5]), np.array([5.0, 3.0, 1.0, 4.0])
    x0 = lo + np.asarray(u) * (hi - lo)
    ref, n_plain = _plain(x0, lo, hi, diff_step)
    batches = []
    pf = Prefetch(lambda X: batches.append(len(X)) or _rows(X), lo, hi, diff_step)
    res = least_squares(pf.fun, x0, bounds=(lo, hi), method="trf", x_scale="jac", ftol=1e-12, xtol=1e-12,
                        gtol=1e-12, diff_step=diff_step, max_nfev=200, workers=pf.map)
    assert res.x.tobytes() == ref.x.tobytes() and res.fun.tobytes() == ref.fun.tobytes()
    assert (res.cost, res.nfev, res.njev, res.status) == (ref.cost, ref.nfev, ref.njev, ref.status)
    assert ref.njev >= 2 and pf.evals == n_plain  # what scipy asked for: the residuals and every Jacobian point
    n_residuals = n_plain - 4 * ref.njev
    assert len(batches) <= n_residuals  # one batched call per residual; the Jacobians' points come with them


def test_points_are_scipys_own_at_the_bounds():
    """At the upper bound scipy steps backwards: the predicted points are the ones it asks for."""
    lo, hi = np.zeros(3), np.ones(3)
    x = np.array([1.0, 0.5, 0.0])
    asked = []
    from scipy.optimize._numdiff import approx_derivative

    approx_derivative(lambda v: v.copy(), x, method="2-point", bounds=(lo, hi),
                      workers=lambda f, xs: [asked.append(v.copy()) or v for v in xs])
    assert np.array_equal(np.array(asked), fd_points(x, lo, hi))
    assert fd_points(x, lo, hi)[0, 0] < 1.0  # the step into the box


def test_lsm_fit_same_with_and_without_prefetch():
    """mrhyst's LSM (run_lsm) on a noisy J-A loop in the physical form: with prefetching, and with a problem that
    has no batched rows (every residual and Jacobian point alone, as scipy does by itself), the same bytes and
    the same evaluation count."""
    from mrhyst.fit import identify as idf
    from mrhyst.model import ja

    I = ja.paper_current_path(2.0, 27)
    H = I * 3000.0
    truth = np.array([1.1e6, 1500.0, 1.2e-3, 0.25, 1800.0])
    B, ok = ja.simulate_h(truth, H, form="physical", substeps=2)
    assert ok
    B = B + 1e-4 * np.random.default_rng(3).standard_normal(B.size)

    def problem():
        return idf.Problem(H, B, np.ones(B.size, dtype=bool), **idf.problem_kw(form="physical", substeps=2))

    class Lone:  # the same problem without residual_rows
        def __init__(self, p):
            self.p = p

        def __getattr__(self, k):
            if k == "residual_rows":
                raise AttributeError(k)
            return getattr(self.p, k)

    box = idf.table_box(truth)
    a = idf.run_lsm(problem(), box, truth * 1.2, max_iterations=20)
    b = idf.run_lsm(Lone(problem()), box, truth * 1.2, max_iterations=20)
    assert a["x"].tobytes() == b["x"].tobytes() and a["history"] == b["history"] and a["J"] < 2e-4
    assert a["n_evals"] == b["n_evals"] > 20


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=4, max_size=4), st.sampled_from([None, 1e-6]))
def test_jac_gives_scipys_two_point_fit(u, diff_step):
    """jac=pf.jac against scipy's own 2-point Jacobian (no prefetch at all), from any start in the box, the
    bounds included (scipy steps backwards there): x, residuals, cost, Jacobian, nfev, njev and status are the
    same bytes, and the evaluations counted are the plain fit's."""
    lo, hi = np.array([0.1, 0.1, 0.0, 0.5]), np.array([5.0, 3.0, 1.0, 4.0])
    x0 = lo + np.asarray(u) * (hi - lo)
    ref, n_plain = _plain(x0, lo, hi, diff_step)
    pf = Prefetch(_rows, lo, hi, diff_step)
    res = least_squares(pf.fun, x0, bounds=(lo, hi), method="trf", x_scale="jac", ftol=1e-12, xtol=1e-12,
                        gtol=1e-12, diff_step=diff_step, max_nfev=200, jac=pf.jac)
    assert res.x.tobytes() == ref.x.tobytes() and res.fun.tobytes() == ref.fun.tobytes()
    assert res.jac.tobytes() == ref.jac.tobytes()
    assert (res.cost, res.nfev, res.njev, res.status) == (ref.cost, ref.nfev, ref.njev, ref.status)
    assert pf.evals == n_plain


def test_jac_by_hand_at_a_bound():
    """At the upper bound the column is the backward difference (f(x - h) - f(x)) / (-h): computed here by hand
    from the model, with scipy's step rule for rel_step None (sqrt(eps) max(1, |x|))."""
    lo, hi = np.array([0.1, 0.1, 0.0, 0.5]), np.array([5.0, 3.0, 1.0, 4.0])
    x = np.array([5.0, 1.0, 0.5, 2.0])  # Ms at its upper bound
    pf = Prefetch(_rows, lo, hi)
    pf.fun(x)
    J = pf.jac(x)
    h = np.sqrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(x))
    f0 = _rows(x)[0]
    xb = x.copy()
    xb[0] = x[0] - h[0]
    assert np.allclose(J[:, 0], (_rows(xb)[0] - f0) / (xb[0] - x[0]), rtol=1e-12, atol=0)
    xf = x.copy()
    xf[1] = x[1] + h[1]
    assert np.allclose(J[:, 1], (_rows(xf)[0] - f0) / (xf[1] - x[1]), rtol=1e-12, atol=0)
    assert np.allclose(J[:, 0], np.exp(-x[1] * T), rtol=1e-6)  # d/dx0 of x0 exp(-x1 T): the model's own slope


def _scipy_points(x, lo, hi, rel_step=None):
    from scipy.optimize._numdiff import _adjust_scheme_to_bounds, _compute_absolute_step

    h = _compute_absolute_step(rel_step, x, np.zeros(1), "2-point")
    h, _ = _adjust_scheme_to_bounds(x, h, 1, "1-sided", lo, hi)
    X = np.repeat(x[None, :], x.size, axis=0)
    X[np.arange(x.size), np.arange(x.size)] = x + h
    return X


_bound = st.one_of(st.floats(-1e6, 1e6), st.just(np.inf), st.just(-np.inf))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(st.floats(-1e6, 1e6), _bound, _bound, st.sampled_from([0.0, 1e-9, 1e-3, 1.0])),
                min_size=1, max_size=7))
def test_points_are_the_bytes_of_scipys_step_helpers(coords):
    """fd_points' own step rule (Python floats, mrhyst.fit.prefetch._steps) against scipy's helpers on arrays,
    for x anywhere: inside, on and near a bound (x at lo + d), outside, with infinite bounds on either side."""
    x = np.array([c[0] for c in coords])
    lo = np.array([min(c[1], c[2]) for c in coords])
    hi = np.array([max(c[1], c[2]) for c in coords])
    near = np.where(np.isfinite(lo), lo + np.array([c[3] for c in coords]), x)  # x on or just inside lo
    for xs in (x, near):
        assert fd_points(xs, lo, hi).tobytes() == _scipy_points(xs, lo, hi).tobytes()


def test_points_in_a_box_narrower_than_the_step():
    """A box narrower than the step: scipy steps to the farther bound, forwards on a tie (x at the middle)."""
    lo, hi = np.array([0.0, 0.0, -1.0]), np.array([1e-12, 1e-12, -1.0 + 1e-12])
    for x in (np.array([5e-13, 1e-13, -1.0 + 9e-13]), lo.copy(), hi.copy()):
        assert fd_points(x, lo, hi).tobytes() == _scipy_points(x, lo, hi).tobytes()
