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

The compiled pieces (``lane_constants_compiled``, the branch-free ``vexp``, ``vlog``, ``lang`` and the
anisotropic quadrature's ``aniso_span``, ``aniso_node``) are in ``anh_jit`` (numba), re-exported here lazily: this
module loads no numba (issue 26: a warm fit can run the ahead-of-time compiled kernel, ``mrhyst.model.aot``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

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


# the variants whose lane constants are products and quotients of the parameters only: anh_jit's
# lane_constants_compiled (and the ahead-of-time module) computes them, kind KIND[model]
KIND = {"ja": 0, "jtd1992": 1, "venkataraman": 2}


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


def aniso_reference(x: float, beta: float):
    """(<u>, Var u) by adaptive quadrature (scipy), for the tests."""
    from scipy.integrate import quad

    c0 = abs(x) + abs(beta)
    w = lambda u, p: u**p * math.exp(x * u + beta * u * u - c0)  # noqa: E731
    z = quad(w, -1, 1, args=(0,), epsabs=0, epsrel=1e-13, limit=200)[0]
    m1 = quad(w, -1, 1, args=(1,), epsabs=0, epsrel=1e-13, limit=200)[0] / z
    m2 = quad(w, -1, 1, args=(2,), epsabs=0, epsrel=1e-13, limit=200)[0] / z
    return m1, m2 - m1 * m1


_JIT_NAMES = frozenset({"lane_constants_compiled", "vexp", "vlog", "lang", "aniso_span", "aniso_node", "_f2i", "_i2f"})


def __getattr__(name):
    """The compiled pieces, from anh_jit on first use (importing numba then, not with this module)."""
    if name in _JIT_NAMES:
        from mrhyst.model import anh_jit

        return getattr(anh_jit, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
