"""The flexible material base of the layered diagnosis (issue 23): a Preisach model with free, non-negative,
smoothness-regularised weights, and each measurement effect's increment on top of it.

**The base.** Rectangular hysterons on a triangle grid of switching fields (alpha up >= beta down) at the
midpoints of ``2 G`` equal steps of [-Hmax, Hmax]; the diagonal alpha = beta hysterons are reversible steps.
B = mu0 H + chi H + sum_h w_h s_h(t) with w_h >= 0 and chi >= 0; the weights of a hysteron and of its mirror
(-beta, -alpha) are one parameter. Hence, for any weights:

* B is **odd**: the path -H from the mirrored start state gives -B (no offset on a symmetric loop);
* B depends only on the H history (no drift, no lag: a hysteron state changes only when H crosses it);
* B is non-decreasing in H along every monotone branch (non-negative weights): no clip-like kink is forced,
  but any rate-independent, monotone, congruent loop shape is reachable (Mayergoyz 1991: the Preisach
  model is exactly the class with wiping-out and congruency).

The weights are a linear non-negative least-squares problem ([A; sqrt(lam) D] w = [B; 0], scipy nnls), with
D the first differences of the weights across the grid; lam is chosen by interleaved K-fold cross-validation
of the base alone, the effective degrees of freedom (BIC) are the trace of the hat matrix on the active set.
Start states: demagnetised (the mirror pairs at +-1), or left by an excursion to -Hmax / +Hmax (all -1 / +1:
a remanent start is material history here, not a fault); a third-party loop runs its conditioning prefix.

**Increments** (the measurement layer), each fitted on the base with the same lam: ``hall_offset`` (a column
of ones, either sign), ``thermal_drift`` (a column of time), ``eddy_lag`` (the base's columns through the
registry's eddy filter, the lag by a grid and a golden-section refinement), ``sensor_saturation`` (samples at
the flat extreme |B| censored: the base fitted to the rest, clip(B) compared there; or samples flagged at a
declared output limit). Everything here fits; :mod:`.layered` decides.
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import nnls

from mrhyst.diagnose.nnlsgram import nnls_gram
from mrhyst.diagnose.sweep import Sweep, folds
from mrhyst.model import effects as fx

MU0 = 4e-7 * math.pi
TIE_REL = 1e-9  # RSS equal to this relative difference: the same fit (rounding), not a better one
STARTS = ("demagnetised", "negative", "positive")


def grid_levels(H, B, G: int, db_share: float) -> np.ndarray:
    """2G switching fields, odd-symmetric: G of the midpoints between the data's distinct |H| levels (never on a
    stepped sweep's level), chosen at equal steps of a weight that is ``db_share`` the loop's |dB| across each
    midpoint (dense where the loop is steep: a square loop's coercive field) and the rest uniform in |H|
    (``layers.grid_db_share``: 0.5 left the Hiperco 50 loop's switching fields 3-4 A/m apart where B moves by
    0.08 T per A/m, 38 mT of misfit; 0.75 gives 29 mT, and the M130-27s 217 A/m loop 8.9 -> 7.4 mT, the
    ferrite's 40 A/m loop 2.2 -> 1.0 mT, at the same cost)."""
    u = np.unique(np.round(np.abs(np.asarray(H, dtype=float)), 12))
    mids = 0.5 * (u[1:] + u[:-1]) if u.size > 1 else np.array([max(float(u[0]), 1.0) / 2.0])
    lo, hi = np.minimum(np.abs(H[:-1]), np.abs(H[1:])), np.maximum(np.abs(H[:-1]), np.abs(H[1:]))
    dB = np.abs(np.diff(B))
    w = np.array([float(np.sum(dB[(lo < m) & (hi > m)])) for m in mids])
    span = np.diff(np.concatenate([[0.0], u]))[1:] if u.size > 1 else np.ones(1)
    w = db_share * w / max(w.sum(), 1e-300) + (1.0 - db_share) * span / max(span.sum(), 1e-300)
    c = np.cumsum(w) - 0.5 * w
    pick = np.unique([int(np.argmin(np.abs(c - q))) for q in (np.arange(G) + 0.5) / G])
    if pick.size < min(G, mids.size):  # quantiles that fell on one midpoint: the heaviest others fill the grid
        rest = [j for j in np.argsort(-w, kind="stable") if j not in set(pick.tolist())]
        pick = np.sort(np.r_[pick, rest[: min(G, mids.size) - pick.size]]).astype(int)
    m = mids[pick]
    return np.concatenate([-m[::-1], m])


def hysterons(G: int):
    """(i_alpha, i_beta) of every hysteron (alpha >= beta) and the index of each one's mirror."""
    L = 2 * G
    pairs = [(i, j) for i in range(L) for j in range(i + 1)]
    idx = {p: k for k, p in enumerate(pairs)}
    mirror = np.array([idx[(L - 1 - j, L - 1 - i)] for i, j in pairs])
    return np.array(pairs), mirror


def start_states(a, b, start: str) -> np.ndarray:
    """Each hysteron's state (up field a, down field b) before the path: demagnetised (-sign(a + b): a hysteron
    switched down if its centre is positive, 0 on the anti-diagonal), or all -1 / +1."""
    if start == "demagnetised":
        return -np.sign(a + b)
    return np.full(a.size, -1.0 if start == "negative" else 1.0)


@numba.njit(cache=True)
def _cell_sums(H, a, b, s0, cell, ncell):
    """(cells, samples): the sum of the states of each cell's hysterons along H (up where H >= a, else down
    where H <= b). The states are -1, 0 or +1, so the sums are exact in any order: the bytes of summing the
    (samples, hysterons) state array cell by cell (numpy did that in ~10x the time and 2 M floats per call)."""
    out = np.zeros((ncell, H.size))
    for i in range(a.size):
        s, ai, bi, c = s0[i], a[i], b[i], cell[i]
        for k in range(H.size):
            h = H[k]
            if h >= ai:
                s = 1.0
            elif h <= bi:
                s = -1.0
            out[c, k] += s
    return out


def cell_states(H, lv, start: str, F: int) -> np.ndarray:
    """Mean state of each cell of the coarse triangle grid (samples, hysterons of :func:`hysterons`): a cell is
    F x F hysterons with switching fields spread between the coarse levels' neighbours (a constant density in
    the cell, so that B moves smoothly between the coarse levels instead of in steps)."""
    L = lv.size
    x = (np.arange(F * L) + 0.5) / F - 0.5  # sub-levels in units of the coarse index
    lf = np.interp(x, np.arange(L), lv)
    lo, hi = x < 0, x > L - 1
    lf[lo] = lv[0] + x[lo] * (lv[1] - lv[0])
    lf[hi] = lv[-1] + (x[hi] - (L - 1)) * (lv[-1] - lv[-2])
    i, j = np.tril_indices(F * L)
    cell = (i // F) * (i // F + 1) // 2 + j // F  # the coarse pair's index in hysterons() order
    a, b = lf[i], lf[j]
    ncell = L * (L + 1) // 2
    sums = _cell_sums(np.ascontiguousarray(H, dtype=float), a, b, start_states(a, b, start), cell, ncell)
    return sums.T / np.bincount(cell, minlength=ncell)


@functools.lru_cache(maxsize=8)
def structure(G: int) -> tuple:
    """(pairs, P, D) of a grid of G fields per sign, the same for every sweep, start state and H offset: the
    hysterons (:func:`hysterons`), P (full weights = P @ one weight per mirror pair) and the smoothness penalty on
    the pair weights and chi (first differences between neighbours along alpha and beta). Only |D w| enters (the
    penalty and the edf): D is held as its R factor, the same norm for every w with one row per column instead of one
    per neighbour pair (3.7x fewer NNLS rows at 16 fields). Cached: read-only."""
    pairs, mirror = hysterons(G)
    keep = np.flatnonzero(np.arange(mirror.size) <= mirror)  # one column per mirror pair
    P = np.zeros((mirror.size, keep.size))
    P[keep, np.arange(keep.size)] = 1.0
    P[mirror[keep], np.arange(keep.size)] = 1.0
    L = 2 * G
    pos = {tuple(p): k for k, p in enumerate(pairs.tolist())}
    rows = []
    for (i, j), k in pos.items():  # neighbours along alpha and along beta inside the triangle
        for nb in ((i + 1, j), (i, j + 1)):
            if nb in pos and nb[0] < L:
                rows.append((k, pos[nb]))
    D = np.zeros((len(rows), mirror.size))
    for r, (k, m) in enumerate(rows):
        D[r, k], D[r, m] = 1.0, -1.0
    Dp = np.column_stack([np.einsum("ij,jk->ik", D, P), np.zeros(len(rows))])
    Dr = np.linalg.qr(Dp, mode="r") if Dp.shape[0] > Dp.shape[1] else Dp
    for a in (pairs, P, Dr):
        a.setflags(write=False)
    return pairs, P, Dr


@functools.lru_cache(maxsize=8)
def pair_columns(G: int) -> tuple:
    """(one, other, two) of :func:`structure`'s P: each pair column's hysteron, its mirror, and whether the mirror
    is another hysteron (not on the anti-diagonal), so that S @ P = S[:, one] + S[:, other] where two. The same
    bytes as the product (every other term of it is an exact zero), ~15x faster than einsum for a 256-sample
    loop at 16 fields. Cached: read-only."""
    P = structure(G)[1]
    one, other = np.argmax(P, axis=0), P.shape[0] - 1 - np.argmax(P[::-1], axis=0)
    two = one != other
    for a in (one, other, two):
        a.setflags(write=False)
    return one, other, two


def pair_sums(S, G: int) -> np.ndarray:
    """S @ P of :func:`structure` (G fields per sign) by :func:`pair_columns`: the states summed per mirror pair, in C
    order as the product was (numpy's column gather returns Fortran order, and a design in that order is summed in
    another order downstream: last-bit differences in a real-core diagnosis)."""
    one, other, two = pair_columns(G)
    A = np.ascontiguousarray(S[:, one])
    A[:, two] += S[:, other[two]]
    return A


class Everett:
    """The base's design for one sweep: columns (mirror pairs + chi), their smoothness penalty, the samples."""

    def __init__(self, sw: Sweep, G: int, start: str, fine: int, first: int, db_share: float, h0: float = 0.0):
        self.sw = sw
        self.H = sw.n_over_le * sw.current - h0  # the field the core saw: a measured H off by h0 (errors in H)
        v = sw.valid
        lv = grid_levels(self.H[v] + h0, sw.B[v], G, db_share)  # the levels of the data as read: |H - h0| of a
        # symmetric loop has twice as many distinct levels, and a grid from them jumps with any h0 (0.67 -> 3.2 mT)
        pairs, _, self.D = structure(lv.size // 2)
        S = np.zeros((self.H.size, pairs.shape[0]))
        S[first:] = cell_states(self.H[first:], lv, start, int(fine))
        self.A = np.column_stack([pair_sums(S, lv.size // 2), self.H])  # last column: the reversible chi H (chi >= 0)
        self.fixed = MU0 * self.H
        self.start = start


def solve(A, y, D, lam: float, extra=None, want_edf: bool = False, start=None):
    """Non-negative weights of [A extra] for y, with sqrt(lam) D on A's columns: (coef, fitted, edf); the edf
    (trace of the hat matrix on the active set) only when asked. The columns are scaled to unit norm and the
    problem is solved on its normal equations (:func:`nnls_gram`), ``start`` a guess of the active set (a fold of
    the same design, another lam); scipy's nnls on the stacked system where the normal equations fail."""
    X = A if extra is None else np.column_stack([A, extra])
    sc = np.sqrt(np.sum(X * X, axis=0))
    sc[sc == 0] = 1.0
    Xs = X / sc
    k = D.shape[1]
    G = Xs.T @ Xs
    G[:k, :k] += lam * penalty_gram(D) / np.outer(sc[:k], sc[:k])
    w = nnls_gram(G, Xs.T @ y, start)
    if w is None:  # not positive definite in floating point, or no convergence: the stacked system
        M = np.vstack([Xs, np.zeros((D.shape[0], X.shape[1]))])
        M[X.shape[0]:, :k] = D * math.sqrt(lam) / sc[:k]
        w, _ = nnls(M, np.concatenate([y, np.zeros(D.shape[0])]), maxiter=50 * M.shape[1])
    coef = w / sc
    return coef, np.einsum("ij,j->i", X, coef), (edf_of(X, D, sc, lam, w > 0) if want_edf else 0.0)


_GRAM: dict = {}


def penalty_gram(D) -> np.ndarray:
    """D'D of a penalty factor, once per array (those of :func:`structure` are cached and read-only)."""
    hit = _GRAM.get(id(D))
    if hit is None or hit[0] is not D:  # the array is held, so its id is not another's while cached
        if len(_GRAM) >= 16:
            _GRAM.clear()
        hit = _GRAM[id(D)] = (D, np.einsum("ki,kj->ij", D, D))
    return hit[1]


def edf_of(X, D, sc, lam: float, act) -> float:
    """The trace of the hat matrix on the active set ``act`` (the weights > 0) of :func:`solve`'s system, D the
    penalty on X's first D.shape[1] columns (an increment's extra columns carry none): with the columns scaled by
    sc, Xa (Xa'Xa + lam Da'Da + 1e-12 I)^-1 Xa' has the trace ||L^-1 Xa'||^2 for the Cholesky factor L of the
    bracket, and Da'Da is D'D's block (:func:`penalty_gram`): no p x p inverse, no product over D's rows."""
    if not act.any():
        return 0.0
    ia = np.flatnonzero(act)
    s = sc[ia]
    Xa = X[:, ia] / s
    G = np.einsum("ki,kj->ij", Xa, Xa)
    pen = ia[ia < D.shape[1]]  # ia is sorted: the penalised columns come first
    Pa = np.zeros_like(G)
    Pa[: pen.size, : pen.size] = penalty_gram(D)[np.ix_(pen, pen)]
    Ab = G + lam * Pa / np.outer(s, s) + 1e-12 * np.eye(G.shape[0])
    try:
        Z = solve_triangular(np.linalg.cholesky(Ab), Xa.T, lower=True, check_finite=False)
    except np.linalg.LinAlgError:  # not positive definite in floating point: the plain solve
        return float(np.trace(np.linalg.solve(Ab, G)))
    return float(np.einsum("ij,ij->", Z, Z))


def edf_at(A, D, lam: float, coef, extra=None) -> float:
    """:func:`solve`'s edf for weights ``coef`` it returned (coef = w / sc with sc > 0: the same active set)."""
    X = A if extra is None else np.column_stack([A, extra])
    sc = np.sqrt(np.sum(X * X, axis=0))
    sc[sc == 0] = 1.0
    return edf_of(X, D, sc, lam, coef > 0)


def rss_of(r) -> float:
    return float(np.sum(np.asarray(r) ** 2))


class Model:
    """One linear model of the layers on the fitted samples: design X (rows = the sweep's samples), target y,
    penalty D on the base's columns, and optionally a clip on the ``cens`` samples (fitted without them, compared
    after clipping): symmetric at +-``clip``, or between ``clip = (lo, hi)`` (one rail: the other infinite)."""

    def __init__(self, X, y, D, extra=None, clip: float | tuple | None = None, cens=None, fixed=None):
        self.X, self.y, self.D, self.extra, self.clip = X, y, D, extra, clip
        self.cens = np.zeros(y.size, dtype=bool) if cens is None else cens
        self.fixed = np.zeros(y.size) if fixed is None else fixed  # B not in X (mu0 H): the clip acts on the sum
        self._warm = None  # the last solve's active set: the next one's start (a fold, another lam)

    def fit(self, rows, lam: float, want_edf: bool = False):
        """(prediction at every sample, edf) of a fit to ``rows`` (boolean); its weights in ``self.coef``. The same
        fit asked again (the base's resolution choice, :mod:`.baseres`, then :func:`fit_base` on the chosen designs)
        is answered from a memo: the same arrays."""
        tr = rows & ~self.cens
        if self.clip is not None and bool((rows & self.cens).any()):
            tr = self._censored(rows, tr, lam)
        memo = self.__dict__.setdefault("_memo", {})
        k = (float(lam), tr.tobytes())
        if k in memo and (memo[k][1] is not None or not want_edf):
            coef, edf = memo[k]
        elif k in memo:  # solved without its edf: the edf from the same weights, not a second NNLS
            coef = memo[k][0]
            edf = edf_at(self.X[tr], self.D, lam, coef, None if self.extra is None else self.extra[tr])
            memo[k] = (coef, edf)
        else:
            ex = None if self.extra is None else self.extra[tr]
            coef, _, edf = solve(self.X[tr], self.y[tr], self.D, lam, ex, want_edf, self._warm)
            memo[k] = (coef, edf if want_edf else None)
            self._warm = coef > 0
        edf = edf if want_edf and edf is not None else 0.0
        self.coef = coef  # an increment's size without solving the same system again (stability_sizes)
        Xf = self.X if self.extra is None else np.column_stack([self.X, self.extra])
        pred = np.einsum("ij,j->i", Xf, coef)
        if self.clip is not None:
            lo, hi = self._rails()
            pred = np.clip(pred + self.fixed, lo, hi) - self.fixed
        return pred, edf + (1.0 if self.clip is not None else 0.0)

    def _rails(self) -> tuple:
        return self.clip if isinstance(self.clip, tuple) else (-self.clip, self.clip)

    def _censored(self, rows, tr, lam: float, max_rounds: int = 8):
        """The rows a clipped fit is fitted to: the samples inside the limits, and each flagged one where the model
        falls short of the rail it was read at (a censored reading: the true B is at or beyond the rail, so a
        prediction inside the limits misses it; the model may go beyond the rail freely). Active set: a flagged
        sample joins while the fit falls short there and leaves once the fit passes the rail; until the set
        repeats (a few NNLS solves). Before 2026-11-27 the flagged samples were never fitted: a base fitted inside
        the limits fell short of them wherever it had no data to follow, and that shortfall stayed in ``left``."""
        memo = self.__dict__.setdefault("_memo", {})  # the same rows asked again: the same set, no NNLS
        done = self.__dict__.setdefault("_cens_memo", {})
        if (float(lam), rows.tobytes()) in done:
            return done[(float(lam), rows.tobytes())]
        lo, hi = self._rails()
        yb = self.y + self.fixed
        upper = np.abs(yb - hi) <= np.abs(yb - lo)  # the rail each flagged reading was read at (inf: never)
        cand, seen = rows & self.cens, set()
        ex = None if self.extra is None else self.extra
        Xf = self.X if ex is None else np.column_stack([self.X, ex])
        cur = tr
        for _ in range(max_rounds):
            key = cur.tobytes()
            if key in seen:
                break
            seen.add(key)
            coef, _, _ = solve(self.X[cur], self.y[cur], self.D, lam, None if ex is None else ex[cur], start=self._warm)
            self._warm = coef > 0
            memo.setdefault((float(lam), key), (coef, None))  # fit() takes the last round's weights from here
            pred = np.einsum("ij,j->i", Xf, coef) + self.fixed
            short = cand & np.where(upper, pred < hi, pred > lo)
            eps = 1e-9 * max(1.0, *(abs(x) for x in (lo, hi) if np.isfinite(x)))  # a fit that meets the rail
            keep = cur & self.cens & np.where(upper, pred <= hi + eps, pred >= lo - eps)  # fitted, not past it
            nxt = tr | short | keep
            if np.array_equal(nxt, cur):
                break
            cur = nxt
        done[(float(lam), rows.tobytes())] = cur
        return cur

    def stats(self, rows, lam: float, fold) -> dict:
        """RSS, edf, BIC (edf as parameters) and interleaved CV RMS over ``rows``."""
        pred, edf = self.fit(rows, lam, True)
        n = int(rows.sum())
        rss = rss_of((pred - self.y)[rows])
        cv = 0.0
        for k in np.unique(fold[rows]):
            test = rows & (fold == k)
            p, _ = self.fit(rows & ~test, lam)
            cv += rss_of((p - self.y)[test])
        return {"rss_T2": rss, "rms_T": math.sqrt(rss / n), "edf": edf, "n": n, "cv_T": math.sqrt(cv / n),
                "bic": n * math.log(max(rss, 1e-30) / n) + edf * math.log(n), "pred": pred,
                "resid": pred - self.y}  # the model's B at every sample is the data's B + resid (y = B - fixed)


def lam_grid(cfg: dict) -> list:
    return [float(x) for x in cfg["lambdas"]]


def h_centres(sw: Sweep) -> tuple:
    """The H offsets the base tries (errors in H, :func:`base_models`): 0 on a Hall sweep (H is the current times
    N/Le, exact); on a third-party B(H) loop, whose H is measured (an H coil, a fluxmeter's integrator), 0 and
    1/2, 1 and 3/2 of the loop's model-free centre in H, the mean of its last ascending and descending
    branches' zero crossings of B (Hiperco 50: +1.0 A/m; a constant B offset moves both crossings alike, so the
    base chooses h0 again with every increment)."""
    if sw.kind != "bh":
        return (0.0,)
    H, B, a = sw.n_over_le * sw.current, sw.B, int(sw.start)
    cross = {}
    for seg in sw.measured_shape.segments:  # the measured samples' path, derived once per diagnosis (from a)
        j = np.arange(seg.start, seg.stop + 1) + a
        j = j[sw.valid[j]]
        b, h = B[j], H[j]
        k = np.flatnonzero(np.sign(b[:-1]) * np.sign(b[1:]) < 0)
        if k.size:
            i = int(k[-1])
            cross[seg.direction] = float(h[i] - b[i] * (h[i + 1] - h[i]) / (b[i + 1] - b[i]))
    if len(cross) < 2:
        return (0.0,)
    hc = 0.5 * (cross[1] + cross[-1])
    return (0.0,) if not hc else (0.0, 0.5 * hc, hc, 1.5 * hc)


def base_models(sw: Sweep, cfg: dict) -> dict:
    """{(start, h0): (Everett design, Model)} for the start states this sweep allows and its H offsets
    (:func:`h_centres`): a closed third-party loop (from its extreme) runs its own conditioning prefix from the
    demagnetised state; a Hall sweep, or an open path (Hiperco's, from H ~ 0 with an unknown history), starts
    at its first sample from any of the three."""
    cyclic = _cyclic(sw)
    first = first_sample(sw)
    out = {}
    for h0 in h_centres(sw):
        for st in ("demagnetised",) if cyclic else STARTS:
            ev = Everett(sw, int(cfg["grid"]), st, int(cfg["fine"]), first, float(cfg["grid_db_share"]), h0)
            out[(st, h0)] = (ev, Model(ev.A, sw.B - ev.fixed, ev.D))
    return out


def _cyclic(sw: Sweep) -> bool:
    """A closed loop from its extreme (its conditioning prefix is run from the demagnetised state)."""
    H = np.abs(sw.current)
    return bool(sw.start > 0 and H[sw.start] >= 0.9 * float(np.max(H)))


def first_sample(sw: Sweep) -> int:
    """Where the base's hysterons start: 0 (the prefix run), or an open path's first sample (an unknown state)."""
    return 0 if _cyclic(sw) or sw.start == 0 else int(sw.start)


def free_choices(mods) -> float:
    """The degrees of freedom of the base's choices: one for a start state chosen among several, one for an H
    offset chosen among several."""
    return float(len({k[0] for k in mods}) > 1) + float(len({k[1] for k in mods}) > 1)


def fit_base(sw: Sweep, cfg: dict, mods: dict | None = None) -> dict:
    """The base: its start state and H offset (lowest RSS at the middle lam), lam by interleaved CV, its
    statistics. ``mods``: :func:`base_models` of this grid when made already (:mod:`.baseres`)."""
    rows = sw.valid.copy()
    fold = folds(sw, int(cfg["cv_folds"]), "interleaved")
    lams = lam_grid(cfg)
    mods = base_models(sw, cfg) if mods is None else mods
    mid = lams[len(lams) // 2]
    key = min(mods, key=lambda s: rss_of((mods[s][1].fit(rows, mid)[0] - mods[s][1].y)[rows]))
    ev, m = mods[key]
    sts = [m.stats(rows, lam, fold) for lam in lams]
    k = int(np.argmin([x["cv_T"] for x in sts]))
    lam, st = lams[k], sts[k]
    st["edf"] += free_choices(mods)
    n = st["n"]
    st["bic"] = n * math.log(max(st["rss_T2"], 1e-30) / n) + st["edf"] * math.log(n)
    return {"design": ev, "model": m, "lam": lam, "lams": lams, "start": key[0], "h0": key[1], "rows": rows,
            "fold": fold, "stats": st, "starts": mods}


def _variants(base: dict) -> dict:
    return base.get("starts") or {(base["start"], base.get("h0", 0.0)): (base["design"], base["model"])}


def _on_best_start(base: dict, make, lam: float):
    """((start, h0), Model, tied Models) of the start state and H offset under which ``make(design, model) -> Model``
    (an effect's model on the base's columns) fits best at ``lam``: a measurement effect moves the first readings
    too, so the start state that suits the bare base need not be the one under the effect (measured: a gadolinium
    Hall sweep with an eddy lag of 0.4, bare base from the demagnetised state 18.0 mT, from the negative remanence
    under the lag 2.8 mT), and a B offset moves a steep loop's zero crossings as an H offset does. Both are the
    material's (its history, its loop's centre in H), chosen again with every effect."""
    rows, fits = base["rows"], []
    for key, (ev, m) in _variants(base).items():
        mod = make(ev, m)
        fits.append((rss_of((mod.fit(rows, lam)[0] - mod.y)[rows]), key, mod))
    r0 = min(f[0] for f in fits)
    # the same fit to rounding: the base's own choice, else the first (H offsets a grid step apart can give the same
    # design; which one won was the solver's last bit: rc_048's offset 0.15 or 0.31 mT, a test's h0 12.8 or 19.1 A/m)
    tied = [f for f in fits if f[0] <= r0 * (1.0 + TIE_REL)]
    own = [f for f in tied if f[1] == (base["start"], base.get("h0", 0.0))]
    return (*(own or tied)[0][1:], [f[2] for f in tied])


def _charged(st: dict, base: dict) -> dict:
    """Statistics of an increment with the base's choices charged (:func:`free_choices`), as the base's own BIC is."""
    k = free_choices(_variants(base))
    st["edf"] += k
    st["bic"] += k * math.log(st["n"])
    return st


def stability_sizes(base: dict, effect: str, sw: Sweep, cfg: dict) -> list:
    """The effect's size on the base made more and less flexible (the smallest and largest lam of the grid):
    an increment that stands for a measurement effect keeps its size; one that patches the base's misfit
    follows the base. A lag is refined by half the steps of the judged one (on the grid alone, 0.05 against
    0.15 on a Hiperco Hall sweep whose lag is 0.15 failed the factor 2 between grid points)."""
    out = []
    for lam in sorted({min(base["lams"]), max(base["lams"])} - {base["lam"]}):
        r = increment(dict(base, lam=lam), effect, sw, dict(cfg, lag_refine=int(cfg["lag_refine"]) // 2),
                      size_only=True)
        if r is not None:
            out.append(float(r["size"]))
    return out


def increment(base: dict, effect: str, sw: Sweep, cfg: dict, sigs=None, size_only: bool = False) -> dict | None:
    """The effect's increment on the base: {"stats", "size", "start"} (size in the contract's unit; the start
    state chosen with the effect, :func:`_on_best_start`), or None when this sweep cannot show the effect (no
    sample times; no flat extreme for a clip). ``sigs``: the sweep's model-free signatures (a clip reads its
    flat_kink, :func:`_clip`). ``size_only``: {"size"} alone, the same size without the statistics' CV fits
    (:func:`stability_sizes` reads nothing else)."""
    lam, rows, fold = base["lam"], base["rows"], base["fold"]
    if effect in ("hall_offset", "thermal_drift"):
        if effect == "hall_offset":
            col = np.ones((sw.n, 1))
        elif not sw.has_time or not float(np.ptp(sw.time)) > 0:
            return None
        else:
            col = (sw.time - sw.time[0])[:, None]
        key, mod, tied = _on_best_start(base, lambda ev, m: Model(m.X, m.y, m.D, np.column_stack([col, -col])), lam)
        if size_only:  # the chosen model's fit at lam: _with_size's system
            return {"size": float(mod.coef[-2] - mod.coef[-1])}
        st = _charged(mod.stats(rows, lam, fold), base)
        out = {**_with_size(st, None, mod, rows, lam, effect), "start": key[0], "h0": key[1]}
        return dict(out, **size_tied(tied, rows, lam, out["size"]))
    if effect == "eddy_lag":
        return _lag(base, sw, cfg, size_only) if sw.has_time else None
    if effect == "sensor_saturation":
        from mrhyst.diagnose import everclip  # it builds on this module's Model

        return everclip.clip(base, sw, cfg, sigs, size_only)
    return None


def size_tied(tied: list, rows, lam: float, size: float) -> dict:
    """{"size_tied": [lo, hi]} when start states or H offsets that fit the sweep alike (RSS within TIE_REL: H offsets
    a grid step apart can give the same design) give the effect different sizes (by more than 1 % of the chosen
    one): the sweep does not identify the size between them (rc_048 of a build: an offset of 0.15 or 0.31 mT);
    else {}."""
    sizes = []
    for m in tied:
        m.fit(rows, lam)  # each was fitted at lam by _on_best_start: its memo, not a second solve
        sizes.append(float(m.coef[-2] - m.coef[-1]))
    lo, hi = min(sizes + [size]), max(sizes + [size])
    return {"size_tied": [lo, hi]} if hi - lo > 0.01 * abs(size) else {}


def _with_size(st, _, mod: Model, rows, lam: float, kind: str) -> dict:
    mod.fit(rows, lam)  # the system stats() solved (its memo): the same weights, not solved again
    return {"stats": st, "size": float(mod.coef[-2] - mod.coef[-1])}


def _lag(base: dict, sw: Sweep, cfg: dict, size_only: bool = False) -> dict:
    """The lag by the RSS over a grid for every start state (:func:`_on_best_start`; each walked, :func:`_walk`),
    refined by golden section between the best point's neighbours on the best start."""
    lam, rows, fold = base["lam"], base["rows"], base["fold"]
    starts = _variants(base)

    made = {}

    def model(lag, start):  # one Model per (lag, start): the chosen one's statistics reuse its fit (Model's memo)
        if (lag, start) not in made:
            ev, m = starts[start]
            Xf = fx.eddy_filter(m.X.T, lag).T
            made[(lag, start)] = Model(Xf, sw.B - fx.eddy_filter(ev.fixed, lag), m.D)
        return made[(lag, start)]

    def cost(lag, start):
        mod = model(lag, start)
        return rss_of((mod.fit(rows, lam)[0] - mod.y)[rows])

    grid = [float(x) for x in cfg["lag_grid"]]
    c = _walk(cost, grid, starts)
    g0, start = min(c, key=c.get)
    i = grid.index(g0)
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    g = (math.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = b - g * (b - a), a + g * (b - a)
    f1, f2 = cost(x1, start), cost(x2, start)
    for _ in range(int(cfg["lag_refine"])):
        if f1 < f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - g * (b - a)
            f1 = cost(x1, start)
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + g * (b - a)
            f2 = cost(x2, start)
    lag = min([(c[(g0, start)], g0), (f1, x1), (f2, x2)])[1]
    if size_only:
        return {"size": float(lag)}
    st = _charged(model(lag, start).stats(rows, lam, fold), base)
    st["edf"] += 1.0
    st["bic"] += math.log(st["n"])
    return {"stats": st, "size": float(lag), "start": start[0], "h0": start[1]}


def _walk(cost, grid, starts) -> dict:
    """{(lag, start): RSS} on the lag grid, each start state's walked up from the smallest lag and stopped at the
    first lag whose RSS is above the one before it (issue 23's speed goal: the grid is ~2/3 of a lag search's NNLS
    solves). The same minimum as the whole grid wherever a start's RSS along the grid has no second, deeper dip past
    its first rise; measured on 202 lag searches (60 blind, 30 bipolar2, the 55 real-cores Hall cases; 606 start
    curves): every curve unimodal, every argmin the whole grid's, 17 % (blind) and 40 % (the rest) of the grid's
    solves left out; the whole benchmark's 378 diagnoses the same JSON but for ``search``. ``bench/bench_nnls.py
    --lag`` counts it again on any cases."""
    c = {}
    for st in starts:
        prev = None
        for g in grid:
            c[(g, st)] = cost(g, st)
            if prev is not None and c[(g, st)] > prev:
                break
            prev = c[(g, st)]
    return c
