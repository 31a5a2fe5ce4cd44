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

The per-iteration work around the model calls is compiled (numba) in the summation orders of the numpy forms it
replaced (einsum, np.linalg.norm, np.clip; the two batched solves stay np.linalg.solve), so a fit gives the same bytes
(tests/test_lm_fused.py, tests/test_fastpaths.py). Why not start pruning or looser tails: bench/lm_anatomy.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

LANES = 16  # parameter sets the batched J-A kernel integrates in about the time of one (mrhyst.model.ja.LANES)
MAX_ATTEMPTS = 8
HV = 0.1  # step of the geodesic probe along the velocity


@dataclass
class LMResult:
    x: np.ndarray  # (N, D) solution per row
    cost: np.ndarray  # (N,) sum of squared residuals (inf when no valid start)
    fun: np.ndarray  # (N, m) residuals at x
    nit: np.ndarray  # (N,) iterations taken
    converged: np.ndarray  # (N,) stopped by the cost tolerance or the damping cap, not by max_iter
    nfev: int  # rows evaluated in total


def _eval(fun, X, rows):
    """(residuals with the rows that have no valid model set to 0, cost per row: inf for those)."""
    with np.errstate(invalid="ignore", over="ignore"):
        r = np.array(fun(X, rows), dtype=float)
    if r.ndim != 2 or r.shape[1] == 0 or not r.flags.c_contiguous:  # einsum sums another layout in another order
        return _eval_numpy(r)
    return r, _cost_rows(r)


def _eval_numpy(r):
    """:func:`_eval`'s cost in numpy (the form :func:`_cost_rows` replaced)."""
    with np.errstate(invalid="ignore", over="ignore"):
        cost = np.einsum("ij,ij->i", r, r)
    bad = ~np.isfinite(cost)
    cost[bad] = np.inf
    r[bad] = 0.0
    return r, cost


@numba.njit(cache=True)
def _cost_rows(r):
    """np.einsum("ij,ij->i", r, r) summed in its order (two lanes, blocks of 8, no FMA; see _curvature); a row
    whose cost is not finite gets cost inf and residuals 0."""
    n, m = r.shape
    cost = np.empty(n)
    for k in range(n):
        a0 = 0.0
        a1 = 0.0
        p = 0
        while m - p >= 8:
            a0 = r[k, p] * r[k, p] + (r[k, p + 2] * r[k, p + 2] + (r[k, p + 4] * r[k, p + 4] + (
                r[k, p + 6] * r[k, p + 6] + a0)))
            a1 = r[k, p + 1] * r[k, p + 1] + (r[k, p + 3] * r[k, p + 3] + (r[k, p + 5] * r[k, p + 5] + (
                r[k, p + 7] * r[k, p + 7] + a1)))
            p += 8
        while p < m:
            a0 = r[k, p] * r[k, p] + a0
            if p + 1 < m:
                a1 = r[k, p + 1] * r[k, p + 1] + a1
            p += 2
        c = 0.0 + (a0 + a1)
        if np.isfinite(c):
            cost[k] = c
        else:
            cost[k] = np.inf
            for t in range(m):
                r[k, t] = 0.0
    return cost


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


def _jacobian_into(fun, X, r, rows, act, hi, steps, J, G, A):
    """:func:`_jacobian` and :func:`_normal` of the rows ``rows`` written into J, G = J'r, A = J'J in place (no
    per-call Jacobian array, no copies of its rows): a row's frozen columns are never written, so they stay the
    zeros J starts with, as the copied form had them."""
    if X.shape[1] < 2:  # einsum's own order for D = 1 (see _normal)
        J[rows] = _jacobian(fun, X, r, rows, act, hi, steps)
        G[rows], A[rows] = _normal(J[rows], r[rows], True)
        return
    kk, jj = (np.ascontiguousarray(v) for v in np.nonzero(act[rows]))
    if kk.size:
        ii = rows[kk]
        Xp, h = _probes(X, ii, jj, hi, steps)
        rp, cp = _eval(fun, Xp, ii)
        _columns(J, ii, jj, rp, r, ii, h, cp)  # J's rows addressed by the problem row itself
    _normal_rows(J, r, rows, G, A)


@numba.njit(cache=True)
def _normal_rows(J, r, rows, G, A):
    """G[i] = J[i]'r[i], A[i] = J[i]'J[i] for i in ``rows``: :func:`_normal_compiled`'s sums, in its order."""
    D = J.shape[2]
    for i in rows:
        g, a = np.zeros(D), np.zeros((D, D))
        for t in range(J.shape[1]):
            rt = r[i, t]
            for c in range(D):
                jc = J[i, t, c]
                g[c] += jc * rt
                for e in range(c, D):
                    a[c, e] += jc * J[i, t, e]
        for c in range(D):
            G[i, c] = g[c]
            for e in range(D):
                A[i, c, e] = a[c, e] if e >= c else a[e, c]


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
    every row (they change only with its Jacobian).

    The numpy form (:func:`_step_numpy`, kept for D = 1, where its einsums take another summation order) in four
    compiled passes around the two solves and the probe: no copies of J's rows, a few calls instead of ~25 numpy
    ones (each pass does the numpy form's operations in its order: the same bytes, tests/test_lm_fused.py)."""
    if X.shape[1] < 2:
        return _step_numpy(fun, X, r, J, G, A, Dmax, lam, lo, hi, act, live)
    free, d, M, g, Xl, lol, hil = _gather_damped(A, G, X, lo, hi, act, Dmax, lam, live)
    vel = _lin(M, g)
    rh, ch = _eval(fun, _probe(Xl, vel, lol, hil), live)
    acc = _lin(M, _curvature(J, r, live, rh, vel, free))
    return _trial(Xl, vel, acc, d, ch, lol, hil)


def _step_numpy(fun, X, r, J, G, A, Dmax, lam, lo, hi, act, live):
    """:func:`_step` in numpy (the form it was written in)."""
    Jl, rl = J[live], r[live]
    g, A = G[live], A[live]
    Xl, lol, hil = X[live], lo[live], hi[live]
    free, d, M = _damped(A, g, Xl, lol, hil, act[live], Dmax[live], lam)
    Dmax[live] = d
    vel = _solve(M, g, free)
    hv = HV
    rh, ch = _eval(fun, np.clip(Xl + hv * vel, lol, hil), live)
    rvv = (2.0 / hv) * ((rh - rl) / hv - np.einsum("nmj,nj->nm", Jl, vel))
    acc = _solve(M, _normal(Jl, rvv, False)[0], free)
    sq = np.sqrt(d + 1e-300)
    ratio = np.linalg.norm(acc * sq, axis=1) / (np.linalg.norm(vel * sq, axis=1) + 1e-300)
    use_acc = np.isfinite(ch) & (2.0 * ratio <= 0.75)
    return np.clip(Xl + vel + np.where(use_acc[:, None], 0.5 * acc, 0.0), lol, hil)


def _lin(M, rhs) -> np.ndarray:
    """-M^-1 rhs per row (rhs already 0 at the frozen coordinates): :func:`_solve`'s solve."""
    try:
        return -np.linalg.solve(M, rhs[:, :, None])[:, :, 0]
    except np.linalg.LinAlgError:
        return -np.stack([np.linalg.lstsq(M[k], rhs[k], rcond=None)[0] for k in range(M.shape[0])])


@numba.njit(cache=True)
def _gather_damped(A, G, X, lo, hi, act, Dmax, lam, live):
    """:func:`_damped` of the rows ``live`` read in place (no fancy-index copies), Dmax[live] = d afterwards, and the
    right-hand side g = G[live] with 0 at the frozen coordinates (:func:`_solve`'s np.where); plus X, lo, hi of the
    rows (the probe and the trial are clipped into them)."""
    n, D = live.size, X.shape[1]
    Al, gl, Xl, lol, hil = np.empty((n, D, D)), np.empty((n, D)), np.empty((n, D)), np.empty((n, D)), np.empty((n, D))
    al, dl = np.empty((n, D), dtype=np.bool_), np.empty((n, D))
    for q in range(n):
        i = live[q]
        for a in range(D):
            gl[q, a], Xl[q, a], lol[q, a], hil[q, a] = G[i, a], X[i, a], lo[i, a], hi[i, a]
            al[q, a], dl[q, a] = act[i, a], Dmax[i, a]
            for b in range(D):
                Al[q, a, b] = A[i, a, b]
    free, d, M = _damped(Al, gl, Xl, lol, hil, al, dl, lam)
    for q in range(n):
        for a in range(D):
            Dmax[live[q], a] = d[q, a]
            gl[q, a] = gl[q, a] if free[q, a] else 0.0
    return free, d, M, gl, Xl, lol, hil


@numba.njit(cache=True)
def _clip(x, lo, hi):
    """np.clip of one float, NaN and signed zeros as numpy has them (max(x, lo) then min(., hi))."""
    y = x if (x != x or x > lo) else lo
    return y if (y != y or y < hi) else hi


@numba.njit(cache=True)
def _probe(Xl, vel, lol, hil):
    """The geodesic probe points clip(X + HV vel)."""
    out = np.empty_like(Xl)
    for q in range(Xl.shape[0]):
        for a in range(Xl.shape[1]):
            out[q, a] = _clip(Xl[q, a] + HV * vel[q, a], lol[q, a], hil[q, a])
    return out


@numba.njit(cache=True)
def _curvature(J, r, live, rh, vel, free):
    """J'rvv (0 at the frozen coordinates) per live entry: rvv = (2 / HV) ((r(X + HV vel) - r) / HV - J vel), the
    second directional derivative of the residual along vel; J vel summed as np.einsum("nmj,nj->nm") sums a
    contiguous axis (two lanes, blocks of 8 in its order, no FMA), J'rvv as _normal_compiled (in order of m)."""
    n, m, D = live.size, r.shape[1], J.shape[2]
    c = 2.0 / HV
    out = np.zeros((n, D))
    for q in range(n):
        i = live[q]
        for t in range(m):
            a0 = 0.0
            a1 = 0.0
            p = 0
            while D - p >= 8:
                a0 = J[i, t, p] * vel[q, p] + (J[i, t, p + 2] * vel[q, p + 2] + (
                    J[i, t, p + 4] * vel[q, p + 4] + (J[i, t, p + 6] * vel[q, p + 6] + a0)))
                a1 = J[i, t, p + 1] * vel[q, p + 1] + (J[i, t, p + 3] * vel[q, p + 3] + (
                    J[i, t, p + 5] * vel[q, p + 5] + (J[i, t, p + 7] * vel[q, p + 7] + a1)))
                p += 8
            while p < D:
                a0 = J[i, t, p] * vel[q, p] + a0
                if p + 1 < D:
                    a1 = J[i, t, p + 1] * vel[q, p + 1] + a1
                p += 2
            rvv = c * ((rh[q, t] - r[i, t]) / HV - (0.0 + (a0 + a1)))
            for a in range(D):
                out[q, a] += J[i, t, a] * rvv
        for a in range(D):
            out[q, a] = out[q, a] if free[q, a] else 0.0
    return out


@numba.njit(cache=True)
def _norm(x, q):
    """np.linalg.norm(x[q]): the squares summed as numpy's pairwise sum does (8 accumulators from 8 on)."""
    D = x.shape[1]
    if D < 8:
        s = 0.0
        for i in range(D):
            s += x[q, i] * x[q, i]
        return np.sqrt(s)
    r = np.empty(8)
    for i in range(8):
        r[i] = x[q, i] * x[q, i]
    i = 8
    while i < D - (D % 8):
        for j in range(8):
            r[j] += x[q, i + j] * x[q, i + j]
        i += 8
    s = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < D:
        s += x[q, i] * x[q, i]
        i += 1
    return np.sqrt(s)


@numba.njit(cache=True)
def _trial(Xl, vel, acc, d, ch, lol, hil):
    """The trial points clip(X + vel + acc / 2), the acceleration taken where the probe was valid and it is small
    against the velocity (|acc| <= 0.375 |vel| in the metric sqrt(d))."""
    n, D = Xl.shape
    out = np.empty_like(Xl)
    sa, sv = np.empty((n, D)), np.empty((n, D))
    for q in range(n):
        for a in range(D):
            sq = np.sqrt(d[q, a] + 1e-300)
            sa[q, a], sv[q, a] = acc[q, a] * sq, vel[q, a] * sq
    for q in range(n):
        ratio = _norm(sa, q) / (_norm(sv, q) + 1e-300)
        use = np.isfinite(ch[q]) and (2.0 * ratio <= 0.75)
        for a in range(D):
            out[q, a] = _clip(Xl[q, a] + vel[q, a] + (0.5 * acc[q, a] if use else 0.0), lol[q, a], hil[q, a])
    return out


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


@numba.njit(cache=True)
def _live(done, nit, max_iter, need, act):
    """(the rows still going, those of them that need a Jacobian (their flag cleared), the Jacobian's columns)."""
    live = np.flatnonzero(~done & (nit < max_iter))
    jrows = live[need[live]]
    n_free = 0
    for i in jrows:
        need[i] = False
        for c in range(act.shape[1]):
            n_free += act[i, c]
    return live, jrows, n_free


@numba.njit(cache=True)
def _entries(live, k, lam):
    """Each live row k times, with the dampings lam 2^j, j = 0 .. k-1 (its attempts, in order)."""
    rows, lr = np.empty(live.size * k, dtype=live.dtype), np.empty(live.size * k)
    for q in range(live.size):
        f = 1.0
        for j in range(k):
            rows[q * k + j], lr[q * k + j] = live[q], lam[live[q]] * f
            f *= 2.0
    return rows, lr


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
    # a writable contiguous copy: a broadcast (read-only, maybe strided) mask would be another numba signature
    act = np.ones((N, D), dtype=bool) if mask is None else np.array(np.broadcast_to(np.asarray(mask, bool), (N, D)))
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
        live, jrows, n_free = _live(done, nit, int(max_iter), need, act)
        if live.size == 0:
            break
        if jrows.size:
            _jacobian_into(fun, X, r, jrows, act, hi, steps, J, G, A)
            nfev += n_free
        k = _attempts(live.size, int(lanes))
        rows, lam_rows = _entries(live, k, lam)
        Xn = _step(fun, X, r, J, G, A, Dmax, lam_rows, lo, hi, act, rows)
        rn, cn = _eval(fun, Xn, rows)
        nfev += 2 * rows.size
        _accept(live, k, Xn, rn, cn, X, r, cost, lam, need, done, nit, int(max_iter), float(ftol), float(lam_max))
    # r and cost are those of X already (a row's residual is kept from the evaluation that accepted it)
    return LMResult(X, cost, r, nit, done.copy(), nfev)

