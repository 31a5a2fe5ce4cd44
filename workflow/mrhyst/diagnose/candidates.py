"""Candidate fitting: plain J-A by multi-start LM, each effect (and pairs) from data-derived starts, a deep
search from random starts, held-out errors (K-fold CV, branch hold-out), standard errors, BIC.

Everything here fits; nothing decides (that is :mod:`.policy`)."""

from __future__ import annotations

import math

import numpy as np

from mrhyst.data.io import InputError
from mrhyst.diagnose.problem import HOLDOUT_FTOL, HOLDOUT_MAX_ITER, JA_NAMES, LM_FTOL, Fit, Problem, best, n_params
from mrhyst.diagnose.sweep import folds
from mrhyst.fit.accuracy import correlation_factor
from mrhyst.model import effects as fx
from mrhyst.model import streams


def bic(rss: float, n: int, p: int, floor_T: float) -> float:
    """BIC = n ln(RSS/n) + p ln n, RSS floored at n floor^2 (noise-free data would give ln 0)."""
    return n * math.log(max(rss, n * floor_T**2) / n) + p * math.log(n)


def _random_ja(prob: Problem, rng, n: int) -> np.ndarray:
    """n J-A coordinate sets drawn log-uniformly (alpha, c uniformly) from start_box."""
    J = np.empty((n, 5))
    for j, name in enumerate(JA_NAMES):
        lo, hi = (float(x) for x in prob.cfg["start_box"][name])
        J[:, j] = rng.uniform(lo, hi, n) if name in ("alpha", "c") else rng.uniform(math.log(lo), math.log(hi), n)
    return J


def _n_best(prob: Problem, U, mask) -> np.ndarray:
    cost, _ = prob.cost(U, mask.astype(float))
    order = np.argsort(cost, kind="stable")[: int(prob.cfg["n_starts"])]
    return U[order[np.isfinite(cost[order])]]


def random_starts(prob: Problem, mask, seed: int) -> np.ndarray:
    """The n_starts best of n_random J-A parameter sets drawn from start_box (one batched call)."""
    rng = np.random.default_rng([int(seed), 20190111])
    n = int(prob.cfg["n_random"])
    U = np.tile(prob.null, (n, 1))
    U[:, :5] = _random_ja(prob, rng, n)
    return _n_best(prob, U, mask)


def fit_plain(prob: Problem, seeds, mask=None) -> dict:
    """Plain J-A by multi-start LM for each seed (all starts of all seeds in one batch): {seed: best Fit}."""
    sw = prob.sw
    mask = sw.valid if mask is None else mask
    rows, owner = [], []
    for s in seeds:
        st = random_starts(prob, mask, s)
        rows += list(st)
        owner += [s] * len(st)
    if not rows:
        raise InputError(f"{sw.source}: no J-A parameter set in the start box gives a valid loop for "
                         f"{sw.sensor}; is coil_turns_per_m right?")
    fits = prob.lm(np.array(rows), [()] * len(rows), mask.astype(float))
    out = {}
    for s in seeds:
        mine = [f for f, o in zip(fits, owner) if o == s]
        if mine:
            out[s] = best(mine)
    return out


def effect_starts(prob: Problem, e: str, base: Fit, mask) -> list:
    """Start values of effect ``e``'s coordinate from a fit and its residual (the registry's ``starts``)."""
    ctx = prob.ctx
    ctx.mask, ctx.ja_coords = mask, base.u[:5]
    return list(fx.REGISTRY[e].starts(ctx, (prob.sw.B - base.B) * 1e3))


def fit_augmented(prob: Problem, models, base, mask=None, ftol: float = LM_FTOL) -> dict:
    """Fit each model (tuple of effects) from a fit of a sub-model, with data-derived starts for the
    effects that sub-model lacks; all starts of all models in one LM batch. ``base``: one Fit for every
    model, or a list of Fits per model (each a start). Returns {model: best Fit}."""
    mask = prob.sw.valid if mask is None else mask
    rows, eff_rows = [], []
    for i, model in enumerate(models):
        for b in (base[i] if isinstance(base, (list, tuple)) else [base]):
            u0 = prob.embed(b.u, model)
            starts = [u0]
            for e in model:
                if e in b.effects:
                    continue
                for x in effect_starts(prob, e, b, mask):
                    u = u0.copy()
                    u[prob.col[e]] = x
                    starts.append(prob.embed(u, model))
            for u in starts:
                if not any(np.array_equal(u, w) for w, m in zip(rows, eff_rows) if m == model):
                    rows.append(u)
                    eff_rows.append(model)
    fits = prob.lm(np.array(rows), eff_rows, mask.astype(float), ftol=ftol)
    return {model: best([f for f, m in zip(fits, eff_rows) if m == model]) for model in models}


def deep_starts(prob: Problem, e: str, seed: int, mask) -> np.ndarray:
    """Starts for J-A + ``e`` away from the plain fit: random J-A sets x the registry's grid of the
    effect's size (one batched call); the n_starts best. The draws are the effect's own stream, keyed by its
    name (:func:`mrhyst.model.streams.stream`): registering another effect leaves them as they are."""
    rng = streams.stream(seed, 20190112, e)
    n = int(prob.cfg["n_random_deep"])
    J = _random_ja(prob, rng, n)
    prob.ctx.mask = mask
    grid = fx.REGISTRY[e].grid(prob.ctx)
    U = np.tile(prob.null, (n * len(grid), 1))
    for g, x in enumerate(grid):
        U[g * n:(g + 1) * n, :5] = J
        U[g * n:(g + 1) * n, prob.col[e]] = x
    U = prob.embed_rows(U, (e,))
    return _n_best(prob, U, mask)


def deep_search(prob: Problem, fits: dict, seed: int) -> bool:
    """Every candidate searched again from deep starts; ``fits`` updated in place. True when one improved."""
    v = prob.sw.valid
    rows, effs = [], []
    for e in fits:
        st = deep_starts(prob, e, seed, v)
        rows += list(st)
        effs += [(e,)] * len(st)
    if not rows:
        return False
    deep = prob.lm(np.array(rows), effs, v.astype(float))
    changed = False
    for e in fits:
        f = best([d for d, m in zip(deep, effs) if m == (e,)] + [fits[e]])
        changed |= f is not fits[e]
        fits[e] = f
    return changed


def stderr_widening(prob: Problem, fit: Fit, mask) -> dict:
    """{"factor", "rho"}: how much the fit's residuals, correlated along the path, widen its Jacobian standard
    errors (:func:`mrhyst.fit.accuracy.correlation_factor`, rho capped at config diagnose.stderr_rho_max)."""
    k, rho = correlation_factor([fit.B[mask] - prob.Bobs_mT[mask] * 1e-3], float(prob.cfg["stderr_rho_max"]))
    return {"factor": k, "rho": rho}


def std_errors(prob: Problem, fit: Fit, mask) -> np.ndarray:
    """Standard errors of the free coordinates from the Jacobian at the optimum, widened for residuals correlated
    along the path (:func:`stderr_widening`; on a real core the residual is mostly model form, smooth along the
    path, and the plain stderr is several times too small).

    cov = s^2 (J'J)^-1 with s^2 = RSS / (n - p), through a column-scaled pseudo-inverse (the J-A
    coordinates are strongly correlated at low field; the effect's coordinate usually is not).
    """
    J = prob.jacobian(fit, mask)
    s2 = fit.rss * 1e6 / max(fit.n - J.shape[1], 1)  # mT^2
    norms = np.sqrt(np.sum(J**2, axis=0))
    norms[norms == 0] = 1.0
    Js = J / norms
    cov = np.linalg.pinv(Js.T @ Js, rcond=1e-12, hermitian=True) * s2 / np.outer(norms, norms)
    se = np.full(len(prob.cols), np.nan)
    se[np.flatnonzero(prob.spec(fit.effects)[0])] = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return se * stderr_widening(prob, fit, mask)["factor"]


def holdout_masks(sw, K: int, kinds) -> list:
    """(kind, train, test) of every fold of every scheme in ``kinds``."""
    masks = []
    for kind in kinds:
        if kind == "branch":
            train = sw.valid & (np.arange(sw.n) <= sw.peak_last)
            test = sw.valid & (np.arange(sw.n) > sw.peak_last)
            if test.any():
                masks.append((kind, train, test))
            continue
        fo = folds(sw, K, kind)
        for k in range(K):
            test = sw.valid & (fo == k)
            if test.any():
                masks.append((kind, sw.valid & (fo != k), test))
    return masks


HOLDOUT_KEY = {"interleaved": "cv_interleaved_T", "blocks": "cv_blocks_T", "branch": "heldout_T"}


def pool_holdout(sw, names, kinds, tags, predictions) -> dict:
    """RMS over held-out samples per (name, kind) from refits' predictions (None for a failed refit)."""
    acc = {(name, kind): [0.0, 0] for name in names for kind in kinds}
    folds = {name: [] for name in names}  # each contiguous block's own RMS, in path order (policy: blocks_rule)
    for (name, kind, test), B in zip(tags, predictions):
        a = acc[(name, kind)]
        if kind == "blocks":
            folds[name].append(math.inf if B is None else math.sqrt(float(np.mean((B[test] - sw.B[test]) ** 2))))
        if B is None or a[0] == math.inf:
            a[0] = math.inf
            continue
        a[0] += float(np.sum((B[test] - sw.B[test]) ** 2))
        a[1] += int(test.sum())
    out = {name: {HOLDOUT_KEY[kind]: (math.sqrt(acc[(name, kind)][0] / acc[(name, kind)][1])
                                      if acc[(name, kind)][1] and math.isfinite(acc[(name, kind)][0]) else math.inf)
                  for kind in kinds} for name in names}
    for name in names:
        if folds[name]:
            out[name]["cv_blocks_folds_T"] = folds[name]
    return out


def holdout(prob: Problem, fits: dict, kinds=("interleaved", "blocks", "branch")) -> dict:
    """Held-out errors of every fit in ``fits`` ({name: Fit}), all refits in one LM batch.

    ``interleaved`` / ``blocks``: K-fold cross-validation, each fold predicted from a fit to the
    others (warm start from the full fit); RMS over all held-out samples (T). Interleaved folds test
    whether the extra parameter generalises between neighbouring samples (fair to an effect whose
    evidence is local, like a clipped top); contiguous blocks test extrapolation along the loop.
    ``branch``: fit the ascending branch and the turning point, predict the descending branch.
    Returns {name: {"cv_interleaved_T", "cv_blocks_T", "heldout_T"}} (inf when a refit fails).
    """
    sw = prob.sw
    masks = holdout_masks(sw, int(prob.cfg["cv_folds"]), kinds)
    rows, effs, W, tags = [], [], [], []
    for name, f in fits.items():
        for kind, train, test in masks:
            rows.append(f.u)
            effs.append(f.effects)
            W.append(train)
            tags.append((name, kind, test))
    res = (prob.lm(np.array(rows), effs, np.array(W, dtype=float), max_iter=HOLDOUT_MAX_ITER, ftol=HOLDOUT_FTOL)
           if rows else [])
    return pool_holdout(sw, fits, kinds, tags, [f.B if f.ok else None for f in res])


def needs_holdout(scores: dict) -> set:
    """The candidates whose held-out refits a verdict can read (issue 23's screen, like the model form's
    :func:`mrhyst.diagnose.modelform.needs_holdout`): those with delta BIC > 0. A verdict weighs the held-out errors
    of the ``cv_max_candidates`` largest delta BIC past ``bic_margin`` >= 0 (:func:`.asrun.cross_validated`), the
    pair search those of delta BIC > 0 (:func:`.asrun.possible_leaders`), the deep-search test those past
    ``cross_seed_margin`` >= 0, the layers a J-A increment's only where it earns (delta BIC > ``bic_margin``). A
    candidate with delta BIC <= 0 keeps no held-out statistics (measured: 58-67 % of a build's candidates)."""
    return {e for e, c in scores.items() if c["delta_bic"] > 0}


def holdout_once(prob: Problem, fits: dict, memo: dict) -> dict:
    """:func:`holdout` of the fits whose held-out errors ``memo`` lacks; the others from it (``memo`` updated).
    A fit is keyed by its model and coordinates: its refits start there and each row of the LM batch is
    computed on its own (a row gives the same bytes in any batch), so a fit the deep search left as it was
    gets the same errors without refitting it."""
    def key(f):
        return f.effects, f.u.tobytes()

    todo = {name: f for name, f in fits.items() if key(f) not in memo}
    memo.update({key(todo[name]): ho for name, ho in holdout(prob, todo).items()})
    return {name: dict(memo[key(f)]) for name, f in fits.items()}


def score(prob: Problem, base: Fit, fits: dict) -> dict:
    """BIC, delta BIC (vs plain J-A), size and plausibility of every fitted candidate."""
    cfg = prob.cfg
    nv = int(prob.sw.valid.sum())
    floor = float(cfg["rss_floor_T"])
    b0 = bic(base.rss, nv, 5, floor)
    out = {}
    for e, f in fits.items():
        b = bic(f.rss, nv, n_params(f.effects), floor)
        ja_d, eff = prob.physical(f.u, f.effects)
        out[e] = {"effect": e, "n_params": n_params(f.effects), "rss_T2": f.rss, "rms_T": f.rms, "bic": b,
                  "delta_bic": b0 - b, "ja_params": ja_d, "params": eff[e], "ok": f.ok,
                  "branch_identifiable": fx.REGISTRY[e].branch_identifiable,
                  "time_bound": fx.REGISTRY[e].time_bound,
                  "block_identifiable": fx.REGISTRY[e].block_identifiable, **plausibility(prob, f, (e,))}
    return out


def plausibility(prob: Problem, f: Fit, effects) -> dict:
    """{"plausible": bool, "plausible_why": str} of the fitted sizes of ``effects`` (registry checks)."""
    ctx = prob.ctx
    ctx.ja_coords = f.u[:5]
    ok, why = True, []
    for e in effects:
        good, text = fx.REGISTRY[e].plausible(prob.to_contract(e, f.u), ctx, prob.cfg["plausible"])
        ok &= bool(good)
        why.append(f"{e}: {text}" + ("" if good else " (implausible)"))
    return {"plausible": ok, "plausible_why": "; ".join(why)}
