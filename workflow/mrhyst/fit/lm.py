"""Batched Levenberg-Marquardt with geodesic acceleration and box bounds.

``least_squares_batch(fun, x0, bounds, ...)`` minimises ``0.5 * sum(fun(x)**2)`` for every row of ``x0``
(N, D) from its own start, all rows in lock-step: one call of ``fun`` evaluates every row that needs a
residual (the forward-difference Jacobian columns of all rows are one batch as well). That is the point
of this solver: with a vectorised model (the batched J-A kernel) N fits cost about as much as one call
per step, measured 3-4x faster than ``scipy.optimize.least_squares`` run N times (bench/bench_diagnose.py).

The method (Transtrum & Sethna 2012, "Improvements to the Levenberg-Marquardt algorithm for nonlinear
least-squares minimization"): Marquardt damping on the running maximum of diag(J'J), a geodesic
acceleration term (second directional derivative of the residual along the step, by a finite
difference) accepted when it is small against the velocity, bounds by an active set (a coordinate at a
bound whose gradient points out of the box is frozen for the step) and clipping of the step into the
box. ``mask`` (N, D) frees coordinates per row: a row's other coordinates never move.

``fun(X, rows) -> R``: the residuals (k, m) of the parameter rows ``X`` (k, D), which belong to the
problem rows ``rows`` (k,) (so a row may carry its own data weights). A row of R that is not finite
means "no valid model here" (cost = inf: the step is rejected).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

LANES = 16  # parameter sets the batched J-A kernel integrates in about the time of one (mrhyst.model.ja.LANES)
MAX_ATTEMPTS = 8


@dataclass
class LMResult:
    x: np.ndarray  # (N, D) solution per row
    cost: np.ndarray  # (N,) sum of squared residuals (inf when no valid start)
    fun: np.ndarray  # (N, m) residuals at x
    nit: np.ndarray  # (N,) iterations taken
    converged: np.ndarray  # (N,) stopped by the cost tolerance or the damping cap, not by max_iter
    nfev: int  # rows evaluated in total


def _eval(fun, X, rows):
    with np.errstate(invalid="ignore", over="ignore"):
        r = np.array(fun(X, rows), dtype=float)
        cost = np.einsum("ij,ij->i", r, r)
    bad = ~np.isfinite(cost)
    cost[bad] = np.inf
    r[bad] = 0.0
    return r, cost


def _normal(J, r, need_A: bool):
    """(J'r (n, D), J'J (n, D, D) or None) per row of J (n, m, D), r (n, m); J'J only when ``need_A``.

    The bytes of np.einsum("nmj,nm->nj") and ("nmi,nmj->nij"): for D >= 2 einsum sums these strided operands
    in order m = 0, 1, ... from 0 without FMA, as the compiled loop does (tests/test_lm.py checks it), at a
    fraction of einsum's call overhead; for D = 1 the sum over m is contiguous and einsum takes its SIMD
    path, so einsum it is."""
    if J.shape[2] < 2:
        return np.einsum("nmj,nm->nj", J, r), (np.einsum("nmi,nmj->nij", J, J) if need_A else None)
    g, A = _normal_compiled(J, r, need_A)
    return g, (A if need_A else None)


@numba.njit(cache=True)
def _normal_compiled(J, r, need_A):
    n, m, D = J.shape
    g = np.zeros((n, D))
    A = np.zeros((n, D, D) if need_A else (0, D, D))
    for k in range(n):
        for t in range(m):
            rt = r[k, t]
            for i in range(D):
                ji = J[k, t, i]
                g[k, i] += ji * rt
                if need_A:
                    for j in range(i, D):
                        A[k, i, j] += ji * J[k, t, j]
        if need_A:
            for i in range(D):
                for j in range(i):
                    A[k, i, j] = A[k, j, i]
    return g, A


def _solve(M, rhs, free) -> np.ndarray:
    """-M^-1 rhs per row, with the frozen coordinates' entries of rhs set to 0."""
    rhs = np.where(free, rhs, 0.0)
    try:
        return -np.linalg.solve(M, rhs[:, :, None])[:, :, 0]
    except np.linalg.LinAlgError:
        return -np.stack([np.linalg.lstsq(M[k], rhs[k], rcond=None)[0] for k in range(M.shape[0])])


def _jacobian(fun, X, r, rows, act, hi, steps):
    """Forward-difference Jacobians (k, m, D) of the rows ``rows`` at X[rows], all columns in one call."""
    J = np.zeros((rows.size, r.shape[1], X.shape[1]))
    # (row, column) pairs, row-major: one difference per free column. Contiguous copies: np.nonzero's are strided
    # views unless there is one pair, and each layout is a kernel signature of its own for numba to compile
    kk, jj = (np.ascontiguousarray(v) for v in np.nonzero(act[rows]))
    if kk.size == 0:
        return J
    ii = rows[kk]
    Xp, h = _probes(X, ii, jj, hi, steps)
    rp, cp = _eval(fun, Xp, ii)
    _columns(J, kk, jj, rp, r, ii, h, cp)
    return J


@numba.njit(cache=True)
def _probes(X, ii, jj, hi, steps):
    """The probe points (X[ii] with coordinate jj moved by its step, backwards where that leaves the box)."""
    Xp = np.empty((ii.size, X.shape[1]))
    h = np.empty(ii.size)
    for p in range(ii.size):  # element loops, not row slices: those cost seconds of compile time
        i, j = ii[p], jj[p]
        h[p] = -steps[j] if X[i, j] + steps[j] > hi[i, j] else steps[j]
        for q in range(X.shape[1]):
            Xp[p, q] = X[i, q]
        Xp[p, j] += h[p]
    return Xp, h


@numba.njit(cache=True)
def _columns(J, kk, jj, rp, r, ii, h, cp):
    """J[kk, :, jj] = (rp - r[ii]) / h, 0 where the probe had no valid model."""
    for p in range(kk.size):
        good = np.isfinite(cp[p])
        for t in range(rp.shape[1]):
            J[kk[p], t, jj[p]] = (rp[p, t] - r[ii[p], t]) / h[p] if good else 0.0


@numba.njit(cache=True)
def _damped(A, g, X, lo, hi, act, Dmax, lam):
    """(free (n, D), d (n, D), M (n, D, D)) of the live rows: the free coordinates (active, and not at a bound
    that the gradient pushes against), the running maximum d of diag(J'J), and the damped normal matrix
    M = J'J + lam diag(d + 1e-12 max(d_free)) restricted to the free coordinates, with 1 on the diagonal of a
    frozen one. Elementwise only, no FMA: the bytes of the numpy form this replaced (np.where / np.maximum /
    eye products), at a fraction of its call overhead."""
    n, D = g.shape
    free = np.empty((n, D), dtype=np.bool_)
    d = np.empty((n, D))
    M = np.empty((n, D, D))
    for k in range(n):
        scale = 0.0
        for i in range(D):
            free[k, i] = act[k, i] and not ((X[k, i] <= lo[k, i]) and (g[k, i] > 0)) and not (
                (X[k, i] >= hi[k, i]) and (g[k, i] < 0))
            a, b = Dmax[k, i], A[k, i, i]
            d[k, i] = a if (a > b or a != a) else b  # np.maximum: NaN propagates
            v = d[k, i] if free[k, i] else 0.0
            scale = v if (i == 0 or v > scale or v != v) else scale
        scale = scale + 1e-300
        for i in range(D):
            for j in range(D):
                m = A[k, i, j] + (lam[k] * (d[k, i] + 1e-12 * scale) if i == j else 0.0)
                m = m if (free[k, i] and free[k, j]) else 0.0
                M[k, i, j] = m + ((0.0 if free[k, i] else 1.0) if i == j else 0.0)
    return free, d, M


def _step(fun, X, r, J, G, A, Dmax, lam, lo, hi, act, live):
    """Trial point of every live row (``live`` may name a row more than once): damped Gauss-Newton velocity
    plus geodesic acceleration, at the damping ``lam`` (one per entry of ``live``). G, A: J'r and J'J of
    every row (they change only with its Jacobian)."""
    Jl, rl = J[live], r[live]
    g, A = G[live], A[live]
    Xl, lol, hil = X[live], lo[live], hi[live]
    free, d, M = _damped(A, g, Xl, lol, hil, act[live], Dmax[live], lam)
    Dmax[live] = d
    vel = _solve(M, g, free)
    hv = 0.1
    rh, ch = _eval(fun, np.clip(Xl + hv * vel, lol, hil), live)
    rvv = (2.0 / hv) * ((rh - rl) / hv - np.einsum("nmj,nj->nm", Jl, vel))
    acc = _solve(M, _normal(Jl, rvv, False)[0], free)
    sq = np.sqrt(d + 1e-300)
    ratio = np.linalg.norm(acc * sq, axis=1) / (np.linalg.norm(vel * sq, axis=1) + 1e-300)
    use_acc = np.isfinite(ch) & (2.0 * ratio <= 0.75)
    return np.clip(Xl + vel + np.where(use_acc[:, None], 0.5 * acc, 0.0), lol, hil)


@numba.njit(cache=True)
def _accept(live, k, Xn, rn, cn, X, r, cost, lam, need, done, nit, max_iter, ftol, lam_max):
    """Each live row's attempts in turn (row q's attempt j is entry q * k + j of Xn, made at lam * 2^j): the
    first that lowers the cost is taken (less damping, a new Jacobian next), each that does not doubles the
    damping. A row is done when its relative decrease falls below ftol or its damping passes lam_max; it
    stops trying at max_iter attempts. Attempt j is the step the row would take after j rejections, so this is
    the one-attempt-per-iteration LM, step for step."""
    for q in range(live.size):
        i = live[q]
        for j in range(k):
            p = q * k + j
            nit[i] += 1
            if cn[p] < cost[i]:
                rel = (cost[i] - cn[p]) / cost[i] if cost[i] > 0 else 0.0
                for c in range(X.shape[1]):
                    X[i, c] = Xn[p, c]
                for t in range(r.shape[1]):
                    r[i, t] = rn[p, t]
                cost[i] = cn[p]
                lam[i] = max(lam[i] / 3.0, 1e-12)
                need[i] = True
                done[i] = rel < ftol or cost[i] == 0.0
                break
            lam[i] *= 2.0
            done[i] = lam[i] > lam_max
            if done[i] or nit[i] >= max_iter:
                break


def _attempts(n_live: int, lanes: int = LANES) -> int:
    """Dampings tried at once per row: as many as fill the lanes of the model blocks the live rows take anyway
    (a batched model integrates a block of ``lanes`` rows in about the time of one), at most MAX_ATTEMPTS. In the
    long tail of a run, where a few rows go on and most of their steps are rejected, one model call then does
    the work of several iterations. A model whose rows cost in proportion (``lanes`` = 1) tries one."""
    return max(1, min(MAX_ATTEMPTS, (lanes * -(-n_live // lanes)) // n_live))


def least_squares_batch(fun, x0, bounds=(-np.inf, np.inf), mask=None, *, diff_step=1e-7, max_iter: int = 200,
                        ftol: float = 1e-9, lam0: float = 1e-3, lam_max: float = 1e10, lanes: int = LANES) -> LMResult:
    """Minimise sum(fun(x)^2) for every row of ``x0`` (see the module docstring).

    ``bounds``: (lo, hi), each broadcastable to x0's shape (N, D); ``mask``: (N, D) or (D,) bool, the
    free coordinates (default all); ``diff_step``: absolute forward-difference step per coordinate
    (scalar or (D,)); ``ftol``: a row stops when an accepted step lowers its cost by less than this
    fraction; ``lam_max``: a row stops when its damping exceeds this (no step lowers the cost); ``lanes``: rows
    that ``fun`` evaluates in about the time of one (a row of two J-A sets: LANES // 2; a model without lanes: 1).
    It sets only how many dampings a row tries per model call, never the result (attempt j is the step after j
    rejections).
    """
    X = np.atleast_2d(np.array(x0, dtype=float))
    N, D = X.shape
    lo = np.broadcast_to(np.asarray(bounds[0], dtype=float), (N, D)).copy()
    hi = np.broadcast_to(np.asarray(bounds[1], dtype=float), (N, D)).copy()
    act = np.ones((N, D), dtype=bool) if mask is None else np.broadcast_to(np.asarray(mask, dtype=bool), (N, D))
    X = np.clip(X, lo, hi)
    steps = np.broadcast_to(np.asarray(diff_step, dtype=float), (D,)).copy()
    r, cost = _eval(fun, X, np.arange(N))
    nfev = N
    lam = np.full(N, float(lam0))
    done = ~np.isfinite(cost)
    need = np.ones(N, dtype=bool)
    J = np.zeros((N, r.shape[1], D))
    G, A = np.zeros((N, D)), np.zeros((N, D, D))  # J'r and J'J at each row's X: a rejected step leaves them
    Dmax = np.zeros((N, D))
    nit = np.zeros(N, dtype=int)
    while True:
        live = np.flatnonzero(~done & (nit < int(max_iter)))
        if live.size == 0:
            break
        jrows = live[need[live]]
        if jrows.size:
            J[jrows] = _jacobian(fun, X, r, jrows, act, hi, steps)
            G[jrows], A[jrows] = _normal(J[jrows], r[jrows], True)
            nfev += int(act[jrows].sum())
            need[jrows] = False
        k = _attempts(live.size, int(lanes))
        rows = np.repeat(live, k)
        Xn = _step(fun, X, r, J, G, A, Dmax, lam[rows] * np.tile(2.0 ** np.arange(k), live.size), lo, hi, act, rows)
        rn, cn = _eval(fun, Xn, rows)
        nfev += 2 * rows.size
        _accept(live, k, Xn, rn, cn, X, r, cost, lam, need, done, nit, int(max_iter), float(ftol), float(lam_max))
    # r and cost are those of X already (a row's residual is kept from the evaluation that accepted it)
    return LMResult(X, cost, r, nit, done.copy(), nfev)

