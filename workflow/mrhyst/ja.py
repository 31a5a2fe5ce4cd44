"""Jiles-Atherton model in B-I form (Li & Gong 2019, Eqs. 1-13).

Parameters are always ordered ``(Ms, a, alpha, c, k)`` (see ``PARAM_NAMES``).

The model is integrated along a piecewise-linear current path with a fixed-step
classical RK4 (the paper's solver, "fourth-order Runge-Kutta with fixed step").
Because J-A is rate independent we integrate in H directly: each interval
between two consecutive applied currents is split into ``substeps`` equal
RK4 steps, and the sweep direction delta (Eq. 8) is constant on an interval
and taken from the sign of the current change, so the discontinuity of delta
at a turning point always falls on an interval boundary.

Two forms sit behind one switch:

``paper``
    Eq. (10) (equivalently Eqs. 8-9 with M_irr = (M - c M_an)/(1 - c)) exactly
    as printed: no guard after a field reversal, so dM/dH can be negative
    there (the well-known defect of the 1986 form).
``physical``
    Jiles, Thoelke & Devine (1992): the irreversible slope dM_irr/dH is set to
    0 where (M_an - M_irr) has the wrong sign for the sweep direction
    (delta * (M_an - M_irr) <= 0), so dM/dH >= 0 everywhere.

The paper writes ``c dM_an/dt`` in Eq. (13) without saying whether the
molecular-field feedback (H_e = H + alpha M, Eq. 4) is differentiated too.
``dman="total"`` (default, config ``ja.dman``) takes the total derivative
dM_an/dH = M_an'(H_e) (1 + alpha dM/dH) and solves the resulting linear
equation for dM/dH exactly; ``dman="partial"`` uses M_an'(H_e) alone.

A candidate whose integration fails (the denominator of Eq. 8 reaches 0, i.e.
alpha |M_an - M_irr| >= k on a branch where the pole is reachable; overflow;
|M| beyond 10 Ms) is flagged ``ok = False`` and its B is set to NaN in the
returned array; the objective layer turns that into a large finite cost.

The batched kernel is compiled with numba (a hard dependency: a PSO fit at the
paper's settings is 10^4 model evaluations, which numpy over a 100-particle
batch cannot do in well under a second; see ``bench/``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

MU0 = 4e-7 * math.pi  # Eq. (11): vacuum permeability, N/A^2
PARAM_NAMES = ("Ms", "a", "alpha", "c", "k")
FORMS = ("paper", "physical")
DMAN_CHOICES = ("total", "partial")
SERIES_BELOW = 1e-2  # |x| below which the Langevin series is used (ARCHITECTURE sec. 5)
M_LIMIT = 10.0  # |M| > M_LIMIT * Ms counts as a failed integration


# --------------------------------------------------------------------------
# Langevin function, Eq. (5)
# --------------------------------------------------------------------------
def langevin(x):
    """L(x) = coth(x) - 1/x, with its series x/3 - x^3/45 + 2x^5/945 near 0."""
    x = np.asarray(x, dtype=float)
    out = np.empty_like(x)
    small = np.abs(x) < SERIES_BELOW
    xs = x[small]
    out[small] = xs / 3.0 - xs**3 / 45.0 + 2.0 * xs**5 / 945.0
    xl = x[~small]
    out[~small] = 1.0 / np.tanh(xl) - 1.0 / xl
    return out if out.ndim else float(out)


def dlangevin(x):
    """L'(x) = 1/x^2 - 1/sinh(x)^2, with its series 1/3 - x^2/15 + 2x^4/189 near 0."""
    x = np.asarray(x, dtype=float)
    out = np.empty_like(x)
    small = np.abs(x) < SERIES_BELOW
    xs = x[small]
    out[small] = 1.0 / 3.0 - xs**2 / 15.0 + 2.0 * xs**4 / 189.0
    xl = x[~small]
    with np.errstate(over="ignore"):
        sh = np.sinh(xl)
    out[~small] = 1.0 / xl**2 - 1.0 / sh**2
    return out if out.ndim else float(out)


# --------------------------------------------------------------------------
# compiled kernel
# --------------------------------------------------------------------------
@numba.njit(cache=True, fastmath=False)
def _lang(x):
    """(L(x), L'(x)); one exp per call: with t = exp(-2|x|), coth|x| = (1 + t)/(1 - t) and
    1/sinh(x)^2 = 4t/(1 - t)^2 (no overflow for large |x|: t underflows to 0)."""
    if abs(x) < SERIES_BELOW:
        x2 = x * x
        return x / 3.0 - x * x2 / 45.0 + 2.0 * x * x2 * x2 / 945.0, 1.0 / 3.0 - x2 / 15.0 + 2.0 * x2 * x2 / 189.0
    t = math.exp(-2.0 * abs(x))
    omt = 1.0 - t
    coth = math.copysign((1.0 + t) / omt, x)
    return coth - 1.0 / x, 1.0 / (x * x) - 4.0 * t / (omt * omt)


@numba.njit(cache=True, fastmath=False)
def _rhs(H, M, Ms, a, alpha, c, k, delta, physical, total):
    """dM/dH of Eq. (10); returns (slope, ok)."""
    He = H + alpha * M  # Eq. (4)
    L, dL = _lang(He / a)
    Man = Ms * L  # Eq. (5)
    dMan = Ms / a * dL  # dM_an/dH_e
    diff = (Man - M) / (1.0 - c)  # = M_an - M_irr, from Eq. (6)
    ok = True
    if physical and delta * diff <= 0.0:
        irr = 0.0  # Jiles 1992: no irreversible change against the sweep
    else:
        den = k * delta - alpha * diff  # Eq. (8) denominator
        if delta * den <= 0.0:
            ok = False  # pole of Eq. (8) reached: alpha |M_an - M_irr| >= k
            irr = 0.0
        else:
            irr = (1.0 - c) * diff / den
    num = irr + c * dMan  # Eq. (9)
    if total:
        den2 = 1.0 - alpha * c * dMan  # dM_an/dH = M_an' (1 + alpha dM/dH)
        if den2 <= 0.0:
            ok = False
            den2 = 1.0
        num = num / den2
    return num, ok


@numba.njit(cache=True, fastmath=False)
def _simulate_one(p, H, substeps, physical, total, M0, out):
    """Integrate one parameter set along H; write B into out; return ok."""
    Ms = p[0]
    a = p[1]
    alpha = p[2]
    c = p[3]
    k = p[4]
    if not (Ms > 0.0 and a > 0.0 and k > 0.0 and c >= 0.0 and c < 1.0 and alpha >= -1.0):
        for j in range(H.shape[0]):
            out[j] = np.nan
        return False
    M = M0
    out[0] = MU0 * (H[0] + M)  # Eq. (11)
    lim = M_LIMIT * Ms
    for j in range(H.shape[0] - 1):
        dH = H[j + 1] - H[j]
        if dH == 0.0:
            out[j + 1] = MU0 * (H[j + 1] + M)
            continue
        delta = 1.0 if dH > 0.0 else -1.0
        h = dH / substeps
        for s in range(substeps):
            h0 = H[j] + s * h
            k1, ok1 = _rhs(h0, M, Ms, a, alpha, c, k, delta, physical, total)
            k2, ok2 = _rhs(h0 + 0.5 * h, M + 0.5 * h * k1, Ms, a, alpha, c, k, delta, physical, total)
            k3, ok3 = _rhs(h0 + 0.5 * h, M + 0.5 * h * k2, Ms, a, alpha, c, k, delta, physical, total)
            k4, ok4 = _rhs(h0 + h, M + h * k3, Ms, a, alpha, c, k, delta, physical, total)
            M = M + h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
            if not (ok1 and ok2 and ok3 and ok4) or not (abs(M) <= lim):
                for i in range(j + 1, H.shape[0]):
                    out[i] = np.nan
                return False
        out[j + 1] = MU0 * (H[j + 1] + M)
    return True


@numba.njit(cache=True, fastmath=False)
def _simulate_batch(P, H, substeps, physical, total, M0, B, ok):
    for i in range(P.shape[0]):
        ok[i] = _simulate_one(P[i], H, substeps, physical, total, M0[i], B[i])


# --------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------
def _check_form(form: str, dman: str) -> None:
    if form not in FORMS:
        raise ValueError(f"J-A form must be one of {FORMS}, got {form!r}")
    if dman not in DMAN_CHOICES:
        raise ValueError(f"dman must be one of {DMAN_CHOICES}, got {dman!r}")


def simulate_h(params, H, *, form: str = "paper", substeps: int = 8, dman: str = "total", M0=0.0):
    """B (T) along a field path H (A/m) for one or many parameter sets.

    ``params`` has shape (5,) or (n, 5); ``M0`` (A/m) is the magnetisation at
    H[0] (0 = demagnetised), a scalar or shape (n,). Returns ``(B, ok)`` with
    B of shape (m,) or (n, m) and ok a bool or shape (n,). Failed candidates
    have ``ok = False`` and NaN in B from the failing interval on.
    """
    _check_form(form, dman)
    P = np.asarray(params, dtype=np.float64)
    single = P.ndim == 1
    P = np.ascontiguousarray(np.atleast_2d(P))
    if P.shape[1] != 5:
        raise ValueError(f"params must have 5 columns {PARAM_NAMES}, got shape {P.shape}")
    Hp = np.ascontiguousarray(np.asarray(H, dtype=np.float64))
    if Hp.ndim != 1 or Hp.size < 1:
        raise ValueError("H must be a non-empty 1-D array")
    if int(substeps) < 1:
        raise ValueError("substeps must be >= 1")
    n = P.shape[0]
    M0a = np.ascontiguousarray(np.broadcast_to(np.asarray(M0, dtype=np.float64), (n,)).copy())
    B = np.empty((n, Hp.size))
    ok = np.empty(n, dtype=np.bool_)
    _simulate_batch(P, Hp, int(substeps), form == "physical", dman == "total", M0a, B, ok)
    if single:
        return B[0], bool(ok[0])
    return B, ok


def simulate(params, current, n_over_le: float, **kw):
    """B (T) along an applied-current path (A), with H = (N/Le) I (Eq. 12)."""
    return simulate_h(params, np.asarray(current, dtype=float) * float(n_over_le), **kw)


def paper_current_path(i_max: float = 2.0, n_up: int = 27) -> np.ndarray:
    """The paper's protocol: n_up equally spaced currents 0 -> i_max, then back to 0.

    27 values up and 27 down sharing the peak: 53 samples (paper, 'Testing').
    """
    up = np.linspace(0.0, i_max, n_up)
    return np.concatenate([up, up[-2::-1]])


def as_param_array(d) -> np.ndarray:
    """(5,) array from a mapping with keys PARAM_NAMES."""
    try:
        return np.array([float(d[name]) for name in PARAM_NAMES])
    except KeyError as e:
        raise ValueError(f"parameter set lacks {e.args[0]!r}; needs {PARAM_NAMES}") from None


def as_param_dict(p) -> dict:
    return {name: float(v) for name, v in zip(PARAM_NAMES, p)}


# --------------------------------------------------------------------------
# straightforward scalar reference (pure Python, no numpy in the loop)
# --------------------------------------------------------------------------
def simulate_scalar(params, H, *, form: str = "paper", substeps: int = 8, dman: str = "total", M0: float = 0.0):
    """Plain-Python J-A integration, one parameter set; the bench's baseline.

    Written independently of the compiled kernel (same equations), so the
    tests can check one against the other.
    """
    _check_form(form, dman)
    Ms, a, alpha, c, k = (float(v) for v in params)
    physical = form == "physical"
    total = dman == "total"

    def rhs(h, m, delta):
        x = (h + alpha * m) / a
        if abs(x) < SERIES_BELOW:
            L = x / 3 - x**3 / 45 + 2 * x**5 / 945
            dL = 1 / 3 - x**2 / 15 + 2 * x**4 / 189
        else:
            L = 1 / math.tanh(x) - 1 / x
            dL = 1 / x**2 - (1 / math.sinh(x) ** 2 if abs(x) < 350 else 0.0)
        man = Ms * L
        dman_ = Ms / a * dL
        diff = (man - m) / (1 - c)
        if physical and delta * diff <= 0:
            irr = 0.0
        else:
            den = k * delta - alpha * diff
            if delta * den <= 0:
                raise FloatingPointError("Eq. (8) denominator reached 0")
            irr = (1 - c) * diff / den
        num = irr + c * dman_
        if total:
            num /= 1 - alpha * c * dman_
        return num

    Hs = [float(h) for h in H]
    M = float(M0)
    out = [MU0 * (Hs[0] + M)]
    for j in range(len(Hs) - 1):
        dH = Hs[j + 1] - Hs[j]
        if dH != 0:
            delta = 1.0 if dH > 0 else -1.0
            h = dH / substeps
            for s in range(substeps):
                h0 = Hs[j] + s * h
                k1 = rhs(h0, M, delta)
                k2 = rhs(h0 + h / 2, M + h / 2 * k1, delta)
                k3 = rhs(h0 + h / 2, M + h / 2 * k2, delta)
                k4 = rhs(h0 + h, M + h * k3, delta)
                M += h * (k1 + 2 * k2 + 2 * k3 + k4) / 6
        out.append(MU0 * (Hs[j + 1] + M))
    return out
