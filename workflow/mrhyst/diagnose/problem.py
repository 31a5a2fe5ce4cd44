"""One sweep's fitting problem: J-A plus effects in one coordinate space, through the one forward model.

Every model lives in one coordinate space; a model is the set of coordinates it frees. The J-A part is
(ln Ms, ln a, alpha, c, ln k); each effect of :data:`mrhyst.model.effects.REGISTRY` with a ``coord`` adds one
coordinate (scaled by its ``unit`` so the problem stays well conditioned: offsets in mT, the drift as mT
over the whole sweep, ...). An effect with a ``shared`` coordinate frees none: it widens one of J-A's (the air
gap lets alpha' (column 2) go below 0, ARCHITECTURE 5).
The forward model is :func:`mrhyst.model.effects.forward` (nothing here applies an effect); the solver is the
domain-free batched Levenberg-Marquardt :func:`mrhyst.fit.lm.least_squares_batch`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mrhyst.diagnose.settings import resolve_config
from mrhyst.diagnose.sweep import Sweep
from mrhyst.fit.lm import least_squares_batch
from mrhyst.model import effects as fx
from mrhyst.model import ja

MU0 = ja.MU0
JA_NAMES = ja.PARAM_NAMES
JA_COLS = ("ln_Ms", "ln_a", "alpha", "c", "ln_k")
JA_STEPS = (1e-7, 1e-7, 1e-9, 1e-7, 1e-7)  # forward-difference steps of the J-A coordinates
LM_FTOL = 1e-9  # a row stops when an accepted step lowers its cost by less than this fraction
LM_LAMBDA_MAX = 1e10
# A held-out refit of plain J-A, an effect or a pair starts at the full fit and only has to follow the fold it lost:
# it stops at a looser relative decrease and an iteration cap (the tail of a lock-step batch is a few rows creeping
# along J-A's ill-conditioned valley to max_iter). 1e-6 / 100: held-out RMS within 0.1 % of 1e-9 / 200 on the rig
# sweep; 1e-5 / 40 (0.5-2 %, and the model-form refits alike) flipped a blocks_factor = 1.0 comparison on a blind
# case (bench/verdict_diff.py). The model-form refits keep their own settings: the two-phase fit never converges.
HOLDOUT_FTOL = 1e-6
HOLDOUT_MAX_ITER = 100
# A pair (J-A + two effects) stops at 1e-6: its BIC moved < 0.04 on the rig sweeps (margins 2-10), for half the CPU
PAIR_FTOL = 1e-6


def candidates() -> tuple:
    """The effects the diagnosis refits (every registered one)."""
    return tuple(fx.REGISTRY)


def n_params(effects) -> int:
    """Parameters of J-A plus effects, as BIC counts them (the air gap's Nd counts as one)."""
    return 5 + len(tuple(effects))


@dataclass
class Fit:
    effects: tuple
    u: np.ndarray  # coordinates (Problem.cols)
    rss: float  # T^2 over the fitted samples
    n: int  # fitted samples
    ok: bool
    B: np.ndarray  # model B at every sample (T)
    iters: int = 0  # LM iterations taken
    converged: bool = True  # stopped by the cost tolerance (not by max_iter)

    @property
    def rms(self) -> float:
        return math.sqrt(self.rss / self.n) if self.ok else math.inf


def ja_sets(U) -> np.ndarray:
    """Classic J-A sets (n, 5) from coordinates (ln Ms, ln a, alpha, c, ln k, ...) (n, >= 5)."""
    P = np.empty((U.shape[0], 5))
    P[:, 0], P[:, 1], P[:, 4] = np.exp(U[:, 0]), np.exp(U[:, 1]), np.exp(U[:, 4])
    P[:, 2:4] = U[:, 2:4]
    return P


def best(fits):
    return min(fits, key=lambda f: (not f.ok, f.rss))


class Problem:
    """One sweep's fitting problem: coordinates and bounds, the batched forward model, the batched LM."""

    def __init__(self, sweep: Sweep, cfg):
        cfg = resolve_config(cfg)  # the diagnose section's settings (resolved once: these are returned as they are)
        self.sw, self.cfg, self.form = sweep, cfg, cfg["form"]
        self.dman, self.substeps = cfg["dman"], int(cfg["substeps"])
        Bv = sweep.B[sweep.valid]
        dt = float(sweep.time[-1] - sweep.time[0])
        self.dt = dt
        self.span_mT = max(float(np.ptp(Bv)), float(np.max(np.abs(Bv))), 1e-6) * 1e3
        self.t_rel = (sweep.time - sweep.time[0]) / dt if dt > 0 else np.zeros(sweep.n)
        self.ctx = fx.Context(self.span_mT, dt, sweep.B * 1e3, self.t_rel, sweep.valid, sweep.dwell_s,
                              dict(sweep.sensor_info))
        self.coord_effects = tuple(e for e in fx.REGISTRY.values() if e.coord)
        self.cols = JA_COLS + tuple(e.coord for e in self.coord_effects)
        self.col = {e.name: 5 + i for i, e in enumerate(self.coord_effects)}
        self.col.update({n: e.shared.col for n, e in fx.REGISTRY.items() if e.shared is not None})
        box = cfg["box"]
        lo = [math.log(box["Ms"][0]), math.log(box["a"][0]), box["alpha"][0], box["c"][0], math.log(box["k"][0])]
        hi = [math.log(box["Ms"][1]), math.log(box["a"][1]), box["alpha"][1], box["c"][1], math.log(box["k"][1])]
        for e in self.coord_effects:
            a, b = e.bounds(self.ctx)
            lo.append(a)
            hi.append(b)
        self.lo, self.hi = np.array(lo, dtype=float), np.array(hi, dtype=float)
        self.null = np.array([0.0] * 5 + [e.null for e in self.coord_effects])
        self.steps = np.array(list(JA_STEPS) + [e.step for e in self.coord_effects])
        self.Bobs_mT = sweep.B * 1e3
        self.n_evals = 0
        self._specs = {}
        self._runs, self._orders = {}, {}  # prepared integrations per substeps; effect orders per set of names

    # ---- models ----
    def spec(self, effects) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(free coordinates, lower, upper) of J-A + ``effects`` (read-only arrays, made once per model)."""
        key = tuple(effects)
        if key not in self._specs:
            self._specs[key] = self._make_spec(key)
        return self._specs[key]

    def _make_spec(self, effects) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        act = np.zeros(len(self.cols), dtype=bool)
        act[:5] = True
        lo, hi = self.lo.copy(), self.hi.copy()
        for e in effects:
            if e not in self.col:
                raise ValueError(f"unknown effect {e!r}")
            sh = fx.REGISTRY[e].shared
            if sh is not None:  # the air gap: alpha' may go below 0
                lo[sh.col] = float(self.cfg[sh.lo_key])
            else:
                act[self.col[e]] = True
        for j in np.flatnonzero(~act):
            lo[j] = hi[j] = self.null[j]
        for a in (act, lo, hi):
            a.setflags(write=False)
        return act, lo, hi

    def embed(self, u, effects) -> np.ndarray:
        """Coordinates of J-A + ``effects`` from any fit's coordinates: new effects start null, dropped
        ones are set null, alpha' is clipped into the model's range."""
        return self.embed_rows(np.asarray(u, dtype=float)[None, :], effects)[0]

    def embed_rows(self, U, effects) -> np.ndarray:
        """:meth:`embed` of every row of U (n, len(cols)) into the one model ``effects``."""
        act, lo, hi = self.spec(effects)
        W = np.array(U, dtype=float)
        W[:, ~act] = self.null[~act]
        W[:, act] = np.clip(W[:, act], lo[act] + 1e-9 * (hi[act] - lo[act]), hi[act] - 1e-9 * (hi[act] - lo[act]))
        return W

    def ja_sets(self, U) -> np.ndarray:
        """J-A sets (n, 5) of coordinate rows U (a reference-mode problem maps them its own way)."""
        return ja_sets(U)

    def ja_params(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        return np.array([math.exp(u[0]), math.exp(u[1]), u[2], u[3], math.exp(u[4])])

    def physical(self, u, effects) -> tuple[dict, dict]:
        """({Ms, a, alpha, c, k}, {effect: {contract parameter: value}})."""
        ja_d = ja.as_param_dict(self.ja_params(u))
        eff = {}
        for e in effects:
            eff[e] = {fx.REGISTRY[e].param: self.to_contract(e, u)}
            sh = fx.REGISTRY[e].shared
            if sh is not None:
                ja_d[JA_NAMES[sh.col]] = sh.ja_value(float(u[sh.col]))
        return ja_d, eff

    def forward_params(self, u, effects) -> tuple[np.ndarray, dict]:
        """(J-A set, {effect: {parameter: value}}) that :func:`mrhyst.model.effects.forward` runs for a fit: the
        J-A set of the coordinates themselves (a shared-coordinate effect is in them: the air gap's alpha'), the
        other effects at their contract sizes."""
        eff = {e: {fx.REGISTRY[e].param: self.to_contract(e, u)} for e in effects if fx.REGISTRY[e].shared is None}
        return self.ja_params(u), eff

    def to_contract(self, e: str, u) -> float:
        x = float(u[self.col[e]])
        sh = fx.REGISTRY[e].shared
        if sh is not None:  # the air gap: the smallest Nd that explains alpha' (alpha = 0)
            return sh.size(x)
        return x * fx.REGISTRY[e].unit(self.ctx)

    def contract_slope(self, e: str, u) -> float:
        """d(contract parameter)/d(coordinate), to carry a standard error over."""
        x = float(u[self.col[e]])
        sh = fx.REGISTRY[e].shared
        if sh is not None:
            return sh.slope(x)
        return fx.REGISTRY[e].unit(self.ctx)

    # ---- forward ----
    def forward(self, U, substeps: int | None = None):
        """Observed B (T), shape (n, m), and ok (n,) for coordinates U (n, len(cols))."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        P = self.ja_sets(U)
        eff = {}
        used = np.any(U[:, 5:] != self.null[5:], axis=0)
        for e in self.coord_effects:  # only the effects some row uses (the others are identities)
            if used[self.col[e.name] - 5]:
                eff[e.name] = {e.param: U[:, self.col[e.name]] * e.unit(self.ctx)}
        self.n_evals += U.shape[0]
        steps = int(substeps or self.substeps)
        if steps not in self._runs:  # the sweep's integration, checked once (fx.forward's bytes, its checks once)
            self._runs[steps] = ja.prepared(self.sw.current, self.sw.n_over_le, form=self.form, substeps=steps,
                                            dman=self.dman)
        names = tuple(eff)
        if names not in self._orders:
            self._orders[names] = fx.ordered(fx.normalise(eff))
        return fx.apply(self._runs[steps], P, self.sw.M0, self.sw.time, eff, self._orders[names])

    def resid(self, U, W):
        """Weighted residuals (mT) of the rows U, NaN rows where no valid model."""
        B, ok = self.forward(U)
        r = (B * 1e3 - self.Bobs_mT[None, :]) * W
        r[~ok] = np.nan
        return r

    def cost(self, U, W) -> tuple[np.ndarray, np.ndarray]:
        """(cost in mT^2 (inf where invalid), B) of the rows U."""
        B, ok = self.forward(U)
        with np.errstate(invalid="ignore", over="ignore"):
            r = (B * 1e3 - self.Bobs_mT[None, :]) * W
            c = np.einsum("ij,ij->i", r, r)
        c[~ok | ~np.isfinite(c)] = np.inf
        return c, B

    # ---- the batched LM (mrhyst.fit.lm) ----
    def lm(self, U0, effects_rows, W, max_iter: int | None = None, ftol: float = LM_FTOL) -> list[Fit]:
        """Minimise sum((B - B_obs)^2 W) for every row from its start, all rows in lock-step.

        ``effects_rows``: the model (tuple of effects) of each row; ``W``: (rows, samples) 0/1 weights
        (or one row for all). Returns one Fit per row."""
        U0 = np.atleast_2d(np.asarray(U0, dtype=float))
        N = U0.shape[0]
        W = np.broadcast_to(np.asarray(W, dtype=float), (N, self.sw.n)).copy()
        D = len(self.cols)
        act, lo, hi, U = np.empty((N, D), dtype=bool), np.empty((N, D)), np.empty((N, D)), np.empty((N, D))
        keys = [tuple(e) for e in effects_rows]
        for key in dict.fromkeys(keys):  # each model's rows at once
            rows = [i for i, k in enumerate(keys) if k == key]
            act[rows], lo[rows], hi[rows] = self.spec(key)
            U[rows] = self.embed_rows(U0[rows], key)
        res = least_squares_batch(lambda X, rows: self.resid(X, W[rows]), U, bounds=(lo, hi), mask=act,
                                  diff_step=self.steps, max_iter=int(max_iter or self.cfg["max_iter"]),
                                  ftol=ftol, lam_max=LM_LAMBDA_MAX)
        cost, B = self.cost(res.x, W)
        return [Fit(tuple(effects_rows[i]), res.x[i].copy(), float(cost[i]) * 1e-6 if np.isfinite(cost[i])
                    else math.inf, int((W[i] > 0).sum()), bool(np.isfinite(cost[i])), B[i], int(res.nit[i]),
                    bool(res.converged[i])) for i in range(N)]

    def jacobian(self, fit: Fit, W) -> np.ndarray:
        """d(residual, mT)/d(free coordinate) at a fit, columns in coordinate order of the free ones."""
        act, lo, hi = self.spec(fit.effects)
        jj = np.flatnonzero(act)
        h = self.steps[jj].copy()
        out = fit.u[jj] + h > hi[jj]
        h[out] = -h[out]
        U = np.repeat(fit.u[None, :], jj.size + 1, axis=0)
        U[np.arange(1, jj.size + 1), jj] += h
        B, ok = self.forward(U)
        m = np.asarray(W, dtype=float) > 0
        J = (B[1:, m] - B[0, m]) * 1e3 / h[:, None]
        J[~ok[1:]] = 0.0
        return J.T
