"""LSM: scipy least_squares (TRF) on the normalised box."""

from __future__ import annotations

import copy

import numpy as np
from scipy.optimize import least_squares

from mrhyst.data.io import InputError
from mrhyst.fit import lockstep
from mrhyst.fit.box import Box
from mrhyst.fit.prefetch import Prefetch
from mrhyst.fit.problem import Problem
from mrhyst.model.ja import LANES
from mrhyst.settings import schema_or


# --------------------------------------------------------------------------------------------
# LSM
# --------------------------------------------------------------------------------------------
def run_lsm(prob: Problem, box: Box, x0=None, *, max_iterations: int | None = None, method: str | None = None,
            ftol: float | None = None, xtol: float | None = None, gtol: float | None = None, diff_step=None,
            fixed: dict | None = None) -> dict:
    """scipy least_squares on the normalised box from x0 (default: the box centre). The settings not given
    (None): config lsm's schema defaults (the callers with a config pass its values).

    ``fixed`` = {coordinate index: physical value} holds coordinates fixed (profiles). Returns x,
    J, J_start, history (J after each TRF iteration), n_iterations, status, message, n_evals
    (every residual evaluation, finite-difference ones included), jac_u (Jacobian of the residuals
    in u at the solution, from scipy).
    """
    s = schema_or("lsm", max_iterations=max_iterations, method=method, ftol=ftol, xtol=xtol, gtol=gtol)
    max_iterations, method, ftol, xtol, gtol = (s[k] for k in ("max_iterations", "method", "ftol", "xtol", "gtol"))
    if method not in ("trf", "dogbox"):
        raise InputError("lsm method must be 'trf' or 'dogbox' (the ones with a per-iteration callback)")
    fixed = fixed or {}
    D = box.dim
    free = np.array([i for i in range(D) if i not in fixed], dtype=int)
    x0 = np.array(box.centre if x0 is None else x0, dtype=float)
    for i, v in fixed.items():
        x0[i] = v
    u0 = np.clip(box.to_u(x0), 0.0, 1.0)
    ufull = u0.copy()
    n0 = prob.n_evals

    def to_x(uf):
        ufull[free] = uf
        x = box.to_x(ufull)
        for i, v in fixed.items():
            x[i] = v
        return x

    def fun(uf):
        return prob.residuals(to_x(uf))

    def rows_x(U):
        full = np.tile(ufull, (len(U), 1))
        full[:, free] = U
        X = box.to_x(full)  # row by row the same bytes (elementwise), one call
        for i, v in fixed.items():
            X[:, i] = v
        return X

    # each residual and its Jacobian's finite-difference points in one batched call (scipy's own points and
    # differences, mrhyst.fit.prefetch: the fit is the same bytes; the joint fits measured 4-5x fewer kernel
    # calls with the points batched, and the prefetch halves what is left)
    batch = getattr(prob, "residual_rows", None)
    lo, hi = np.zeros(free.size), np.ones(free.size)
    pf = None if batch is None else Prefetch(lambda U: batch(rows_x(U)), lo, hi, diff_step, block=LANES)
    r0 = fun(u0[free]) if pf is None else pf.fun(u0[free])
    J0 = float(np.sqrt(np.mean(r0**2)))
    hist: list[float] = []

    def callback(intermediate_result):
        hist.append(float(np.sqrt(2.0 * intermediate_result.cost / prob.nv)))
        if len(hist) >= max_iterations:
            raise StopIteration

    res = least_squares(fun if pf is None else pf.fun, u0[free], bounds=(lo, hi), method=method, ftol=ftol,
                        xtol=xtol, gtol=gtol, diff_step=diff_step, max_nfev=50 * max_iterations * D,
                        callback=callback, jac="2-point" if pf is None else pf.jac)
    if pf is not None:  # a fit reports the evaluations scipy asked for, not the rows prefetched
        prob.n_evals = n0 + pf.evals
    x = to_x(res.x)
    J = float(np.sqrt(2.0 * res.cost / prob.nv))
    if not hist or hist[-1] != J:
        # the solver may stop inside an iteration (termination test on the trial step) before the
        # callback; the accepted point is res.x
        if not hist or J < hist[-1]:
            hist.append(J)
    return {"x": x, "J": J, "J_start": J0, "history": hist, "n_iterations": len(hist),
            "status": int(res.status), "message": str(res.message), "n_evals": prob.n_evals - n0,
            "jac_u": np.asarray(res.jac), "free": free}


def run_lsms(prob: Problem, box: Box, x0s: list, **kw) -> list:
    """[run_lsm(prob, box, x0, **kw) for x0 in x0s] for LSMs that do not depend on one another (one substep count,
    set before): in lockstep (:mod:`mrhyst.fit.lockstep`: their kernel calls batched, the same bytes), each on its
    own copy of the problem, whose evaluation counts are added to ``prob``'s as one after another would."""
    copies = [copy.copy(prob) for _ in x0s]
    runs = lockstep.run_all([lambda p=p, x0=x0: run_lsm(p, box, np.asarray(x0, dtype=float), **kw)
                             for p, x0 in zip(copies, x0s)])
    prob.n_evals += sum(p.n_evals - prob.n_evals for p in copies)
    return runs
