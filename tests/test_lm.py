"""The batched Levenberg-Marquardt (mrhyst.fit.lm) against scipy.optimize.least_squares on the same problems:
same optimum within tolerance, from the same starts, with and without bounds and frozen coordinates."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.fit.lm import least_squares_batch
from scipy.optimize import least_squares

T = np.linspace(0.0, 4.0, 40)


def decay_model(X):
    """y = A exp(-t / tau) + C, batched over rows (A, ln tau, C)."""
    X = np.atleast_2d(X)
    return X[:, :1] * np.exp(-T[None, :] / np.exp(X[:, 1:2])) + X[:, 2:3]


def data(seed=0):
    rng = np.random.default_rng(seed)
    return decay_model([2.0, np.log(0.7), 0.3])[0] + 0.01 * rng.standard_normal(T.size)


def scipy_fit(y, x0, lo=-np.inf, hi=np.inf):
    return least_squares(lambda x: decay_model(x)[0] - y, x0, bounds=(lo, hi), method="trf",
                         xtol=1e-14, ftol=1e-14, gtol=1e-14)


def test_unbounded_matches_scipy_from_every_start():
    y = data()
    starts = np.array([[1.0, 0.0, 0.0], [3.0, -1.0, 1.0], [1.5, 0.5, -0.2], [2.0, np.log(0.7), 0.3]])
    res = least_squares_batch(lambda X, rows: decay_model(X) - y, starts, ftol=1e-14, max_iter=500)
    for i, x0 in enumerate(starts):
        ref = scipy_fit(y, x0)
        assert res.cost[i] == pytest.approx(2 * ref.cost, rel=1e-6)  # scipy's cost is half the sum
        np.testing.assert_allclose(res.x[i], ref.x, rtol=1e-4, atol=1e-6)


def test_active_bound_matches_scipy():
    """The offset C is held below its free optimum (0.3): both solvers stop on the bound, same point."""
    y = data(1)
    lo, hi = np.array([0.0, -3.0, -1.0]), np.array([5.0, 3.0, 0.1])
    x0 = np.array([1.0, 0.0, 0.0])
    res = least_squares_batch(lambda X, rows: decay_model(X) - y, x0, bounds=(lo, hi), ftol=1e-14, max_iter=500)
    ref = scipy_fit(y, x0, lo, hi)
    assert res.x[0, 2] == pytest.approx(0.1, abs=1e-12)
    assert res.cost[0] == pytest.approx(2 * ref.cost, rel=1e-6)
    np.testing.assert_allclose(res.x[0], ref.x, rtol=1e-4, atol=1e-6)


def test_masked_coordinate_never_moves_and_the_rest_match_scipy():
    y = data(2)
    x0 = np.array([[1.0, 0.0, 0.25]])
    mask = np.array([True, True, False])
    res = least_squares_batch(lambda X, rows: decay_model(X) - y, x0, mask=mask, ftol=1e-14, max_iter=500)
    assert res.x[0, 2] == 0.25
    ref = least_squares(lambda x: decay_model([x[0], x[1], 0.25])[0] - y, x0[0, :2], method="trf",
                        xtol=1e-14, ftol=1e-14, gtol=1e-14)
    np.testing.assert_allclose(res.x[0, :2], ref.x, rtol=1e-4, atol=1e-6)


def test_rows_carry_their_own_weights():
    """fun gets the problem rows: row 1 fits only the first half of the samples (as a CV fold does)."""
    y = data(3)
    W = np.ones((2, T.size))
    W[1, T.size // 2:] = 0.0
    x0 = np.tile([1.0, 0.0, 0.0], (2, 1))
    res = least_squares_batch(lambda X, rows: (decay_model(X) - y) * W[rows], x0, ftol=1e-14, max_iter=500)
    half = T.size // 2
    ref = least_squares(lambda x: decay_model(x)[0, :half] - y[:half], x0[1], method="trf",
                        xtol=1e-14, ftol=1e-14, gtol=1e-14)
    assert res.cost[1] == pytest.approx(2 * ref.cost, rel=1e-6)
    assert res.cost[0] > res.cost[1]


def test_invalid_start_is_reported_not_raised():
    y = data()
    res = least_squares_batch(lambda X, rows: np.where(X[:, :1] < 0, np.nan, decay_model(X) - y),
                              np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), max_iter=50)
    assert not np.isfinite(res.cost[0]) and np.isfinite(res.cost[1])


@settings(max_examples=15, deadline=None)
@given(st.floats(0.5, 3.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0))
def test_property_same_optimum_as_scipy(a, lntau, c):
    """Noise-free data of any decay in the box: both solvers reach the truth from the same start."""
    y = decay_model([a, lntau, c])[0]
    x0 = np.array([1.5, 0.0, 0.0])
    res = least_squares_batch(lambda X, rows: decay_model(X) - y, x0, ftol=1e-15, max_iter=1000)
    ref = scipy_fit(y, x0)
    assert res.cost[0] <= max(2 * ref.cost, 1e-20) * (1 + 1e-6) + 1e-20
    np.testing.assert_allclose(res.x[0], ref.x, rtol=1e-4, atol=1e-5)
