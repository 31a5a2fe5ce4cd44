"""scipy ``least_squares``: the residual at a point and its finite-difference Jacobian in ONE batched call.

In every TRF iteration scipy evaluates the residual at a trial point and, once the step is accepted, its
2-point Jacobian there: D more points ``x + h_i e_i``, which :func:`scipy.optimize.approx_derivative` hands to
the ``workers`` map in one go. The J-A kernel integrates a block of 16 parameter sets in about the time of one
(its lanes run in SIMD and the block is latency-bound: 1, 8 or 16 sets cost the same, 98-101 us a call on a
53-sample loop at 8 substeps; bench/README.md, "The LSM's Jacobian"), so
:meth:`Prefetch.fun` evaluates the trial point *together with* the D points scipy will ask for if it accepts
it, and :meth:`Prefetch.map` (the ``workers`` argument) serves them from that call. The points are scipy's
own (its private step helpers, called as approx_derivative calls them), the rows are the batch's (row i has
the bytes of a lone evaluation of X[i]: every set is integrated in its own lane), and a point it did not
foresee is evaluated as before: the fit is the same bytes, with one kernel call per iteration instead of two.

:meth:`Prefetch.jac` (``jac=pf.jac``) goes one step further: it forms scipy's 2-point Jacobian from those
rows itself, with the operations of scipy's ``_dense_difference`` in their order (the same bytes), and skips
scipy's per-Jacobian set-up (bounds, steps and the map wrapper: in the blind key's reference fits, a fifth of
the solver's own time).
"""

from __future__ import annotations

import math

import numpy as np

_RSTEP = float(np.finfo(np.float64).eps ** 0.5)  # scipy's relative '2-point' step for float64 (_eps_for_method)


def _steps(x: np.ndarray, lb: np.ndarray, ub: np.ndarray) -> list:
    """scipy's '2-point' steps at a finite x for the default relative step, element by element in Python floats
    (the same IEEE operations as scipy's _compute_absolute_step and 1-sided _adjust_scheme_to_bounds on arrays,
    at a quarter of their numpy call overhead: ~65,000 calls in one part of the blind key). A coordinate with
    both bounds infinite is left as it is, as scipy leaves every coordinate when all are; tests/test_prefetch.py
    holds it to scipy's helpers."""
    out = []
    for xi, lo, hi in zip(x.tolist(), lb.tolist(), ub.tolist()):
        h = _RSTEP * (1.0 if xi >= 0 else -1.0) * max(1.0, abs(xi))
        if lo != -np.inf or hi != np.inf:
            below, above = xi - lo, hi - xi
            fitting = abs(h) <= max(below, above)
            if fitting and not lo <= xi + h <= hi:
                h = -h  # the step leaves the box and the other side has room: step the other way
            elif not fitting:
                h = above if above >= below else -below
        out.append(h)
    return out


def _fast_points(x: np.ndarray, lb, ub) -> np.ndarray | None:
    """:func:`fd_points` for a finite 1-D float64 x and bounds of its shape without NaN, built from Python floats
    in one array call (x[i] + h[i] is the same IEEE addition as numpy's); None where that does not hold."""
    if not (isinstance(lb, np.ndarray) and isinstance(ub, np.ndarray) and x.ndim == 1 and x.dtype == np.float64
            and lb.shape == x.shape == ub.shape):
        return None
    xs, los, his = x.tolist(), lb.tolist(), ub.tolist()
    if not all(math.isfinite(v) for v in xs) or any(v != v for v in los + his):
        return None
    rows = []
    for i, h in enumerate(_steps(x, lb, ub)):
        row = list(xs)
        row[i] = xs[i] + h
        rows.append(row)
    return np.array(rows, dtype=np.float64)


def fd_points(x: np.ndarray, lb, ub, rel_step=None) -> np.ndarray | None:
    """The D points scipy's '2-point' Jacobian at x evaluates (x with x[i] + h[i] in row i), or None where
    this scipy's step helpers are not what they were (then nothing is prefetched; the fit is unchanged)."""
    if rel_step is None:
        X = _fast_points(x, lb, ub)  # the fits' case (~65,000 calls in one part of the blind key)
        if X is not None:
            return X
    lb, ub = np.broadcast_to(lb, x.shape), np.broadcast_to(ub, x.shape)
    if rel_step is None and np.isfinite(x).all() and not np.isnan(lb).any() and not np.isnan(ub).any():
        X = np.repeat(x[None, :], x.size, axis=0)
        idx = np.arange(x.size)
        X[idx, idx] = x + np.array(_steps(x, lb, ub))
        return X
    try:
        from scipy.optimize._numdiff import _adjust_scheme_to_bounds, _compute_absolute_step

        h = _compute_absolute_step(rel_step, x, np.zeros(1), "2-point")  # f0: only its dtype is read
        h, _ = _adjust_scheme_to_bounds(x, h, 1, "1-sided", lb, ub)
    except Exception:  # a private API: any change there only turns prefetching off
        return None
    X = np.repeat(x[None, :], x.size, axis=0)
    idx = np.arange(x.size)
    X[idx, idx] = x + h  # elementwise, as scipy's x1[i] = x0[i] + h[i]
    return X


class Prefetch:
    """``fun`` and ``map`` for :func:`scipy.optimize.least_squares` (``workers=pf.map``) over ``rows``: a batch
    X (k, D) -> residuals (k, m) whose row i has the bytes of a single evaluation of X[i].

    ``evals`` counts the evaluations scipy asked for (the count a fit reports, prefetched rows not included)."""

    def __init__(self, rows, lb, ub, rel_step=None, block: int | None = None):
        self.rows = rows
        # at most this many rows prefetched with a trial point (None: all D): a kernel of blocks of ``block`` lanes
        # pays a second block for the last points, which a rejected step never needs (the 17-coordinate law fit of
        # rule gdlaws_fit: 18 rows, a quarter of its steps rejected; its jac evaluates the rest)
        self.block = block
        self.lb = np.asarray(lb, dtype=float)
        self.ub = np.asarray(ub, dtype=float)
        self.rel_step = rel_step
        self.memo: dict[bytes, np.ndarray] = {}
        self.evals = 0
        self._points = (None, None)  # (x.tobytes(), fd_points(x)) of the last miss: jac needs them again

    def _evaluate(self, X: np.ndarray) -> np.ndarray:
        return np.asarray(self.rows(X), dtype=float)

    def fun(self, x) -> np.ndarray:
        """The residual at x; on a miss, x and its Jacobian's points (at most ``block`` - 1 of them) in one call
        (they replace the memo)."""
        x = np.asarray(x, dtype=float)
        self.evals += 1
        r = self.memo.get(x.tobytes())
        if r is None:
            F = fd_points(x, self.lb, self.ub, self.rel_step)
            self._points = (x.tobytes(), F)
            if F is not None and self.block is not None:
                F = F[: self.block - 1]
            X = x[None, :] if F is None else np.vstack([x[None, :], F])
            R = self._evaluate(X)
            self.memo = {X[i].tobytes(): R[i] for i in range(X.shape[0])}
            r = R[0]
        return r.copy()

    def map(self, fun, xs) -> list:
        """scipy's ``workers``: the residual at every point of xs (``fun`` is scipy's wrapper of :meth:`fun`,
        not needed); points the memo lacks are evaluated in one call."""
        xs = [np.asarray(x, dtype=float) for x in xs]
        self.evals += len(xs)
        miss = [x for x in xs if x.tobytes() not in self.memo]
        if miss:
            X = np.array(miss)
            R = self._evaluate(X)
            self.memo.update({X[i].tobytes(): R[i] for i in range(X.shape[0])})
        return [self.memo[x.tobytes()].copy() for x in xs]

    def jac(self, x) -> np.ndarray:
        """scipy's '2-point' Jacobian at x (least_squares ``jac=pf.jac``): the bytes of ``jac='2-point'`` with
        ``workers=pf.map``, and the same evaluations counted (scipy's f0 is its residual at x, not counted).
        Row i of J' is (f(x + h_i e_i) - f(x)) / ((x_i + h_i) - x_i), as scipy's ``_dense_difference`` forms
        it, and J is J'.T (the memory order scipy returns); where :func:`fd_points` is None, scipy's own
        ``approx_derivative``."""
        x = np.asarray(x, dtype=float)
        key = x.tobytes()
        F = self._points[1] if self._points[0] == key else fd_points(x, self.lb, self.ub, self.rel_step)
        if F is None:
            from scipy.optimize import approx_derivative

            return approx_derivative(self.fun, x, method="2-point", rel_step=self.rel_step, f0=self._rows_of([x])[0],
                                     bounds=(self.lb, self.ub), workers=self.map)
        self.evals += F.shape[0]
        R = self._rows_of([x, *F])
        dx = np.array([F[i, i] - x[i] for i in range(x.size)])
        J_transposed = (R[1:] - R[0]) / dx[:, None]
        return J_transposed.T

    def _rows_of(self, xs) -> np.ndarray:
        """The residuals at xs (from the memo; the points it lacks in one call, not counted)."""
        miss = [v for v in xs if v.tobytes() not in self.memo]
        if miss:
            X = np.array(miss)
            R = self._evaluate(X)
            self.memo.update({X[i].tobytes(): R[i] for i in range(X.shape[0])})
        return np.array([self.memo[v.tobytes()] for v in xs])
