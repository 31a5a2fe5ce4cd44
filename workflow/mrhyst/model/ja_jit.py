"""The compiled J-A kernel (numba): one RK4 for every variant, the batch dimension innermost (``ja`` explains the
model and its forms; this is its integration loop).

It lives apart from ``ja`` (the public API: ``simulate_h``, ``prepared`` ...) so that importing the API loads no
numba: the API takes the classic kernel from ``mrhyst.model.aot`` (the ahead-of-time compiled module built from
this file when present, else these JIT kernels) and the anisotropic one from here. ``ja`` re-exports
``_simulate_batch``, ``_block`` and ``_aniso_sums`` lazily (its module ``__getattr__``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mrhyst.model import anh_jit
from mrhyst.model import anhysteretic as anh
from mrhyst.model.anhysteretic import MU0
from mrhyst.model.ja import LANES

# The batch is cut into blocks of LANES parameter sets; every loop over a block's lanes has the constant trip
# count LANES and a branch-free body (selects, no calls), so LLVM vectorises it with no scalar remainder and
# a lane gives the same bytes whatever batch it sits in. The field path, its sweep direction delta and the
# step are shared by the whole batch. A variant enters only through the lane constants (anhysteretic.py)
# and, for the anisotropic one, one more lane loop in the anhysteretic stage.
_HALF = LANES // 2
_RM = anh.NC  # row of the block state holding M
_RB = anh.NC + 1  # row holding the failure flag (0.0 / 1.0)
_NS = anh.NC + 2


@numba.njit(cache=True, error_model="numpy", fastmath={"contract", "reassoc"})
def _aniso_sums(x, beta, zq, wq):
    """Quadrature sums (Z, sum w d, sum w d^2) of the anisotropic anhysteretic over the nodes. reassoc (here
    only) lets LLVM vectorise these reductions over the nodes; the order is fixed at compile time, so a lane
    still gives the same bytes whatever batch it is in."""
    ax, D, emax = anh_jit.aniso_span(x, beta)
    Z = 0.0
    D1 = 0.0
    D2 = 0.0
    for i in range(zq.shape[0]):
        w, d = anh_jit.aniso_node(ax, beta, D, emax, zq[i], wq[i])
        Z += w
        D1 += w * d
        D2 += w * d * d
    return Z, D1, D2


@numba.njit(inline="always", **anh.JIT)
def _mixed(x, beta, t, L, dL, quad):
    """(1 - t) (L, L') + t (<u>, Var u): the mixed anhysteretic per unit Ms (anhysteretic.py)."""
    if t == 0.0:  # isotropic lane (and the padding of a block): no quadrature
        return L, dL
    Z, D1, D2 = _aniso_sums(x, beta, quad[0], quad[1])
    m1 = D1 / Z
    A = math.copysign(1.0 - m1, x)
    dA = D2 / Z - m1 * m1
    Lm = (1.0 - t) * L + t * A
    dLm = (1.0 - t) * dL + t * dA
    return Lm, dLm


@numba.njit(inline="always", **anh.JIT)
def _rhs(Hs, M, cl, delta, physical, quad):
    """(dM/dH, failed) of one lane at (Hs, M): Eqs. 4-10 in the common shape of anhysteretic.py.

    cl: the lane's constants as a tuple of scalars (an array argument here would leave NRT reference
    counting calls in the lane loop when LLVM's vectoriser runs, and the loop would stay scalar)."""
    inv_a, Ms, Ms_a, alpha, c, kk, g1, g2, g4, acg5, t, beta = cl
    x = (Hs + alpha * M) * inv_a  # Eq. (4), H_e / a
    L, dL = anh_jit.lang(x)
    if quad is not None:  # resolved at compile time: only the anisotropic variant has quadrature nodes
        L, dL = _mixed(x, beta, t, L, dL, quad)
    Man = Ms * L  # Eq. (5)
    dMan = Ms_a * dL  # dM_an/dH_e
    diff = (Man - M) * g1  # classic: M_an - M_irr, Eq. (6)
    den = delta * kk - alpha * diff  # Eq. (8) denominator
    guard = physical & (delta * diff <= 0.0)  # Jiles 1992: no irreversible change against the sweep
    zero = guard | (delta * den <= 0.0)
    pole = zero & (not guard)  # pole of Eq. (8): alpha |M_an - M_irr| >= k
    inum = 0.0 if zero else g2 * diff
    den = 1.0 if zero else den
    den2 = g4 - acg5 * dMan  # total derivative: dM_an/dH = M_an' (1 + alpha dM/dH), solved for dM/dH
    bad2 = den2 <= 0.0
    den2 = 1.0 if bad2 else den2
    return (inum + c * dMan * den) / (den * den2), pole | bad2  # Eqs. (9)-(10)


@numba.njit(inline="always", **anh.JIT)
def _rk4(h0, h, M, cl, delta, physical, quad):
    """One classical RK4 step of one lane: (M after the step, failed)."""
    k1, b1 = _rhs(h0, M, cl, delta, physical, quad)
    k2, b2 = _rhs(h0 + 0.5 * h, M + 0.5 * h * k1, cl, delta, physical, quad)
    k3, b3 = _rhs(h0 + 0.5 * h, M + 0.5 * h * k2, cl, delta, physical, quad)
    k4, b4 = _rhs(h0 + h, M + h * k3, cl, delta, physical, quad)
    return M + h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0, b1 | b2 | b3 | b4


@numba.njit(inline="always", **anh.JIT)
def _lane(S, l):
    """The lane's constants as a tuple of scalars."""
    return (S[anh.INV_A * LANES + l], S[anh.MS * LANES + l], S[anh.MS_A * LANES + l], S[anh.ALPHA * LANES + l],
            S[anh.C * LANES + l], S[anh.KK * LANES + l], S[anh.G1 * LANES + l], S[anh.G2 * LANES + l],
            S[anh.G4 * LANES + l], S[anh.ACG5 * LANES + l], S[anh.T * LANES + l], S[anh.BETA * LANES + l])


@numba.njit(_nrt=False, **anh.JIT)
def _block(S, H, substeps, physical, quad, out, i0):
    """Integrate one block of LANES sets along H (state S, flat (_NS, LANES)); B into out[i0 + l, :]."""
    m = H.shape[0]
    for l in range(LANES):
        out[i0 + l, 0] = MU0 * (H[0] + S[_RM * LANES + l]) if S[_RB * LANES + l] == 0.0 else np.nan  # Eq. (11)
    for j in range(m - 1):
        dH = H[j + 1] - H[j]
        if dH != 0.0:
            delta = 1.0 if dH > 0.0 else -1.0  # shared by the whole batch on this interval
            h = dH / substeps
            for s in range(substeps):
                h0 = H[j] + s * h
                for la in range(_HALF):  # the vectorised loop: constant trip count, no branches, no calls
                    lb = la + _HALF  # a second, independent lane group in the same iteration hides latency
                    Ma, fa = _rk4(h0, h, S[_RM * LANES + la], _lane(S, la), delta, physical, quad)
                    Mb, fb = _rk4(h0, h, S[_RM * LANES + lb], _lane(S, lb), delta, physical, quad)
                    fa = fa | (S[_RB * LANES + la] != 0.0) | (not (abs(Ma) <= S[anh.LIM * LANES + la]))
                    fb = fb | (S[_RB * LANES + lb] != 0.0) | (not (abs(Mb) <= S[anh.LIM * LANES + lb]))
                    S[_RB * LANES + la] = 1.0 if fa else 0.0  # NaN fails too (the comparison is False)
                    S[_RB * LANES + lb] = 1.0 if fb else 0.0
                    S[_RM * LANES + la] = 0.0 if fa else Ma  # a failed lane rests at 0: no NaN traffic
                    S[_RM * LANES + lb] = 0.0 if fb else Mb
        nbad = 0
        for l in range(LANES):
            failed = S[_RB * LANES + l] != 0.0
            out[i0 + l, j + 1] = np.nan if failed else MU0 * (H[j + 1] + S[_RM * LANES + l])
            nbad += failed
        if nbad == LANES:  # the whole block failed: the rest is NaN
            for l in range(LANES):
                for i in range(j + 2, m):
                    out[i0 + l, i] = np.nan
            return


@numba.njit(**anh.JIT)
def _simulate_batch(Cm, valid, M0, H, substeps, physical, quad, out):
    """Cm (n, NC) lane constants, valid/M0 (n,), out (nblocks * LANES, m): the sets in blocks of LANES, the
    last block padded with benign constants (anh._BENIGN) flagged failed."""
    n = Cm.shape[0]
    S = np.empty(_NS * LANES)
    for b in range(out.shape[0] // LANES):
        for l in range(LANES):
            i = b * LANES + l
            live = i < n and valid[i]
            for r in range(anh.NC):
                S[r * LANES + l] = Cm[i, r] if i < n else anh._BENIGN[r]
            S[_RB * LANES + l] = 0.0 if live else 1.0
            S[_RM * LANES + l] = M0[i] if live else 0.0
        _block(S, H, substeps, physical, quad, out, b * LANES)


def simulate_classic(Cm, valid, M0, H, substeps, physical, out):
    """``_simulate_batch`` of the variants without quadrature (quad None): the function the ahead-of-time module
    exports (mrhyst.model.aot_build), and its JIT form (a plain call: no kernel of its own)."""
    _simulate_batch(Cm, valid, M0, H, substeps, physical, None, out)
