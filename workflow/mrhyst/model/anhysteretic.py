"""J-A model variants and the branch-free pieces the SIMD kernel (``ja.simulate_h``) is built from.

Every variant is the one forward model of ``ja`` (Eqs. 4-13: H_e = H + alpha M, RK4 in H, B = mu0 (H + M)).
A variant changes only

* the anhysteretic function M_an(H_e) (``anisotropic``: a mix of the isotropic Langevin and an anisotropic
  anhysteretic), and/or
* the dM/dH expression, which for all four variants has the one shape

      diff   = g1 (M_an - M)
      dM/dH  = [g2 diff / (delta kk - alpha diff) + c M_an'] / (g4 - acg5 M_an')

  with per-parameter-set coefficients (g1, g2, kk, g4, acg5) computed once per call by ``lane_constants``
  (numpy; the simulator calls its compiled twin ``lane_constants_compiled``, same bytes, for every variant
  but the anisotropic one).

So the RK4 loop in ``ja`` is written once; no variant has its own copy.

Branch-free building blocks (``vexp``, ``vlog``, ``lang``) are plain arithmetic and bit operations so that
LLVM vectorises a loop over the batch: numba's ``math.exp`` is a libm call that LLVM cannot vectorise without
Intel SVML, and the PyPI llvmlite wheel is built without SVML support (``llvmlite.binding.targets.has_svml()``
is False here), so an SVML runtime would not help.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from mrhyst.model.names import PARAM_NAMES

MU0 = 4e-7 * math.pi  # Eq. (11)
SERIES_BELOW = 1e-2  # |x| below which the Langevin series is used (ARCHITECTURE sec. 5)
M_LIMIT = 10.0  # |M| > M_LIMIT * Ms counts as a failed integration

# fastmath: only contraction to FMA (no nnan/ninf: the NaN/overflow checks must keep working; no reassoc:
# the order of every sum is the source order, so one lane gives the same bytes whatever the batch around it).
FASTMATH = {"contract"}
JIT = dict(cache=True, error_model="numpy", fastmath=FASTMATH)


# --------------------------------------------------------------------------
# the variants
# --------------------------------------------------------------------------
CLASSIC = PARAM_NAMES  # ("Ms", "a", "alpha", "c", "k"), named in mrhyst.model.names
CLASSIC_BOUNDS = {"Ms": (1e4, 1e7), "a": (1.0, 1e6), "alpha": (-1.0, 1.0), "c": (0.0, 0.999), "k": (1.0, 1e6)}


@dataclass(frozen=True)
class Model:
    """One J-A variant: parameter names (the classic five first), physical bounds, citation. ``path_sets``:
    for a variant that is the classic model with path-dependent parameters, (P, H path) -> the classic (n, 5)
    sets the kernel integrates (None: the kernel reads the variant's own coefficients, lane_constants)."""

    name: str
    names: tuple
    bounds: dict = field(hash=False)
    citation: str
    doc: str
    path_sets: Callable | None = field(default=None, hash=False, compare=False)


MODELS = {
    "ja": Model(
        "ja", CLASSIC, dict(CLASSIC_BOUNDS),
        "D. C. Jiles, D. L. Atherton, J. Magn. Magn. Mater. 61 (1986) 48; in B-I form as Li & Gong, "
        "Front. Mater. 6:111 (2019), Eqs. 1-13",
        "Classic J-A: M_rev = c (M_an - M_irr), dM_irr/dH = (M_an - M_irr)/(delta k - alpha (M_an - M_irr)); "
        "isotropic Langevin anhysteretic."),
    "jtd1992": Model(
        "jtd1992", CLASSIC, dict(CLASSIC_BOUNDS),
        "D. C. Jiles, J. B. Thoelke, M. K. Devine, IEEE Trans. Magn. 28 (1992) 27",
        "Jiles-Thoelke-Devine 1992 weighting: M_rev = c (M_an - M), so dM/dH = [(M_an - M)/(delta k - "
        "alpha (M_an - M)) + c M_an'] / (1 + c [- alpha c M_an' with dman='total'])."),
    "venkataraman": Model(
        "venkataraman", CLASSIC, dict(CLASSIC_BOUNDS),
        "R. Venkataraman, Modeling and adaptive control of magnetostrictive actuators, PhD thesis, Univ. of "
        "Maryland (1999); as implemented in Zubax/jafit src/jafit/ja.py (_dM_dH, model 'venk')",
        "dM/dH = [c M_an'(H_e) + (1 - c) (M_an - M)/(delta k (1 - c) - alpha (M_an - M))] / (1 - alpha c); "
        "the molecular-field feedback is the fixed factor 1/(1 - alpha c), so `dman` does not apply."),
    "anisotropic": Model(
        "anisotropic", CLASSIC + ("K_an", "psi", "t"),
        dict(CLASSIC_BOUNDS, K_an=(0.0, 1e4), psi=(0.0, math.pi / 2), t=(0.0, 1.0)),
        "R. Szewczyk, 'Computational problems connected with Jiles-Atherton model of magnetic hysteresis', "
        "Adv. Intell. Syst. Comput. 267 (2014) 275; A. Ramesh, D. C. Jiles, J. M. Roderick, IEEE Trans. "
        "Magn. 32 (1996) 4234; JAmodel (romanszewczyk/JAmodel, Mah_aniso.m, uniaxial)",
        "Classic dM/dH with the mixed anhysteretic M_an = (1 - t) M_an,iso + t M_an,aniso; the uniaxial "
        "anisotropic part averages the energies at psi - theta and psi + theta: E/(mu0 Ms a) = x cos(theta) "
        "- K_an/(mu0 Ms a) sin^2(psi -+ theta). Only beta = K_an cos(2 psi)/(mu0 Ms a) enters M_an, so K_an "
        "and psi are not separately identifiable from a loop (hold psi fixed when fitting). K_an in J/m^3, "
        "psi in rad."),
    "amplitude": Model(
        "amplitude", CLASSIC + ("n_a", "n_alpha", "n_k"),
        dict(CLASSIC_BOUNDS, n_a=(-1.0, 1.0), n_alpha=(-1.0, 1.0), n_k=(-1.0, 1.0)),
        "J-A parameters that depend on the excitation: G. M. Lozito, F. Riganti Fulginei, A. Salvini, 'On the "
        "generalization capabilities of the ten-parameter Jiles-Atherton model', Math. Probl. Eng. 2015, 715018 "
        "(doi:10.1155/2015/715018); minor loops by scaling J-A parameters with the loop's peak field: M. Hamimid, "
        "S. M. Mimoune, M. Feliachi, Physica B 407 (2012) 2438 (an exponential scaling; cited by its abstract, "
        "not read). The power law in H_m/a here is this project's choice, not either paper's form.",
        "Classic J-A whose a, alpha and k depend on the path's reversal amplitude H_m = max|H| (a symmetric "
        "cyclic loop's peak field): p_eff = p (H_m/a)^n_p for p in (a, alpha, k) (amplitude in units of a, so "
        "no reference field of our own; any fixed reference spans the same family). Rayleigh region: the "
        "pinning (k, the coercivity of a small loop) and the initial susceptibility of the anhysteretic "
        "(Ms/(3a - alpha Ms): a and alpha) change with the amplitude, which one classic set cannot follow. "
        "All n = 0 is the classic model. From ONE loop the exponents are not identifiable (they only rescale "
        "a, alpha, k); they are from loops of different amplitude fitted jointly.",
        path_sets=lambda P, H: amplitude_scaled(P, float(np.max(np.abs(H))) if np.size(H) else 0.0)),
}
MODEL_INDEX = {name: i for i, name in enumerate(MODELS)}


def amplitude_scaled(P: np.ndarray, h_m: float) -> np.ndarray:
    """The classic (n, 5) parameters of the "amplitude" variant's (n, 8) sets on a path with peak |H| h_m."""
    P = np.asarray(P, dtype=float)
    Q = P[:, :5].copy()
    with np.errstate(all="ignore"):
        # ln(H_m / a); a <= 0 gives NaN: the set is flagged invalid downstream. A path that never leaves
        # H = 0 has no reversal amplitude: no scaling there.
        s = np.log(h_m / P[:, 1]) if h_m > 0 else np.zeros(P.shape[0])
        Q[:, 1] = P[:, 1] * np.exp(P[:, 5] * s)
        Q[:, 2] = P[:, 2] * np.exp(P[:, 6] * s)
        Q[:, 4] = P[:, 4] * np.exp(P[:, 7] * s)
    return Q


def get_model(model: str) -> Model:
    try:
        return MODELS[model]
    except (KeyError, TypeError):
        raise ValueError(f"J-A model must be one of {tuple(MODELS)}, got {model!r}") from None


# lane constants: row indices of the (NC, lanes) block handed to the kernel
INV_A, MS, MS_A, ALPHA, C, KK, G1, G2, G4, ACG5, T, BETA, LIM = range(13)
NC = 13
_BENIGN = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 10.0])


def lane_constants(model: str, P: np.ndarray, total: bool):
    """(n, NC) per-set constants of the dM/dH shape above, and the validity mask (n,).

    Invalid sets (outside the model's physical domain, or non-finite) get benign constants and valid = False:
    the kernel flags them as failed and writes NaN.
    """
    Ms, a, alpha, c, k = (P[:, i] for i in range(5))
    with np.errstate(all="ignore"):
        valid = np.all(np.isfinite(P), axis=1) & (Ms > 0) & (a > 0) & (k > 0) & (c >= 0) & (c < 1) & (alpha >= -1)
        n = P.shape[0]
        Cm = np.zeros((n, NC))
        Cm[:, INV_A], Cm[:, MS], Cm[:, MS_A], Cm[:, ALPHA], Cm[:, C] = 1.0 / a, Ms, Ms / a, alpha, c
        Cm[:, LIM] = M_LIMIT * Ms
        tot = 1.0 if total else 0.0
        if model in ("ja", "anisotropic"):  # Eqs. (6)-(10): diff = M_an - M_irr = (M_an - M)/(1 - c)
            Cm[:, G1], Cm[:, G2], Cm[:, KK], Cm[:, G4], Cm[:, ACG5] = 1.0 / (1.0 - c), 1.0 - c, k, 1.0, alpha * c * tot
        elif model == "jtd1992":
            Cm[:, G1], Cm[:, G2], Cm[:, KK], Cm[:, G4], Cm[:, ACG5] = 1.0, 1.0, k, 1.0 + c, alpha * c * tot
        elif model == "venkataraman":
            Cm[:, G1], Cm[:, G2], Cm[:, KK], Cm[:, G4], Cm[:, ACG5] = 1.0, 1.0 - c, k * (1.0 - c), 1.0 - alpha * c, 0.0
            valid &= alpha * c < 1.0
        if model == "anisotropic":
            K_an, psi, t = P[:, 5], P[:, 6], P[:, 7]
            valid &= (K_an >= 0) & (t >= 0) & (t <= 1)
            Cm[:, T] = t
            Cm[:, BETA] = K_an / (MU0 * Ms * a) * np.cos(2.0 * psi)
    Cm[~valid] = _BENIGN
    return Cm, valid


# lane_constants compiled for the variants without the anisotropic anhysteretic (their constants are products
# and quotients of the parameters only): the same operations in the same order, no fastmath (no FMA), so the
# same bytes as the numpy form above, without its ~25 us of numpy overhead per call on a few rows.
KIND = {"ja": 0, "jtd1992": 1, "venkataraman": 2}


@numba.njit(cache=True, error_model="numpy")
def lane_constants_compiled(kind, P, total):
    """(n, NC) constants and validity (n,) of ``lane_constants`` for KIND[model] ``kind``. One element per
    statement (row slices and tuple stores cost seconds of compile time)."""
    n = P.shape[0]
    Cm = np.zeros((n, NC))
    valid = np.zeros(n, dtype=np.bool_)
    tot = 1.0 if total else 0.0
    for i in range(n):
        Ms, a, alpha, c, k = P[i, 0], P[i, 1], P[i, 2], P[i, 3], P[i, 4]
        ok = Ms > 0 and a > 0 and k > 0 and c >= 0 and c < 1 and alpha >= -1
        for j in range(P.shape[1]):
            ok = ok and np.isfinite(P[i, j])
        if kind == 2:
            ok = ok and alpha * c < 1.0
        valid[i] = ok
        if not ok:
            for j in range(NC):
                Cm[i, j] = _BENIGN[j]
            continue
        Cm[i, INV_A] = 1.0 / a
        Cm[i, MS] = Ms
        Cm[i, MS_A] = Ms / a
        Cm[i, ALPHA] = alpha
        Cm[i, C] = c
        Cm[i, LIM] = M_LIMIT * Ms
        if kind == 0:  # T, BETA (and venkataraman's ACG5) stay 0
            Cm[i, G1] = 1.0 / (1.0 - c)
            Cm[i, G2] = 1.0 - c
            Cm[i, KK] = k
            Cm[i, G4] = 1.0
            Cm[i, ACG5] = alpha * c * tot
        elif kind == 1:
            Cm[i, G1] = 1.0
            Cm[i, G2] = 1.0
            Cm[i, KK] = k
            Cm[i, G4] = 1.0 + c
            Cm[i, ACG5] = alpha * c * tot
        else:
            Cm[i, G1] = 1.0
            Cm[i, G2] = 1.0 - c
            Cm[i, KK] = k * (1.0 - c)
            Cm[i, G4] = 1.0 - alpha * c
    return Cm, valid


# --------------------------------------------------------------------------
# branch-free elementary functions (vectorisable: arithmetic, selects and bit operations only)
# --------------------------------------------------------------------------
@intrinsic
def _f2i(typingctx, x):
    """The IEEE bits of a float64 as int64 (an LLVM bitcast: free, and vectorisable)."""
    if isinstance(x, types.Float):
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], ir.IntType(64))
        return types.int64(types.float64), codegen


@intrinsic
def _i2f(typingctx, n):
    """The float64 whose IEEE bits are the int64 n."""
    if isinstance(n, types.Integer):
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], ir.DoubleType())
        return types.float64(types.int64), codegen


_LN2_HI = 6.93147180369123816490e-01  # fdlibm split of ln 2: n * _LN2_HI is exact for |n| < 2^20
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.44269504088896338700e00
_SHIFT = 6755399441055744.0  # 1.5 * 2^52: y + _SHIFT rounds y to an integer held in the low mantissa bits
_MAGIC = 4503599627370496.0  # 2^52
_EXP_COEF = tuple(1.0 / math.factorial(i) for i in range(14))  # Taylor to r^13 on |r| <= ln2/2: < 1e-17


@numba.njit(inline="always", **JIT)
def vexp(y):
    """exp(y) to ~1 ulp, y clamped to [-700, 700]; exp(r) by degree-13 Horner after y = n ln2 + r."""
    y = min(max(y, -700.0), 700.0)
    kf = y * _INV_LN2 + _SHIFT
    nf = kf - _SHIFT
    r = (y - nf * _LN2_HI) - nf * _LN2_LO
    p = _EXP_COEF[13]
    p = p * r + _EXP_COEF[12]
    p = p * r + _EXP_COEF[11]
    p = p * r + _EXP_COEF[10]
    p = p * r + _EXP_COEF[9]
    p = p * r + _EXP_COEF[8]
    p = p * r + _EXP_COEF[7]
    p = p * r + _EXP_COEF[6]
    p = p * r + _EXP_COEF[5]
    p = p * r + _EXP_COEF[4]
    p = p * r + _EXP_COEF[3]
    p = p * r + _EXP_COEF[2]
    p = p * r + 1.0
    p = p * r + 1.0
    n = _f2i(kf) - _f2i(_SHIFT)
    return p * _i2f((n + 1023) << 52)


_MANT = (1 << 52) - 1
_ONE_BITS = 1023 << 52
_SQRT2 = math.sqrt(2.0)


@numba.njit(inline="always", **JIT)
def vlog(q):
    """log(q) for a positive normal q: q = 2^e m, m in [sqrt(1/2), sqrt(2)), log m = 2 atanh((m-1)/(m+1))."""
    bits = _f2i(q)
    m = _i2f((bits & _MANT) | _ONE_BITS)  # in [1, 2)
    ef = _i2f((bits >> 52) | _f2i(_MAGIC)) - _MAGIC - 1023.0  # exponent as an exact double
    big = m > _SQRT2
    m = 0.5 * m if big else m
    ef = ef + 1.0 if big else ef
    s = (m - 1.0) / (m + 1.0)
    s2 = s * s
    p = 1.0 / 23.0
    p = p * s2 + 1.0 / 21.0
    p = p * s2 + 1.0 / 19.0
    p = p * s2 + 1.0 / 17.0
    p = p * s2 + 1.0 / 15.0
    p = p * s2 + 1.0 / 13.0
    p = p * s2 + 1.0 / 11.0
    p = p * s2 + 1.0 / 9.0
    p = p * s2 + 1.0 / 7.0
    p = p * s2 + 1.0 / 5.0
    p = p * s2 + 1.0 / 3.0
    p = p * s2 + 1.0
    return ef * _LN2_HI + (2.0 * s * p + ef * _LN2_LO)


_THIRD, _C45, _C945, _C15, _C189 = 1.0 / 3.0, 1.0 / 45.0, 2.0 / 945.0, 1.0 / 15.0, 2.0 / 189.0


@numba.njit(inline="always", **JIT)
def lang(x):
    """(L(x), L'(x)) of Eq. (5), branch-free: both the series (|x| < SERIES_BELOW) and the closed form
    with t = exp(-2|x|) (coth|x| = (1+t)/(1-t), 1/sinh^2 = 4t/(1-t)^2, no overflow) are computed and
    the right one selected; one exp and one division."""
    ax = abs(x)
    t = vexp(-2.0 * ax)
    omt = 1.0 - t
    q = 1.0 / (x * omt)
    inv_x = q * omt
    r = q * x  # 1/(1 - t)
    lb = math.copysign((1.0 + t) * r, x) - inv_x
    dlb = inv_x * inv_x - 4.0 * t * r * r
    x2 = x * x
    ls = x * (_THIRD - x2 * (_C45 - x2 * _C945))  # x/3 - x^3/45 + 2x^5/945, no division
    dls = _THIRD - x2 * (_C15 - x2 * _C189)  # 1/3 - x^2/15 + 2x^4/189
    small = ax < SERIES_BELOW
    return (ls if small else lb), (dls if small else dlb)


# --------------------------------------------------------------------------
# anisotropic anhysteretic (Ramesh-Jiles uniaxial, as JAmodel's Mah_aniso.m), as moments in u = cos(theta)
# --------------------------------------------------------------------------
# With u = cos(theta) the averaged energy is x u + beta u^2 + const (beta = K_an cos(2 psi)/(mu0 Ms a)), so
# M_an,aniso/Ms = <u> and dM_an,aniso/dH_e = (Ms/a) Var(u) under the weight exp(x u + beta u^2) on [-1, 1]
# (beta = 0 gives L(x), L'(x)). In d = 1 - sign(x) u in [0, 2] the exponent is e(d) = -|x| d + beta (u^2 - 1),
# e(0) = 0. It is integrated by Gauss-Legendre with NQ nodes on [0, D], where D < 2 only where the weight
# beyond D is below e^-E (E = 36: ~2e-16): beta >= 0 (e convex, e(2) = -2|x|): D = min(2, E/|x|);
# beta < 0 (e concave) with the maximum at d = 0: e(D) = -E. The exponent is shifted to its maximum (no
# overflow). Accuracy against adaptive quadrature (tests/test_variants.py): ~1e-9 relative for |beta| <= 3,
# degrading to ~1e-4 where beta >> 1 squeezes the weight into the ends of [-1, 1].
NQ = 40  # <= 2e-8 relative to adaptive quadrature for |beta| <= 30 (32 nodes: 1.2e-7)
_E = 36.0
_zq, _wq = np.polynomial.legendre.leggauss(NQ)
ZQ = 0.5 * (_zq + 1.0)
WQ = 0.5 * _wq


@numba.njit(inline="always", **JIT)
def aniso_span(x, beta):
    """(|x|, D, exponent maximum) of one lane: the integration span in d and the shift."""
    ax = abs(x)
    nb = -beta
    r = ax - 2.0 * nb  # decay rate at d = 0 when beta < 0
    Dneg = (math.sqrt(r * r + 4.0 * nb * _E) - r) / (2.0 * nb) if r >= 0.0 else 2.0
    D = min(2.0, _E / ax) if beta >= 0.0 else min(2.0, Dneg)
    ds = min(max(1.0 - ax / (2.0 * nb), 0.0), D) if beta < 0.0 else 0.0  # the maximum of e (beta < 0)
    us = 1.0 - ds
    emax = max(0.0, -ax * ds + beta * (us * us - 1.0))
    return ax, D, emax


@numba.njit(inline="always", **JIT)
def aniso_node(ax, beta, D, emax, z, wq):
    """Weight and d at one quadrature node."""
    d = D * z
    u = 1.0 - d
    return wq * vexp(-ax * d + beta * (u * u - 1.0) - emax), d


def aniso_reference(x: float, beta: float):
    """(<u>, Var u) by adaptive quadrature (scipy), for the tests."""
    from scipy.integrate import quad

    c0 = abs(x) + abs(beta)
    w = lambda u, p: u**p * math.exp(x * u + beta * u * u - c0)  # noqa: E731
    z = quad(w, -1, 1, args=(0,), epsabs=0, epsrel=1e-13, limit=200)[0]
    m1 = quad(w, -1, 1, args=(1,), epsabs=0, epsrel=1e-13, limit=200)[0] / z
    m2 = quad(w, -1, 1, args=(2,), epsabs=0, epsrel=1e-13, limit=200)[0] / z
    return m1, m2 - m1 * m1
