"""Model-form candidates (issue 12): physics J-A leaves out, fitted to the same sweep.

* ``two_phase`` - a second magnetic phase: the sum of two J-A magnetisations in the same field,
  B = mu0 (H + M1(H) + M2(H)) = B1 + B2 - mu0 H (core steel + the MR fluid's iron particles; each phase
  has its own Ms, a, alpha, c, k; no coupling between them beyond the common H). 10 parameters.
* ``jtd1992``, ``venkataraman``, ``anisotropic`` - an extended J-A: the variants of :data:`mrhyst.model.ja.MODELS`
  (Jiles-Thoelke-Devine 1992 weights; Venkataraman's form; Szewczyk's mixed isotropic/anisotropic
  anhysteretic, with the anisotropy angle psi held at 0 since only K_an cos(2 psi) enters), started from
  the plain J-A fit. 5 parameters (anisotropic: 7).
* ``preisach`` - a reference hysteresis law outside J-A: the classical Preisach model with a parametric
  switching-field distribution (Mayergoyz 1991): rectangular hysterons that switch up at
  alpha = Hu + Hc and down at beta = Hu - Hc, weighted by a log-normal density of the coercive field Hc
  (median Hc0, log-width sc) times a normal density of the interaction field Hu (width su), plus a
  reversible susceptibility chi: B = mu0 (H (1 + chi) + Ms sum(w s) / sum(w)). The sweep starts from the
  demagnetised state (s = +1 where Hu < 0, -1 where Hu > 0). No maintained Preisach package is listed
  in the environment's package index, so this is a small vectorised implementation: the hysteron states
  along the path do not depend on the parameters (the grid is fixed in units of the sweep's peak field),
  so every parameter set is one matrix product. 5 parameters, like J-A.

Each candidate is a small class with ``forward(X) -> (B, ok)`` batched over parameter rows, bounds,
difference steps and data-derived starts, and ONE entry of :data:`REGISTRY` (:class:`ModelForm`: its name and how
it is built for a sweep; :func:`register` adds one, e.g. a test's toy); :func:`fit_all` fits them with the same
domain-free batched LM as the effects and measures the same held-out errors. Each candidate's random starts come
from its own stream, keyed by its name, never by its place in the list.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np

from mrhyst.data.io import InputError
from mrhyst.diagnose.candidates import HOLDOUT_KEY, bic, holdout_masks, pool_holdout
from mrhyst.diagnose.problem import Fit, Problem, ja_sets
from mrhyst.fit.lm import LANES, least_squares_batch
from mrhyst.model import ja, streams

MU0 = ja.MU0


class JAVariant:
    """An extended J-A of :data:`mrhyst.model.ja.MODELS` in the plain fit's coordinates (+ K_an, t)."""

    def __init__(self, prob: Problem, model: str):
        self.prob, self.name = prob, model
        spec = ja.MODELS[model]
        self.extra = tuple(n for n in spec.names[5:] if n != "psi")  # psi held at 0 (not identifiable)
        self.n_params = 5 + len(self.extra)
        self.doc = f"extended J-A: {model} ({spec.citation.split(';')[0]})"
        self.lo = np.concatenate([prob.lo[:5], [spec.bounds[n][0] for n in self.extra]])
        self.hi = np.concatenate([prob.hi[:5], [spec.bounds[n][1] for n in self.extra]])
        self.steps = np.array([1e-7, 1e-7, 1e-9, 1e-7, 1e-7] + [1e-3 if n == "K_an" else 1e-6 for n in self.extra])
        self.names = spec.names
        self.lanes = LANES  # one J-A set a row

    def full(self, X) -> np.ndarray:
        X = np.atleast_2d(X)
        P = np.zeros((X.shape[0], len(self.names)))  # psi (not a coordinate) stays 0
        P[:, :5] = ja_sets(X)
        for i, n in enumerate(self.extra):
            P[:, self.names.index(n)] = X[:, 5 + i]
        return P

    def forward(self, X):
        sw = self.prob.sw
        return ja.simulate(self.full(X), sw.current, sw.n_over_le, form=self.prob.form,
                           substeps=self.prob.substeps, dman=self.prob.dman, model=self.name)

    def starts(self, base: Fit, rng, k: int) -> np.ndarray:
        u = base.u[:5]
        if not self.extra:
            return np.array([u])
        rows = [np.concatenate([u, [kan, t]]) for kan in (100.0, 2000.0) for t in (0.2, 0.6)]
        return np.clip(np.array(rows[:k]), self.lo, self.hi)

    def params(self, x) -> dict:
        return {n: float(v) for n, v in zip(self.names, self.full(x)[0])}


class TwoPhase:
    name = "two_phase"
    n_params = 10
    doc = "second magnetic phase: sum of two J-A loops (core steel + MR-fluid particles)"

    def __init__(self, prob: Problem):
        self.prob = prob
        sw = prob.sw
        self.H = sw.n_over_le * sw.current
        self.lo = np.concatenate([prob.lo[:5], prob.lo[:5]])
        self.hi = np.concatenate([prob.hi[:5], prob.hi[:5]])
        self.steps = np.array([1e-7, 1e-7, 1e-9, 1e-7, 1e-7] * 2)
        self.run = ja.prepared(sw.current, sw.n_over_le, form=prob.form, substeps=prob.substeps, dman=prob.dman)
        self.lanes = LANES

    def forward(self, X):
        X = np.atleast_2d(X)
        n = X.shape[0]
        P = ja_sets(np.concatenate([X[:, :5], X[:, 5:]]))
        sw = self.prob.sw
        share = P[:n, 0] / (P[:n, 0] + P[n:, 0])  # the start state split between the phases by Ms
        M0 = sw.M0 * np.concatenate([share, 1.0 - share])
        # each distinct (phase set, start) integrated once: a Jacobian's probe moves one phase and leaves the other
        # (12 of its 20 sets a row are distinct); a kernel lane's bytes do not depend on the others
        keep, inv = distinct_rows(np.column_stack([P, M0]))
        B, ok = self.run(P[keep], M0[keep])
        one, two = inv[:n], inv[n:]
        return B[one] + B[two] - MU0 * self.H[None, :], ok[one] & ok[two]

    def starts(self, base: Fit, rng, k: int) -> np.ndarray:
        """The plain fit split into a main phase and a soft or hard minor phase of a tenth to a third."""
        u = base.u[:5]
        rows = []
        for frac, fa, fk in ((0.1, 0.2, 0.2), (0.1, 5.0, 5.0), (0.3, 0.3, 3.0), (0.3, 3.0, 0.3), (0.1, 1.0, 0.1),
                             (0.2, 10.0, 1.0), (0.05, 0.1, 0.05), (0.3, 1.0, 10.0)):
            p2 = [u[0] + math.log(frac), u[1] + math.log(fa), 0.0, 0.5, u[4] + math.log(fk)]
            rows.append(np.clip(np.concatenate([[u[0] + math.log(1 - frac)], u[1:], p2]), self.lo, self.hi))
        return np.array(rows[:k])

    def params(self, x) -> dict:
        names = ja.PARAM_NAMES
        p1 = self.prob.ja_params(x[:5])
        p2 = self.prob.ja_params(x[5:])
        return {"phase1": dict(zip(names, map(float, p1))), "phase2": dict(zip(names, map(float, p2)))}


class Preisach:
    name = "preisach"
    n_params = 5
    doc = "Preisach model, log-normal coercive x normal interaction field distribution, + reversible chi"

    def __init__(self, prob: Problem, grid: int):
        self.prob = prob
        sw = prob.sw
        self.H = sw.n_over_le * sw.current
        hmax = float(np.max(np.abs(self.H))) or 1.0
        self.hmax = hmax
        self.lnhc = np.linspace(math.log(1e-3 * hmax), math.log(3.0 * hmax), grid)
        s = np.sinh(np.linspace(-4.0, 4.0, grid + 1)) / math.sinh(4.0)  # dense near Hu = 0
        self.hu = 3.0 * hmax * s
        self.dhu = np.gradient(self.hu)
        hc = np.exp(self.lnhc)
        HC, HU = np.meshgrid(hc, self.hu, indexing="ij")
        up, down = (HU + HC).ravel(), (HU - HC).ravel()
        self.ST = _states(up, down, -np.sign(HU.ravel()), self.H)  # (hysterons, samples), parameter-free
        # the distinct state columns (a repeated cycle revisits its states: the wiping-out property), each summed
        # once: a sample's m is its column's, the same sums in the same order (half the work on a bipolar sweep)
        # (in order of first appearance: each column's sum is its own, so the order of the columns changes no byte;
        # np.unique's sort of the columns was most of the cost of setting up the candidate)
        keep, self.col_of = distinct_rows(self.ST.T)
        self.ST_distinct = np.ascontiguousarray(self.ST[:, keep])
        # coordinates: ln Ms, ln Hc0, ln sc, ln(su / Hmax), chi
        self.lo = np.array([math.log(1e2), self.lnhc[0], math.log(0.05), math.log(3e-3), 0.0])
        self.hi = np.array([math.log(1e8), self.lnhc[-1], math.log(3.0), math.log(3.0), 1e5])
        self.steps = np.array([1e-7, 1e-7, 1e-7, 1e-7, 1e-4])
        self.lanes = 1  # a row's cost is its own matrix product: one damping per model call

    def shape(self, X) -> np.ndarray:
        """Normalised hysteron magnetisation m(H) in [-1, 1], (rows, samples)."""
        X = np.atleast_2d(X)
        wc = np.exp(-0.5 * ((self.lnhc[None, :] - X[:, 1:2]) / np.exp(X[:, 2:3])) ** 2)
        su = np.exp(X[:, 3:4]) * self.hmax
        wu = np.exp(-0.5 * (self.hu[None, :] / su) ** 2) * self.dhu[None, :]
        w = (wc[:, :, None] * wu[:, None, :]).reshape(X.shape[0], -1)
        tot = w.sum(axis=1, keepdims=True)
        # not BLAS: a multi-threaded BLAS on a loaded machine was measured 25x slower here
        return _hysteron_sum(w, self.ST_distinct)[:, self.col_of] / np.where(tot > 0, tot, 1.0)

    def forward(self, X):
        X = np.atleast_2d(X)
        m = self.shape(X)
        B = MU0 * (self.H[None, :] * (1.0 + X[:, 4:5]) + np.exp(X[:, 0:1]) * m)
        return B, np.all(np.isfinite(B), axis=1)

    def starts(self, base: Fit, rng, k: int) -> np.ndarray:
        """Random distribution shapes; Ms and chi of each by linear least squares; the k best."""
        n = 400
        X = np.column_stack([np.zeros(n), rng.uniform(math.log(3e-3 * self.hmax), math.log(self.hmax), n),
                             rng.uniform(math.log(0.2), math.log(1.5), n), rng.uniform(math.log(0.01), 0.0, n),
                             np.zeros(n)])
        m = self.shape(X)
        sw = self.prob.sw
        v = sw.valid
        y = sw.B[v] / MU0 - self.H[v]
        cost = np.full(n, np.inf)
        for i in range(n):
            A = np.column_stack([m[i, v], self.H[v]])
            (ms, chi), *_ = np.linalg.lstsq(A, y, rcond=None)
            ms, chi = max(ms, 1e2), max(chi, 0.0)
            X[i, 0], X[i, 4] = math.log(ms), chi
            cost[i] = float(np.sum((A @ [ms, chi] - y) ** 2))
        return np.clip(X[np.argsort(cost)[:k]], self.lo, self.hi)

    def params(self, x) -> dict:
        return {"Ms": math.exp(x[0]), "Hc0_A_per_m": math.exp(x[1]), "ln_width_Hc": math.exp(x[2]),
                "Hu_width_A_per_m": math.exp(x[3]) * self.hmax, "chi_rev": float(x[4])}


@numba.njit(cache=True)
def _states(up, down, state, H):
    """The hysteron states (hysterons, samples) along the path H from ``state``: up where H reaches ``up``, then
    down where it reaches ``down`` (a Python loop over the samples of numpy masks did this in ~10x the time)."""
    ST = np.empty((up.size, H.size))
    s = state.copy()
    for j in range(H.size):
        h = H[j]
        for i in range(up.size):
            if up[i] <= h:
                s[i] = 1.0
            if down[i] >= h:
                s[i] = -1.0
            ST[i, j] = s[i]
    return ST


@numba.njit(cache=True)
def _hysteron_sum(w, ST):
    """w @ ST, (n, hysterons) x (hysterons, samples of +-1 states), each sum in hysteron order from 0: the bytes
    of np.einsum("nh,hj->nj", w, ST), which sums a contiguous ST in this order (tests/test_fastpaths.py; the
    products w * (+-1) are exact, so FMA or not makes no difference), in a third of its time."""
    n, nh = w.shape
    out = np.zeros((n, ST.shape[1]))
    for k in range(n):
        for h in range(nh):
            wk = w[k, h]
            for j in range(ST.shape[1]):
                out[k, j] += wk * ST[h, j]
    return out


def distinct_rows(A) -> tuple[np.ndarray, np.ndarray]:
    """(keep, inv): the first row of each distinct byte pattern of A (n, k), in order, and A = A[keep][inv]."""
    A = np.ascontiguousarray(A, dtype=float)
    if not A.flags.writeable:  # a read-only array is a numba signature of its own (tests/test_kernel_signatures.py)
        A = A.copy()
    if A.size == 0:
        return np.zeros(0, dtype=np.intp), np.zeros(len(A), dtype=np.intp)
    return _distinct(A.view(np.int64))  # the float64 bit patterns: rows compare byte for byte (-0.0 != 0.0)


@numba.njit(cache=True)
def _distinct(B):
    """:func:`distinct_rows` of int64 rows by an open-addressing hash table (FNV-1a over the words): a Python dict
    of ``tobytes`` keys did the same in ~6x (40 rows) to ~30x (640 rows) the time (8d83d38 said 13x; timed again on
    random rows of 6 columns, 2026-11-27, load < 2), and it was a sixth of the two-phase candidate's model calls."""
    n, k = B.shape
    size = 16
    while size < 2 * n:
        size *= 2
    table = np.full(size, -1, dtype=np.intp)
    keep = np.empty(n, dtype=np.intp)
    inv = np.empty(n, dtype=np.intp)
    nk = 0
    for i in range(n):
        h = np.uint64(14695981039346656037)
        for c in range(k):
            h = (h ^ np.uint64(B[i, c])) * np.uint64(1099511628211)
        s = np.intp(h & np.uint64(size - 1))
        while True:
            j = table[s]
            if j < 0:
                table[s], keep[nk], inv[i] = nk, i, nk
                nk += 1
                break
            r = keep[j]
            same = True
            for c in range(k):
                if B[r, c] != B[i, c]:
                    same = False
                    break
            if same:
                inv[i] = j
                break
            s = (s + 1) & (size - 1)
    return keep[:nk].copy(), inv


@dataclass(frozen=True)
class ModelForm:
    """One model-form candidate: the single place that names it. ``make(prob, mf)`` builds its fittable model
    for one sweep (``mf``: config ``diagnose.model_form``): ``name``, ``doc``, ``n_params``, ``lo``, ``hi``,
    ``steps``, ``forward(X) -> (B, ok)`` batched over rows, ``starts(base, rng, k)`` and ``params(x)``; ``rng``
    is the candidate's own stream, keyed by its name (:func:`mrhyst.model.streams.stream`)."""

    name: str
    make: Callable
    doc: str = ""


REGISTRY: dict[str, ModelForm] = {}


def register(m: ModelForm) -> ModelForm:
    """Add (or replace) a model-form candidate: config ``diagnose.model_form.candidates`` may then name it."""
    REGISTRY[m.name] = m
    return m


def unregister(name: str) -> None:
    REGISTRY.pop(name, None)


register(ModelForm("two_phase", lambda prob, mf: TwoPhase(prob), TwoPhase.doc))
register(ModelForm("preisach", lambda prob, mf: Preisach(prob, int(mf["preisach_grid"])), Preisach.doc))
for _name in ("jtd1992", "venkataraman", "anisotropic"):
    register(ModelForm(_name, lambda prob, mf, _n=_name: JAVariant(prob, _n), f"extended J-A: {_name} (ja.MODELS)"))


def build(prob: Problem, names) -> list:
    """The fittable models of the model-form candidates ``names`` (registered ones) for this sweep."""
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise InputError(f"diagnose.model_form.candidates: {', '.join(map(repr, unknown))} is not a model-form "
                         f"candidate (expected one of {', '.join(REGISTRY)})")
    return [REGISTRY[n].make(prob, prob.cfg["model_form"]) for n in names]


def _shares(model) -> tuple:
    """What models sharing one LM batch must have in common: dimension, difference steps, lanes."""
    return model.steps.size, model.steps.tobytes(), getattr(model, "lanes", LANES)


def _fit_batch(jobs, max_iter: int, ftol: float) -> list:
    """[(x, rss, B, ok)] of each job (model, starts X0, weights W per start), all in ONE lock-step LM batch: models
    of one sweep with the same :func:`_shares` (jtd1992 and venkataraman) then share the LM's passes. Each model
    evaluates its own rows (a row's bytes do not depend on the rest of the batch, in the kernel or the LM), so a
    job's result is the bytes of fitting it alone (tests/test_fastpaths_modelform.py)."""
    models = [m for m, _, _ in jobs]
    assert len({_shares(m) for m in models}) == 1
    X0 = np.vstack([x for _, x, _ in jobs])
    W = np.vstack([w for _, _, w in jobs])
    owner = np.repeat(np.arange(len(jobs)), [len(x) for _, x, _ in jobs])
    lo = np.vstack([np.broadcast_to(m.lo, x.shape) for m, x, _ in jobs])
    hi = np.vstack([np.broadcast_to(m.hi, x.shape) for m, x, _ in jobs])
    Bobs = models[0].prob.sw.B * 1e3

    def fun(X, rows):
        r = np.empty((len(rows), Bobs.size))
        for k, model in enumerate(models):
            mine = owner[rows] == k
            if mine.any():
                B, ok = model.forward(X[mine])
                rk = (B * 1e3 - Bobs[None, :]) * W[rows[mine]]
                rk[~ok] = np.nan
                r[mine] = rk
        return r

    res = least_squares_batch(fun, X0, bounds=(lo, hi), diff_step=models[0].steps, max_iter=max_iter, ftol=ftol,
                              lanes=_shares(models[0])[2])
    out = []
    for k, model in enumerate(models):
        x = res.x[owner == k]
        B, ok = model.forward(x)
        out.append((x, res.cost[owner == k] * 1e-6, B, ok))
    return out


def _groups(models) -> list:
    """The models in LM batches: those with the same :func:`_shares` together, in their configured order."""
    by: dict = {}
    for m in models:
        by.setdefault(_shares(m), []).append(m)
    return list(by.values())


def needs_holdout(out: dict) -> set:
    """The candidates whose held-out refits a verdict can read (issue 23's screen, like the pair screen of
    :func:`mrhyst.diagnose.asrun.possible_leaders`): a candidate is named only when it earns, delta BIC >
    ``bic_margin`` >= 0 (the schema's minimum; a trade-off replay scales it by positive factors), so its held-out
    errors matter only where delta BIC > 0; and the lowest-BIC candidate's are reported in the ``model_form``
    block whatever it earns. The others keep no held-out statistics (measured: 889 of the 1418 candidates of a
    build's diagnoses had delta BIC <= 0)."""
    keep = {n for n, m in out.items() if m["delta_bic"] > 0}
    return keep | ({min(out, key=lambda n: out[n]["bic"])} if out else set())


def fit_all(prob: Problem, base: Fit, seed: int) -> dict:
    """Every configured model-form candidate fitted, and cross-validated where a verdict can read it
    (:func:`needs_holdout`): {name: statistics}."""
    mf = prob.cfg["model_form"]
    sw = prob.sw
    v = sw.valid
    nv = int(v.sum())
    floor = float(prob.cfg["rss_floor_T"])
    b0 = bic(base.rss, nv, 5, floor)
    built = build(prob, mf["candidates"])
    fitted, models = {}, {m.name: m for m in built}
    for group in _groups(built):
        # each its own stream: another candidate changes nothing
        X0 = [m.starts(base, streams.stream(seed, 20190113, m.name), int(mf["n_starts"])) for m in group]
        jobs = [(m, x, np.tile(v.astype(float), (len(x), 1))) for m, x in zip(group, X0)]
        res = _fit_batch(jobs, int(mf["max_iter"]), float(mf["ftol"]))
        fitted.update(zip((m.name for m in group), res))
    out = {}
    for model in built:  # in the configured order (the diagnosis JSON's)
        x, rss, B, ok = fitted[model.name]
        j = int(np.argmin(np.where(ok, rss, np.inf)))
        if not ok[j]:
            continue
        b = bic(float(rss[j]), nv, model.n_params, floor)
        out[model.name] = {"name": model.name, "doc": model.doc, "n_params": model.n_params,
                           "rms_T": math.sqrt(float(rss[j]) / nv), "bic": b, "delta_bic": b0 - b,
                           "params": model.params(x[j]), "B_T": B[j], "x": x[j]}
    cv = needs_holdout(out)
    done = {}
    for group in _groups([models[n] for n in out if n in cv]):
        done.update(_holdout(group, [out[m.name] for m in group]))
    return {n: done.get(n, m) for n, m in out.items()}


def _holdout(group, stats) -> dict:
    """{name: the candidate's statistics with its held-out errors} (interleaved, blocks, branch) of each model of
    ``group`` (one LM batch, :func:`_fit_batch`), each fold refitted from its full fit ``m["x"]``; the keys in the
    order the diagnosis JSON has always had them."""
    sw = group[0].prob.sw
    kinds = ("interleaved", "blocks", "branch")
    masks = holdout_masks(sw, int(group[0].prob.cfg["cv_folds"]), kinds)
    W = np.array([k[1] for k in masks], dtype=float)
    jobs = [(model, np.tile(m["x"], (len(masks), 1)), W) for model, m in zip(group, stats)]
    out = {}
    mf = group[0].prob.cfg["model_form"]
    fits = _fit_batch(jobs, int(mf["max_iter"]), float(mf["ftol"]))
    for (model, _, _), m, (_, _, Bh, okh) in zip(jobs, stats, fits):
        tags = [(model.name, kind, test) for kind, _, test in masks]
        ho = pool_holdout(sw, [model.name], kinds, tags, [Bh[k] if okh[k] else None for k in range(len(masks))])
        head = {k: m[k] for k in ("name", "doc", "n_params", "rms_T", "bic", "delta_bic")}
        out[model.name] = {**head, **{HOLDOUT_KEY[k]: ho[model.name][HOLDOUT_KEY[k]] for k in kinds},
                           **{k: m[k] for k in ("params", "B_T", "x")}}
    return out
