"""The compiled pieces of ``anhysteretic`` (numba): the lane constants' compiled twin and the branch-free
elementary functions and anisotropic quadrature nodes the SIMD kernel (``ja_jit``) is built from.

They live apart from ``anhysteretic`` (the variants, their bounds and the numpy lane constants) so that importing
the model's public API loads no numba: a warm `mrhyst fit` can take its kernels from the ahead-of-time compiled
module instead (``mrhyst.model.aot``, issue 26). ``anhysteretic`` re-exports every name here lazily (its module
``__getattr__``), so ``anh.vexp``, ``anh.lane_constants_compiled`` ... work as before.

Branch-free building blocks (``vexp``, ``vlog``, ``lang``) are plain arithmetic and bit operations so that
LLVM vectorises a loop over the batch: numba's ``math.exp`` is a libm call that LLVM cannot vectorise without
Intel SVML, and the PyPI llvmlite wheel is built without SVML support (``llvmlite.binding.targets.has_svml()``
is False here), so an SVML runtime would not help.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from mrhyst.model.anhysteretic import (
    _BENIGN,
    _E,
    ACG5,
    ALPHA,
    G1,
    G2,
    G4,
    INV_A,
    JIT,
    KK,
    LIM,
    M_LIMIT,
    MS,
    MS_A,
    NC,
    SERIES_BELOW,
    C,
)


# lane_constants compiled for the variants without the anisotropic anhysteretic (their constants are products
# and quotients of the parameters only): the same operations in the same order, no fastmath (no FMA), so the
# same bytes as the numpy form (anhysteretic.lane_constants), without its ~25 us of numpy overhead per call on
# a few rows.
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

# the anisotropic anhysteretic's span and nodes (anhysteretic.py explains the quadrature)
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

