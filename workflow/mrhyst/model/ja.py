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

Variants (``model=``, see ``anhysteretic.MODELS``): the classic J-A above (default, "ja"),
Jiles-Thoelke-Devine 1992, Venkataraman (as jafit), Szewczyk's mixed
isotropic/anisotropic anhysteretic, and "amplitude" (classic J-A with a, alpha
and k scaled by the path's reversal amplitude). They share the one RK4 loop below; a
variant changes only per-set coefficients of dM/dH, for "anisotropic" the
anhysteretic function, for "amplitude" the classic set handed to the kernel
(anhysteretic.py).

The batched kernel is compiled with numba (a hard dependency: a PSO fit at the
paper's settings is 10^4 model evaluations; the kernel is in ``ja_jit``). The batch
dimension is the innermost loop and is vectorised (issue 15): blocks of LANES
parameter sets, a constant-trip-count lane loop with a branch-free body (selects
for the Langevin series and the physical guard, a bit-level exp instead of libm's),
one sweep direction per interval for the whole batch. ``bench/bench_fit.py``
measures it against a plain compiled scalar J-A.

This module loads no numba: the variants without quadrature run the kernel that
``mrhyst.model.aot.kernels()`` provides (the ahead-of-time compiled module of the
same source when it is built, else the JIT kernel: the same bytes), the
anisotropic variant the JIT kernel (issue 26: a warm fit without numba).
"""

from __future__ import annotations

import math

import numpy as np

from mrhyst.model import anhysteretic as anh
from mrhyst.model import aot
from mrhyst.model.anhysteretic import M_LIMIT, MODELS, MU0, SERIES_BELOW  # noqa: F401  (re-exported)
from mrhyst.model.names import FORMS  # noqa: F401  ("paper", "physical"; re-exported)

PARAM_NAMES = anh.CLASSIC  # ("Ms", "a", "alpha", "c", "k")
DMAN_CHOICES = ("total", "partial")


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
# compiled kernel: one RK4 for every variant, the batch dimension innermost
# --------------------------------------------------------------------------
# The batch is cut into blocks of LANES parameter sets (the compiled loop is in ja_jit.py; the ahead-of-time
# module of its classic form in aot.py): the kernel writes B for a whole number of blocks.
LANES = 16


# --------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------
def _check_form(form: str, dman: str) -> None:
    if form not in FORMS:
        raise ValueError(f"J-A form must be one of {FORMS}, got {form!r}")
    if dman not in DMAN_CHOICES:
        raise ValueError(f"dman must be one of {DMAN_CHOICES}, got {dman!r}")


def simulate_h(params, H, *, form: str, substeps: int, dman: str = "total", M0=0.0,
               model: str = "ja"):
    """B (T) along a field path H (A/m) for one or many parameter sets of one J-A variant.

    ``params`` has shape (p,) or (n, p) with p = len(MODELS[model].names) (classic J-A: (Ms, a, alpha, c, k));
    ``M0`` (A/m) is the magnetisation at H[0] (0 = demagnetised), a scalar or shape (n,). Returns
    ``(B, ok)`` with B of shape (m,) or (n, m) and ok a bool or shape (n,). Failed candidates (outside the
    model's domain, pole of Eq. 8, overflow, NaN) have ``ok = False`` and NaN in B from the failing interval on.
    """
    _check_form(form, dman)
    spec = anh.get_model(model)
    P = np.asarray(params, dtype=np.float64)
    single = P.ndim == 1
    P = np.atleast_2d(P)
    if P.ndim != 2 or P.shape[1] != len(spec.names):
        raise ValueError(f"params for J-A model {model!r} must have {len(spec.names)} columns {spec.names}, "
                         f"got shape {np.shape(params)}")
    Hp = np.ascontiguousarray(np.asarray(H, dtype=np.float64))
    if Hp.ndim != 1 or Hp.size < 1:
        raise ValueError("H must be a non-empty 1-D array")
    if int(substeps) < 1:
        raise ValueError("substeps must be >= 1")
    n = P.shape[0]
    kernel = model
    hook = spec.path_sets
    if hook is not None:  # a classic set per path (e.g. "amplitude": a, alpha, k at its reversal amplitude)
        P, kernel = hook(P, Hp), "ja"
    if kernel in anh.KIND:
        Cm, valid = aot.kernels().lane_constants(anh.KIND[kernel], np.ascontiguousarray(P), dman == "total")
    else:
        Cm, valid = anh.lane_constants(kernel, P, dman == "total")
    quad = (anh.ZQ, anh.WQ) if model == "anisotropic" else None
    B, ok = _integrate(Cm, valid, _start_states(M0, n), Hp, int(substeps), form == "physical", quad)
    if single:
        return B[0], bool(ok[0])
    return B, ok


def _start_states(M0, n: int) -> np.ndarray:
    """M0 (a scalar or broadcastable to (n,)) as the kernel's contiguous (n,) float64 array, always a writable
    copy: a read-only one (a broadcast view) is another argument type, for which numba would compile the whole
    kernel again (~0.5 s, one more cached signature per variant)."""
    M0a = np.asarray(M0, dtype=np.float64)
    return np.full(n, float(M0a)) if M0a.ndim == 0 else np.array(np.broadcast_to(M0a, (n,)), order="C")


def _integrate(Cm, valid, M0a, Hp, substeps: int, physical: bool, quad):
    """(B (n, m), ok (n,)) of the n sets of lane constants Cm along Hp: the one call of the batched kernel."""
    n = Cm.shape[0]
    B = np.empty((-(-n // LANES) * LANES, Hp.size))
    if quad is None:
        aot.kernels().batch(Cm, valid, M0a, Hp, substeps, physical, B)
    else:
        from mrhyst.model import ja_jit

        ja_jit._simulate_batch(Cm, valid, M0a, Hp, substeps, physical, quad, B)
    B = B[:n]
    return B, ~np.isnan(B[:, -1]) & valid


def prepared(current, n_over_le: float, *, form: str, substeps: int, dman: str = "total"):
    """:func:`simulate` of classic J-A sets along one applied-current path, its checks and the path's field
    (H = (N/Le) I, contiguous) done once: returns ``run(P, M0) -> (B (n, m), ok (n,))`` for sets P (n, 5) and
    start magnetisations M0 (scalar or (n,)), the bytes of ``simulate(P, current, n_over_le, ...)`` without its
    per-call checks (a fitting loop calls it thousands of times; tests/test_fastpaths.py compares them)."""
    _check_form(form, dman)
    Hp = np.ascontiguousarray(np.asarray(current, dtype=float) * float(n_over_le), dtype=np.float64)
    if Hp.ndim != 1 or Hp.size < 1:
        raise ValueError("H must be a non-empty 1-D array")
    if int(substeps) < 1:
        raise ValueError("substeps must be >= 1")
    kind, total, physical, steps = anh.KIND["ja"], dman == "total", form == "physical", int(substeps)

    def run(P, M0=0.0):
        P = np.ascontiguousarray(P, dtype=np.float64)
        if P.ndim != 2 or P.shape[1] != 5:
            raise ValueError(f"classic J-A sets must have shape (n, 5), got {P.shape}")
        Cm, valid = aot.kernels().lane_constants(kind, P, total)
        return _integrate(Cm, valid, _start_states(M0, P.shape[0]), Hp, steps, physical, None)

    return run


def simulate(params, current, n_over_le: float, **kw):
    """B (T) along an applied-current path (A), with H = (N/Le) I (Eq. 12)."""
    return simulate_h(params, np.asarray(current, dtype=float) * float(n_over_le), **kw)


def paper_current_path(i_max: float = 2.0, n_up: int = 27) -> np.ndarray:
    """The paper's protocol: n_up equally spaced currents 0 -> i_max, then back to 0.

    27 values up and 27 down sharing the peak: 53 samples (paper, 'Testing').
    """
    up = np.linspace(0.0, i_max, n_up)
    return np.concatenate([up, up[-2::-1]])


def as_param_array(d, model: str = "ja") -> np.ndarray:
    """Parameter array of ``model`` (classic: (5,)) from a mapping with keys MODELS[model].names."""
    names = anh.get_model(model).names
    try:
        return np.array([float(d[name]) for name in names])
    except KeyError as e:
        raise ValueError(f"parameter set lacks {e.args[0]!r}; J-A model {model!r} needs {names}") from None


def as_param_dict(p, model: str = "ja") -> dict:
    return {name: float(v) for name, v in zip(anh.get_model(model).names, p)}


_JIT_NAMES = frozenset({"_simulate_batch", "_block", "_aniso_sums", "simulate_classic"})


def __getattr__(name):
    """The compiled kernels, from ja_jit on first use (importing numba then, not with this module)."""
    if name in _JIT_NAMES:
        from mrhyst.model import ja_jit

        return getattr(ja_jit, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# --------------------------------------------------------------------------
# straightforward scalar reference (pure Python, no numpy in the loop)
# --------------------------------------------------------------------------
def simulate_scalar(params, H, *, form: str, substeps: int, dman: str = "total", M0: float = 0.0):
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
