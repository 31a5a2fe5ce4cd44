"""Integration accuracy that looks after itself: the RK4 substep count of a fit (issue 17, point 3).

The J-A model is integrated with a fixed-step RK4 (``substeps`` steps per sample interval, ja.py). On a
coarse path the step error can be as large as the fit's residual (measured: the 217 A/m M130-27s loop at
2 substeps, 0.093 T). So a fit does not trust a fixed count: at its start point and again at every
solution it compares B(n) with B(2 n) (the doubled step), and while

    max |B(n) - B(2 n)| > tol,   tol = tol_frac * noise floor of the data  (or tol_abs_T without one)

it raises n (RK4 is 4th order: n' = n (err / tol)^(1/4) x 1.25, at least 2 n) and fits again from where it
stood. ``ja.substeps`` in the config is the floor, ``max_substeps`` the ceiling; the count used, the
tolerance and the error at the end go into the fit JSON.

The noise floor of a loop is estimated from the data alone, by the project's one estimator
(:func:`mrhyst.data.shape.noise_floor`, the diagnosis's too): second differences of B along each monotone
run of H (the sweep between reversals): white noise of sd sigma gives d2 of sd sqrt(6) sigma; a robust
(MAD, then clipped RMS) estimate keeps the occasional kink out. The loop's own curvature adds to d2, so the
estimate is an upper bound on the noise on a coarse or noise-free loop; 0 only when there are too few samples.
"""

from __future__ import annotations

import math

import numpy as np

from mrhyst.data import shape as shp


def noise_floor(H, B, valid, shape: shp.PathShape | None, clip: float) -> float:
    """Robust sigma (T) of B from its second differences along monotone runs of H (0 if < 4 triples or H
    never changes); ``shape``: H's, when known (None: derived here); ``clip``: config ja.noise_clip. Where
    the estimate is 0 (most triples flat), it is taken again without the samples of flat runs (:func:`_moving`)."""
    if shape is None:
        try:
            shape = shp.path_shape(H)
        except ValueError:
            return 0.0
    s = shp.noise_floor(B, shape, valid, clip)
    if s == 0.0:  # most second differences exactly 0: B held at one value over runs of samples (a clip)
        s = shp.noise_floor(B, shape, _moving(B, valid), clip)
    return 0.0 if s is None else s


def _moving(B, valid) -> np.ndarray:
    """``valid`` without the samples of a run at one exact B value (a sensor held at its limit, or a signal below
    one ADC code): such a run shows no noise at all, and where it makes up most of the triples the estimate would
    be 0, the integration tolerance the absolute fallback (measured: a Gd loop clipped at 80 % of its peak, 83 of
    132 samples flat (46 + 37 at the two levels: real-cores rc_082), 68 RK4 substeps instead of 8 and 23 CPU s for
    its diagnosis's materials search)."""
    B = np.asarray(B, dtype=float)
    same = np.zeros(B.size, bool)
    eq = B[1:] == B[:-1]
    same[1:] |= eq
    same[:-1] |= eq
    v = np.ones(B.size, bool) if valid is None else np.asarray(valid, bool).copy()
    return v & ~same


def correlation_factor(pieces, rho_max: float) -> tuple[float, float]:
    """(factor, rho): how much residuals correlated along the path widen a least-squares standard error.

    The Jacobian's stderr, sqrt(diag(s^2 (J'J)^-1)), assumes independent residuals. On a real core the
    residual is mostly model form: smooth along the path, neighbours nearly equal. With AR(1) residuals of
    lag-1 autocorrelation rho the sample carries n (1 - rho) / (1 + rho) independent values, so the stderr
    grows by sqrt((1 + rho) / (1 - rho)); rho is pooled over ``pieces`` (one residual array per loop, lags
    within each), floored at 0 (white or alternating residuals: factor 1) and capped at ``rho_max``.
    """
    num = den = 0.0
    for r in pieces:
        r = np.asarray(r, dtype=float)
        r = r[np.isfinite(r)]
        if r.size < 3:
            continue
        r = r - r.mean()
        num += float(r[1:] @ r[:-1])
        den += float(r @ r)
    rho = min(max(num / den, 0.0), rho_max) if den > 0 else 0.0
    return math.sqrt((1.0 + rho) / (1.0 - rho)), rho


def tolerance(noise_T: float, tol_frac: float, tol_abs_T: float) -> float:
    """The integration error allowed: tol_frac x the noise floor, or tol_abs_T when there is none."""
    return float(tol_frac * noise_T) if noise_T > 0 else float(tol_abs_T)


def step_error(prob, x) -> float:
    """max |B(n) - B(2 n)| over the samples at x (T). inf if only B(n) fails (the coarse step overshoots
    into the pole of Eq. 8: a step error too); prob.fail_cost_T if B(2 n) fails as well."""
    x = np.asarray(x, dtype=float)[None, :]
    B1, ok1 = prob.model(x)
    B2, ok2 = prob.model(x, substeps=2 * prob.substeps)
    if not ok2[0]:
        return float(prob.fail_cost_T)
    if not ok1[0]:
        return math.inf
    return float(np.max(np.abs(B1[0] - B2[0])))


def next_substeps(n: int, err: float, tol: float, n_max: int) -> int:
    """The count that should bring err below tol (4th order, 25 % margin), at least 2 n, at most n_max."""
    want = n * (err / tol) ** 0.25 * 1.25 if tol > 0 and math.isfinite(err) else 2 * n
    return int(min(n_max, max(2 * n, math.ceil(want))))


def settle(prob, x, tol: float, n_max: int, finite_only: bool = False) -> tuple[float, bool]:
    """Raise prob.substeps until the step error at x is within tol (or n_max is reached).

    Returns (error at the final count, whether the count was raised). A point where the fine step fails
    too (the pole of Eq. 8 is real there) is left to the objective's fail cost; so, with ``finite_only``
    (a start point, not a solution), is one where only the coarse step fails: a start next to the pole
    must not set the count of the whole fit (measured: 196 substeps from one such start)."""
    raised = False
    while True:
        err = step_error(prob, x)
        if err <= tol or prob.substeps >= n_max or err == prob.fail_cost_T or (finite_only and math.isinf(err)):
            return err, raised
        prob.substeps = next_substeps(prob.substeps, err, tol, n_max)
        raised = True


def accurate(run, prob, x0, tol: float, n_max: int, max_rounds: int = 6, beaten=None) -> tuple[dict, dict]:
    """``run(x_start) -> result dict with "x"``, repeated until the step error at its solution is within tol.

    The count is made good at x0 first (so the search itself runs on an accurate model), then checked at
    each solution; a raise means the search is run again from that solution. ``beaten(result, step error)``:
    True when a result cannot be the one kept at any count (e.g. its J exceeds another start's by more than its
    own step error): then it is not made accurate. Returns (last result, {"substeps", "integration_tol_T",
    "integration_error_T", "substep_rounds"})."""
    settle(prob, x0, tol, n_max, finite_only=True)
    x = np.asarray(x0, dtype=float)
    rounds = 0
    while True:
        rounds += 1
        res = run(x)
        if beaten is not None:
            err = step_error(prob, res["x"])
            if beaten(res, err):
                break
        err, raised = settle(prob, res["x"], tol, n_max)
        if not raised or rounds >= max_rounds:
            break
        x = np.asarray(res["x"], dtype=float)
    return res, {"substeps": int(prob.substeps), "integration_tol_T": float(tol), "integration_error_T": err,
                 "substep_rounds": rounds}
