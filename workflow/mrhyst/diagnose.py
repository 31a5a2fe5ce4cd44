"""Diagnosis of a raw sweep: where the J-A fit misses, which unmodelled effect causes it, how far it shrinks.

Input: one raw sweep (ARCHITECTURE 4) and one of its Hall channels. Output: the ``DIAG.json`` of the
``mrhyst diagnose`` contract, ``{"effect", "ambiguous_with", "rms_before_T", "rms_after_T",
"noise_floor_T", "where", "candidates", ...}`` (:func:`diagnose_file`; :func:`diagnose` for a Sweep).

1. **Where.** Plain J-A (physical form, alpha >= 0 unless the user asks otherwise) is fitted from
   several starts (the best of a batch of random parameter sets, evaluated in one vectorised J-A call)
   by a batched Levenberg-Marquardt with geodesic acceleration (:meth:`Problem.lm`: every start of
   every model in lock-step, one J-A call per step for all of them). Along the loop the squared
   residual is split into regions: ascending low / mid / high current, the turning point,
   descending high / mid / low, and the 0 A remanence point at the end. Along the chain a *gap budget*
   splits the RMS in quadrature into the sensor noise floor (estimated from the data: robust RMS of the
   residual's second differences along each branch, which a smooth misfit hardly reaches), the RK4
   integration error (``substeps`` vs ``ref_substeps``), the optimizer's shortfall (this seed's fit vs
   the best of ``budget_seeds`` seeds) and the model-form remainder.
2. **Which.** Each effect of :mod:`mrhyst.effects` is added to the model in turn and refitted (warm
   starts from the plain fit with data-derived starts for the effect's parameter; when an effect is
   present, the leading candidates are also started from each other's fits; when structure is left,
   a deeper search from random starts). An effect *earns its parameters* when BIC = n ln(RSS/n) + p ln n
   drops by more than ``bic_margin`` AND its interleaved K-fold cross-validation error is below plain
   J-A's. The earner with the lowest BIC is named; earners within ``tie_margin`` of it are
   ``ambiguous_with`` it, with the reason. No earner: ``none`` when plain J-A is within
   ``unexplained_factor`` of the noise floor, ``unexplained`` otherwise (also when the best candidate,
   with a second effect, removes less than ``explained_min`` of the excess: kept as ``partial``). A
   second effect on top of the named one is tried and reported as ``secondary`` when it earns its
   parameter too.
3. **How far.** RMS before/after (T), the fraction of the excess over the noise floor removed, the
   same on held-out data (interleaved and contiguous-block K-fold CV; and the branch hold-out: fit the
   ascending branch and the turning point, predict the descending branch), and the fitted size of the
   effect with a standard error from the Jacobian at the optimum.

The ``air_gap`` is exactly a shift of alpha (ARCHITECTURE 5): its augmentation lets the effective
alpha' = (alpha - Nd)/(1 - Nd) go below 0, and the size reported is the smallest Nd that explains it
(alpha = 0): Nd = -alpha' / (1 - alpha').

Only the paper's protocol is supported: one monotone ascent of the current followed by one
monotone descent (0 -> max -> 0; repeated currents allowed). Anything else is a one-line InputError.
Everything is deterministic for a given seed.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import effects as fx
from . import ja
from .io import InputError, raw_to_loop, read_raw, write_json

MU0 = ja.MU0
JA_NAMES = ja.PARAM_NAMES
CANDIDATES = tuple(e for e in fx.MODELLED if e != "none")  # the augmentations refitted
REGIONS = ("asc_low", "asc_mid", "asc_high", "turning", "desc_high", "desc_mid", "desc_low", "remanence")

# Defaults for every choice; config.yaml `diagnose:` mirrors them (tests/test_diagnose.py checks they agree)
# and the workflow passes that section. The reasons are in config.yaml next to each key.
DEFAULTS: dict = {
    "form": "physical",
    "dman": "total",
    "substeps": 2,
    "ref_substeps": 16,
    "box": {"Ms": [1.0e3, 1.0e8], "a": [1.0e1, 1.0e7], "alpha": [0.0, 0.2], "c": [0.0, 0.99], "k": [1.0, 1.0e7]},
    "alpha_eff_min": -0.3,
    "start_box": {"Ms": [1.0e5, 5.0e6], "a": [1.0e3, 3.0e5], "alpha": [0.0, 2.0e-2], "c": [0.0, 0.95],
                  "k": [1.0e2, 1.0e5]},
    "n_random": 1500,
    "n_random_deep": 500,
    "n_starts": 4,
    "max_iter": 200,
    "budget_seeds": 2,
    "bic_margin": 10.0,
    "tie_margin": 6.0,
    "cv_folds": 5,
    "cv_max_candidates": 3,
    "unexplained_factor": 2.0,
    "secondary_factor": 1.1,
    "explained_min": 0.5,
    "noise_clip": 3.5,
    "rss_floor_T": 1.0e-7,
    "regions": {"low_frac": 0.333333, "high_frac": 0.666667, "zero_tol_frac": 0.01},
    "min_samples": 12,
    "min_per_branch": 4,
    "series": True,
}

def resolve_config(config: dict | None = None) -> dict:
    """DEFAULTS overridden key by key by ``config`` (the `diagnose:` section)."""
    cfg = copy.deepcopy(DEFAULTS)
    for k, v in (config or {}).items():
        if k not in cfg:
            raise InputError(f"diagnose config: unknown key {k!r} (known: {', '.join(sorted(cfg))})")
        if isinstance(v, dict) and isinstance(cfg[k], dict):
            cfg[k].update(copy.deepcopy(v))
        else:
            cfg[k] = copy.deepcopy(v)
    return cfg


# --------------------------------------------------------------------------------------------
# the sweep
# --------------------------------------------------------------------------------------------
@dataclass
class Sweep:
    """One Hall channel of a raw sweep, checked for the 0 -> max -> 0 protocol."""

    source: str
    sensor: str
    current: np.ndarray
    time: np.ndarray
    B: np.ndarray
    valid: np.ndarray
    n_over_le: float
    region: np.ndarray = field(default=None)
    peak_first: int = 0
    peak_last: int = 0

    @property
    def n(self) -> int:
        return int(self.B.size)


def check_protocol(current, source: str = "sweep") -> tuple[int, int]:
    """(first, last) index of the turning point; InputError unless one ascent then one descent."""
    cur = np.asarray(current, dtype=float)
    d = np.sign(np.diff(cur))
    nz = d[d != 0]
    if nz.size == 0:
        raise InputError(f"{source}: the current never changes; diagnose needs the 0 -> max -> 0 protocol")
    if nz[0] < 0:
        raise InputError(f"{source}: the current first falls; diagnose supports only the paper's protocol "
                         f"(one ascent then one descent, 0 -> max -> 0)")
    reversals = int(np.sum(nz[1:] != nz[:-1]))
    if reversals == 0:
        raise InputError(f"{source}: the current only rises (no descending branch); diagnose supports only the "
                         f"paper's protocol (one ascent then one descent, 0 -> max -> 0)")
    if reversals > 1:
        raise InputError(f"{source}: the current path reverses {reversals} times; diagnose supports only the "
                         f"paper's protocol (one ascent then one descent, 0 -> max -> 0)")
    imax = cur.max()
    at = np.flatnonzero(cur == imax)
    if not imax > 0:
        raise InputError(f"{source}: the largest current is {imax:g} A; expected a positive turning point")
    return int(at[0]), int(at[-1])


def region_labels(current, peak_first: int, peak_last: int, cfg: dict) -> np.ndarray:
    """Region of each sample (REGIONS) from its branch and |I| / I_max."""
    cur = np.asarray(current, dtype=float)
    rc = cfg["regions"]
    imax = float(cur[peak_first])
    frac = cur / imax
    lab = np.empty(cur.size, dtype=object)
    for j in range(cur.size):
        if peak_first <= j <= peak_last:
            lab[j] = "turning"
            continue
        side = "asc" if j < peak_first else "desc"
        f = frac[j]
        lab[j] = f"{side}_low" if f < rc["low_frac"] else (f"{side}_mid" if f < rc["high_frac"] else f"{side}_high")
    if cur.size - 1 > peak_last and abs(cur[-1]) <= rc["zero_tol_frac"] * imax:
        lab[-1] = "remanence"
    return lab


def sweep_from_arrays(current, time_s, B, n_over_le: float, valid=None, cfg: dict | None = None,
                      source: str = "arrays", sensor: str = "B") -> Sweep:
    """A Sweep from arrays (tests, the blind key's detectability check); protocol checked as for a file."""
    cfg = resolve_config(cfg) if cfg is None or "box" not in cfg else cfg
    cur = np.asarray(current, dtype=float)
    pf, pl = check_protocol(cur, source)
    valid = np.ones(cur.size, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    sw = Sweep(source, sensor, cur, np.asarray(time_s, dtype=float), np.asarray(B, dtype=float), valid,
               float(n_over_le), peak_first=pf, peak_last=pl)
    sw.region = region_labels(cur, pf, pl, cfg)
    return sw


def load_sweep(raw_path, sensor: str, cfg: dict | None = None) -> Sweep:
    """Read a raw sweep, convert one channel, check the protocol and the sample count."""
    cfg = resolve_config(cfg) if cfg is None or "box" not in cfg else cfg
    raw = read_raw(raw_path)
    loop = raw_to_loop(raw, sensor)
    src = str(raw_path)
    pf, pl = check_protocol(raw.current_A, src)
    valid = np.ones(len(loop), dtype=bool)
    if "saturated" in loop:
        valid = ~loop["saturated"].to_numpy().astype(bool)
    nv = int(valid.sum())
    n_up, n_down = int(valid[: pf + 1].sum()), int(valid[pl:].sum())
    need, per = int(cfg["min_samples"]), int(cfg["min_per_branch"])
    if nv < need or n_up < per or n_down < per:
        raise InputError(f"{src}: {nv} usable samples ({n_up} ascending, {n_down} descending, turning point "
                         f"included); diagnose needs at least {need} with {per} per branch to split the loop "
                         f"into regions")
    sw = Sweep(src, sensor, raw.current_A.astype(float), raw.time_s.astype(float),
               loop["B_T"].to_numpy(dtype=float), valid, float(raw.coil_turns_per_m), peak_first=pf, peak_last=pl)
    sw.region = region_labels(sw.current, pf, pl, cfg)
    return sw


# --------------------------------------------------------------------------------------------
# J-A plus effects, batched, and a batched Levenberg-Marquardt
# --------------------------------------------------------------------------------------------
# Every model lives in one coordinate space; a model is the set of coordinates it frees. Internal units
# keep the problem scaled: offsets, the remanent start (as mu0 M0) and B_sat in mT, the drift as mT over
# the whole sweep. The air gap frees no new coordinate: it lets alpha' (column 2) go below 0.
COLS = ("ln_Ms", "ln_a", "alpha", "c", "ln_k", "offset_mT", "B0_mT", "lag", "drift_mT", "Bsat_mT")
EFFECT_COL = {"hall_offset": 5, "remanent_start": 6, "eddy_lag": 7, "thermal_drift": 8,
              "sensor_saturation": 9, "air_gap": 2}
CONTRACT_PARAM = {"hall_offset": "offset_T", "remanent_start": "M0_A_per_m", "eddy_lag": "lag",
                  "thermal_drift": "drift_T_per_s", "sensor_saturation": "B_sat_T", "air_gap": "Nd"}
BSAT_OFF = 1.0e12  # B_sat (mT) that never clips: the saturation coordinate of a model without it
_STEPS = np.array([1e-7, 1e-7, 1e-9, 1e-7, 1e-7, 1e-6, 1e-6, 1e-7, 1e-6, 1e-6])  # forward-difference steps
LM_FTOL = 1e-9  # a row stops when an accepted step lowers its cost by less than this fraction
LM_LAMBDA_MAX = 1e10


def n_params(effects) -> int:
    """Parameters of J-A plus effects, as BIC counts them (the air gap's Nd counts as one)."""
    return 5 + len(tuple(effects))


@dataclass
class Fit:
    effects: tuple
    u: np.ndarray  # coordinates (COLS)
    rss: float  # T^2 over the fitted samples
    n: int  # fitted samples
    ok: bool
    B: np.ndarray  # model B at every sample (T)
    iters: int = 0  # LM iterations taken
    converged: bool = True  # stopped by the cost tolerance (not by max_iter)

    @property
    def rms(self) -> float:
        return math.sqrt(self.rss / self.n) if self.ok else math.inf


class Problem:
    """One sweep's fitting problem: bounds, the batched forward model and the batched LM."""

    def __init__(self, sweep: Sweep, cfg: dict, form: str = "physical"):
        self.sw = sweep
        self.cfg = cfg
        self.form = form
        self.dman = cfg["dman"]
        self.substeps = int(cfg["substeps"])
        Bv = sweep.B[sweep.valid]
        self.span_mT = max(float(np.ptp(Bv)), float(np.max(np.abs(Bv))), 1e-6) * 1e3
        self.dt = float(sweep.time[-1] - sweep.time[0])
        self.t_rel = (sweep.time - sweep.time[0]) / self.dt if self.dt > 0 else np.zeros(sweep.n)
        box = cfg["box"]
        span = self.span_mT
        self.lo = np.array([math.log(box["Ms"][0]), math.log(box["a"][0]), box["alpha"][0], box["c"][0],
                            math.log(box["k"][0]), -10 * span, -10 * span, 0.0, -10 * span,
                            float(np.min(Bv)) * 1e3 - span])
        self.hi = np.array([math.log(box["Ms"][1]), math.log(box["a"][1]), box["alpha"][1], box["c"][1],
                            math.log(box["k"][1]), 10 * span, 10 * span, 0.95, 10 * span,
                            float(np.max(Bv)) * 1e3 + span])
        self.null = np.array([0.0] * 9 + [BSAT_OFF])
        self.Bobs_mT = sweep.B * 1e3
        self.n_evals = 0

    # ---- models ----
    def spec(self, effects) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(free coordinates, lower, upper) of J-A + ``effects``."""
        act = np.zeros(len(COLS), dtype=bool)
        act[:5] = True
        lo, hi = self.lo.copy(), self.hi.copy()
        for e in effects:
            if e not in EFFECT_COL:
                raise ValueError(f"unknown effect {e!r}")
            if e == "air_gap":
                lo[2] = float(self.cfg["alpha_eff_min"])
            else:
                act[EFFECT_COL[e]] = True
        for j in np.flatnonzero(~act):
            lo[j] = hi[j] = self.null[j]
        return act, lo, hi

    def embed(self, u, effects) -> np.ndarray:
        """Coordinates of J-A + ``effects`` from any fit's coordinates: new effects start null, dropped
        ones are set null, alpha' is clipped into the model's range."""
        act, lo, hi = self.spec(effects)
        w = np.asarray(u, dtype=float).copy()
        w[~act] = self.null[~act]
        w[act] = np.clip(w[act], lo[act] + 1e-9 * (hi[act] - lo[act]), hi[act] - 1e-9 * (hi[act] - lo[act]))
        return w

    def physical(self, u, effects) -> tuple[dict, dict]:
        """({Ms, a, alpha, c, k}, {effect: {contract parameter: value}})."""
        u = np.asarray(u, dtype=float)
        ja_d = ja.as_param_dict([math.exp(u[0]), math.exp(u[1]), u[2], u[3], math.exp(u[4])])
        eff = {}
        for e in effects:
            eff[e] = {CONTRACT_PARAM[e]: self.to_contract(e, u)}
            if e == "air_gap":
                ja_d["alpha"] = max(0.0, float(u[2]))
        return ja_d, eff

    def to_contract(self, e: str, u) -> float:
        x = float(u[EFFECT_COL[e]])
        if e == "air_gap":
            return max(0.0, -x / (1.0 - x))
        if e == "remanent_start":
            return x * 1e-3 / MU0
        if e == "thermal_drift":
            return x * 1e-3 / self.dt
        if e == "eddy_lag":
            return x
        return x * 1e-3  # hall_offset, sensor_saturation

    def contract_slope(self, e: str, u) -> float:
        """d(contract parameter)/d(coordinate), to carry a standard error over."""
        x = float(u[EFFECT_COL[e]])
        return {"air_gap": -1.0 / (1.0 - x) ** 2 if x < 0 else 0.0, "remanent_start": 1e-3 / MU0,
                "thermal_drift": 1e-3 / self.dt if self.dt > 0 else 0.0, "eddy_lag": 1.0}.get(e, 1e-3)

    # ---- forward ----
    def forward(self, U, substeps: int | None = None):
        """Observed B (T), shape (n, m), and ok (n,) for coordinates U (n, len(COLS))."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        P = np.column_stack([np.exp(U[:, 0]), np.exp(U[:, 1]), U[:, 2], U[:, 3], np.exp(U[:, 4])])
        B, ok = ja.simulate(P, self.sw.current, self.sw.n_over_le, form=self.form,
                            substeps=int(substeps or self.substeps), dman=self.dman, M0=U[:, 6] * 1e-3 / MU0)
        self.n_evals += U.shape[0]
        lag = U[:, 7] != 0.0
        if lag.any():  # eddy settling of the flux first, then the Hall zero error, then the output limit
            B[lag] = fx.eddy_filter(B[lag], U[lag, 7])
        B = B + (U[:, 5, None] + U[:, 8, None] * self.t_rel[None, :]) * 1e-3
        sat = U[:, 9] < BSAT_OFF
        if sat.any():
            B[sat] = np.minimum(B[sat], U[sat, 9, None] * 1e-3)
        return B, ok

    def _resid(self, U, W):
        B, ok = self.forward(U)
        with np.errstate(invalid="ignore", over="ignore"):
            r = (B * 1e3 - self.Bobs_mT[None, :]) * W
            cost = np.einsum("ij,ij->i", r, r)
        bad = ~ok | ~np.isfinite(cost)
        cost[bad] = np.inf
        r[bad] = 0.0
        return r, cost, B

    # ---- batched Levenberg-Marquardt ----
    def lm(self, U0, effects_rows, W, max_iter: int | None = None) -> list[Fit]:
        """Minimise sum((B - B_obs)^2 W) for every row from its start, all rows in lock-step.

        ``effects_rows``: the model (tuple of effects) of each row; ``W``: (rows, samples) 0/1 weights
        (or one row for all). Levenberg-Marquardt with geodesic acceleration (Transtrum & Sethna 2012:
        J-A at low field is a "sloppy" model whose cost has long curved valleys, where plain LM
        creeps), Marquardt damping on the running maximum of diag(J'J), bounds by an active set (a
        coordinate at a bound whose gradient points out is frozen for the step), and the
        forward-difference Jacobians of all rows in one batched J-A call. Returns one Fit per row.
        """
        U0 = np.atleast_2d(np.asarray(U0, dtype=float))
        N, D = U0.shape
        W = np.broadcast_to(np.asarray(W, dtype=float), (N, self.sw.n)).copy()
        specs = [self.spec(e) for e in effects_rows]
        act = np.array([s[0] for s in specs])
        lo = np.array([s[1] for s in specs])
        hi = np.array([s[2] for s in specs])
        U = np.array([self.embed(U0[i], effects_rows[i]) for i in range(N)])
        r, cost, _ = self._resid(U, W)
        lam = np.full(N, 1e-3)
        done = ~np.isfinite(cost)
        need = np.ones(N, dtype=bool)
        J = np.zeros((N, self.sw.n, D))
        Dmax = np.zeros((N, D))
        eye = np.eye(D)
        iters = np.zeros(N, dtype=int)
        max_iter = int(max_iter or self.cfg["max_iter"])
        for _ in range(max_iter):
            live = np.flatnonzero(~done)
            iters[live] += 1
            if live.size == 0:
                break
            jrows = [i for i in live if need[i]]
            if jrows:
                pairs = [(i, j) for i in jrows for j in np.flatnonzero(act[i])]
                ii = np.array([p[0] for p in pairs])
                jj = np.array([p[1] for p in pairs])
                h = _STEPS[jj].copy()
                out = U[ii, jj] + h > hi[ii, jj]
                h[out] = -h[out]
                Up = U[ii].copy()
                Up[np.arange(ii.size), jj] += h
                rp, cp, _ = self._resid(Up, W[ii])
                col = (rp - r[ii]) / h[:, None]
                col[~np.isfinite(cp)] = 0.0
                J[jrows] = 0.0
                J[ii, :, jj] = col
                need[jrows] = False
            Jl, rl = J[live], r[live]
            g = np.einsum("nmj,nm->nj", Jl, rl)
            A = np.einsum("nmi,nmj->nij", Jl, Jl)
            Ul, lol, hil = U[live], lo[live], hi[live]
            free = act[live] & ~((Ul <= lol) & (g > 0)) & ~((Ul >= hil) & (g < 0))
            Dmax[live] = np.maximum(Dmax[live], np.einsum("nii->ni", A))
            d = Dmax[live]
            scale = np.where(free, d, 0.0).max(axis=1, keepdims=True) + 1e-300
            M = A + lam[live, None, None] * np.einsum("ni,ij->nij", d + 1e-12 * scale, eye)
            fr = free[:, :, None] & free[:, None, :]
            M = np.where(fr, M, 0.0) + np.einsum("ni,ij->nij", (~free).astype(float), eye)

            vel = _solve(M, g, free)
            # geodesic acceleration: second directional derivative of r along vel, by a finite difference
            hv = 0.1
            Uh = np.clip(Ul + hv * vel, lol, hil)
            rh, ch, _ = self._resid(Uh, W[live])
            rvv = (2.0 / hv) * ((rh - rl) / hv - np.einsum("nmj,nj->nm", Jl, vel))
            acc = _solve(M, np.einsum("nmj,nm->nj", Jl, rvv), free)
            sq = np.sqrt(d + 1e-300)
            ratio = np.linalg.norm(acc * sq, axis=1) / (np.linalg.norm(vel * sq, axis=1) + 1e-300)
            use_acc = np.isfinite(ch) & (2.0 * ratio <= 0.75)
            step = vel + np.where(use_acc[:, None], 0.5 * acc, 0.0)
            Un = np.clip(Ul + step, lol, hil)
            rn, cn, _ = self._resid(Un, W[live])
            better = cn < cost[live]
            for k, i in enumerate(live):
                if better[k]:
                    rel = (cost[i] - cn[k]) / cost[i] if cost[i] > 0 else 0.0
                    U[i], r[i], cost[i] = Un[k], rn[k], cn[k]
                    lam[i] = max(lam[i] / 3.0, 1e-12)
                    need[i] = True
                    if rel < LM_FTOL or cost[i] == 0.0:
                        done[i] = True
                else:
                    lam[i] *= 2.0
                    if lam[i] > LM_LAMBDA_MAX:
                        done[i] = True
        _, cost, B = self._resid(U, W)
        fits = []
        for i in range(N):
            m = W[i] > 0
            ok = bool(np.isfinite(cost[i]))
            fits.append(Fit(tuple(effects_rows[i]), U[i].copy(), float(cost[i]) * 1e-6 if ok else math.inf,
                            int(m.sum()), ok, B[i], int(iters[i]), bool(done[i])))
        return fits

    def jacobian(self, fit: Fit, W) -> np.ndarray:
        """d(residual, mT)/d(free coordinate) at a fit, columns in COLS order of the free coordinates."""
        act, lo, hi = self.spec(fit.effects)
        jj = np.flatnonzero(act)
        h = _STEPS[jj].copy()
        out = fit.u[jj] + h > hi[jj]
        h[out] = -h[out]
        U = np.repeat(fit.u[None, :], jj.size + 1, axis=0)
        U[np.arange(1, jj.size + 1), jj] += h
        B, ok = self.forward(U)
        m = np.asarray(W, dtype=float) > 0
        J = (B[1:, m] - B[0, m]) * 1e3 / h[:, None]
        J[~ok[1:]] = 0.0
        return J.T


def _solve(M, rhs, free) -> np.ndarray:
    """-M^-1 rhs per row, with the frozen coordinates' entries of rhs set to 0."""
    rhs = np.where(free, rhs, 0.0)
    try:
        return -np.linalg.solve(M, rhs[:, :, None])[:, :, 0]
    except np.linalg.LinAlgError:
        return -np.stack([np.linalg.lstsq(M[k], rhs[k], rcond=None)[0] for k in range(M.shape[0])])


def _best(fits):
    return min(fits, key=lambda f: (not f.ok, f.rss))


def random_starts(prob: Problem, mask, seed: int) -> np.ndarray:
    """The n_starts best of n_random J-A parameter sets drawn log-uniformly from start_box (one batched call)."""
    cfg = prob.cfg
    rng = np.random.default_rng([int(seed), 20190111])
    sb = cfg["start_box"]
    n = int(cfg["n_random"])
    U = np.tile(prob.null, (n, 1))
    for j, name in enumerate(JA_NAMES):
        lo, hi = (float(x) for x in sb[name])
        if name in ("alpha", "c"):
            U[:, j] = rng.uniform(lo, hi, n)
        else:
            U[:, j] = rng.uniform(math.log(lo), math.log(hi), n)
    _, cost, _ = prob._resid(U, mask.astype(float))
    order = np.argsort(cost, kind="stable")[: int(cfg["n_starts"])]
    return U[order[np.isfinite(cost[order])]]


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
            out[s] = _best(mine)
    return out


def effect_starts(prob: Problem, e: str, base: Fit, mask) -> list:
    """Start values of effect ``e``'s coordinate from the plain fit and its residual."""
    sw = prob.sw
    v = mask
    r = (sw.B - base.B) * 1e3  # data - plain fit, mT
    first = int(np.flatnonzero(v)[0])
    if e == "hall_offset":
        return [0.0, float(r[first]), float(np.mean(r[v]))]
    if e == "remanent_start":
        return [0.0, float(sw.B[first] * 1e3), float(r[first])]
    if e == "eddy_lag":
        return [0.05, 0.3]
    if e == "thermal_drift":
        A = np.column_stack([np.ones(int(v.sum())), prob.t_rel[v]])
        return [0.0, float(np.linalg.lstsq(A, r[v], rcond=None)[0][1])]
    if e == "sensor_saturation":
        top = np.sort(sw.B[v])[::-1] * 1e3
        return [float(top[0]), float(top[min(2, top.size - 1)])]
    if e == "air_gap":
        return [min(float(base.u[2]), 0.0) + x for x in (-2e-3, -1e-2, -3e-2)]
    return []


def fit_augmented(prob: Problem, models, base, mask=None) -> dict:
    """Fit each model (tuple of effects) from a fit of a sub-model, with data-derived starts for the
    effects that sub-model lacks; all starts of all models in one LM batch. ``base``: one Fit for every
    model, or a list of Fits per model (each a start). Returns {model: best Fit}."""
    mask = prob.sw.valid if mask is None else mask
    rows, eff_rows = [], []
    for i, model in enumerate(models):
        bases = base[i] if isinstance(base, (list, tuple)) else [base]
        for b in bases:
            u0 = prob.embed(b.u, model)
            starts = [u0]
            for e in model:
                if e in b.effects:
                    continue
                for x in effect_starts(prob, e, b, mask):
                    u = u0.copy()
                    u[EFFECT_COL[e]] = x
                    starts.append(prob.embed(u, model))
            for u in starts:
                if not any(np.array_equal(u, w) for w, m in zip(rows, eff_rows) if m == model):
                    rows.append(u)
                    eff_rows.append(model)
    fits = prob.lm(np.array(rows), eff_rows, mask.astype(float))
    return {model: _best([f for f, m in zip(fits, eff_rows) if m == model]) for model in models}


# --------------------------------------------------------------------------------------------
# statistics
# --------------------------------------------------------------------------------------------
def bic(rss: float, n: int, p: int, floor_T: float) -> float:
    return n * math.log(max(rss, n * floor_T**2) / n) + p * math.log(n)


def _trunc_factor(c: float) -> float:
    """E[x^2 | |x| < c] for a standard normal x."""
    phi = math.exp(-0.5 * c * c) / math.sqrt(2 * math.pi)
    return 1.0 - 2.0 * c * phi / math.erf(c / math.sqrt(2))


def noise_floor(resid, sweep: Sweep, clip: float = 3.5) -> float:
    """Sensor noise sigma (T) from the residual's second differences along each branch.

    d2[j] = r[j-1] - 2 r[j] + r[j+1] of white noise has sd sqrt(6) sigma; a smooth model misfit adds
    little to it. A MAD estimate first, then the RMS of the d2 within ``clip`` MAD-sigmas (kinks,
    e.g. where a sensor starts to clip, drop out), corrected for the truncation. Triples that
    straddle the turning point or contain a flagged sample are not used.
    """
    r = np.asarray(resid, dtype=float)
    v = sweep.valid
    d2 = []
    for lo, hi in ((0, sweep.peak_first), (sweep.peak_last, sweep.n - 1)):
        for j in range(lo + 1, hi):
            if v[j - 1] and v[j] and v[j + 1]:
                d2.append(r[j - 1] - 2 * r[j] + r[j + 1])
    d2 = np.asarray(d2)
    if d2.size < 4:
        rv = r[v]
        return float(np.sqrt(np.mean(rv**2)))
    s0 = 1.482602218505602 * float(np.median(np.abs(d2)))
    if s0 == 0.0:
        return 0.0
    keep = np.abs(d2) <= clip * s0
    s = math.sqrt(float(np.mean(d2[keep] ** 2)) / _trunc_factor(clip))
    return s / math.sqrt(6.0)


def region_breakdown(resid, sweep: Sweep) -> dict:
    r = np.asarray(resid, dtype=float)
    v = sweep.valid
    tot = float(np.sum(r[v] ** 2))
    out = {}
    for name in REGIONS:
        m = (sweep.region == name) & v
        k = int(m.sum())
        ss = float(np.sum(r[m] ** 2))
        out[name] = {
            "n": k,
            "share": ss / tot if tot > 0 else 0.0,
            "rms_T": math.sqrt(ss / k) if k else 0.0,
            "mean_T": float(np.mean(r[m])) if k else 0.0,
        }
    return out


def std_errors(prob: Problem, fit: Fit, mask) -> np.ndarray:
    """Standard errors of the free coordinates (COLS order) from the Jacobian at the optimum.

    cov = s^2 (J'J)^-1 with s^2 = RSS / (n - p), through a column-scaled pseudo-inverse (the J-A
    coordinates are strongly correlated at low field; the effect's coordinate usually is not).
    """
    J = prob.jacobian(fit, mask)
    p = J.shape[1]
    s2 = fit.rss * 1e6 / max(fit.n - p, 1)  # mT^2
    norms = np.sqrt(np.sum(J**2, axis=0))
    norms[norms == 0] = 1.0
    Js = J / norms
    cov = np.linalg.pinv(Js.T @ Js, rcond=1e-12, hermitian=True) * s2 / np.outer(norms, norms)
    se = np.full(len(COLS), np.nan)
    se[np.flatnonzero(prob.spec(fit.effects)[0])] = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return se


def folds(sweep: Sweep, K: int, kind: str) -> np.ndarray:
    """Fold of each sample: ``interleaved`` (sample j in fold j mod K) or ``blocks`` (K contiguous blocks
    along the path)."""
    j = np.arange(sweep.n)
    return j % int(K) if kind == "interleaved" else (j * int(K)) // sweep.n


def holdout(prob: Problem, fits: dict, kinds=("interleaved", "blocks", "branch")) -> dict:
    """Held-out errors of every fit in ``fits`` ({name: Fit}), all refits in one LM batch.

    ``interleaved`` / ``blocks``: K-fold cross-validation, each fold predicted from a fit to the
    others (warm start from the full fit); RMS over all held-out samples (T). Interleaved folds test
    whether the extra parameter generalises between neighbouring samples (fair to an effect whose
    evidence is local, like a clipped top); contiguous blocks test extrapolation along the loop (a
    parameter that only the held-out block determines cannot be predicted). ``branch``: fit the
    ascending branch and the turning point, predict the descending branch.
    Returns {name: {"cv_interleaved_T", "cv_blocks_T", "heldout_T"}} (inf when a refit fails).
    """
    sw = prob.sw
    K = int(prob.cfg["cv_folds"])
    masks = []  # (kind, train, test)
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
    rows, effs, W, tags = [], [], [], []
    for name, f in fits.items():
        for kind, train, test in masks:
            rows.append(f.u)
            effs.append(f.effects)
            W.append(train)
            tags.append((name, kind, test))
    res = prob.lm(np.array(rows), effs, np.array(W, dtype=float)) if rows else []
    acc = {(name, kind): [0.0, 0] for name in fits for kind in kinds}
    for (name, kind, test), f in zip(tags, res):
        a = acc[(name, kind)]
        if not f.ok or a[0] == math.inf:
            a[0] = math.inf
            continue
        a[0] += float(np.sum((f.B[test] - sw.B[test]) ** 2))
        a[1] += int(test.sum())
    key = {"interleaved": "cv_interleaved_T", "blocks": "cv_blocks_T", "branch": "heldout_T"}
    return {name: {key[kind]: (math.sqrt(acc[(name, kind)][0] / acc[(name, kind)][1])
                               if acc[(name, kind)][1] and math.isfinite(acc[(name, kind)][0]) else math.inf)
                   for kind in kinds} for name in fits}


def deep_starts(prob: Problem, e: str, seed: int, mask) -> np.ndarray:
    """Starts for J-A + ``e`` away from the plain fit: random J-A sets x a grid of the effect's size
    (one batched call); the n_starts best."""
    cfg = prob.cfg
    rng = np.random.default_rng([int(seed), 20190112, CANDIDATES.index(e)])
    sb = cfg["start_box"]
    n = int(cfg["n_random_deep"])
    J = np.empty((n, 5))
    for j, name in enumerate(JA_NAMES):
        lo, hi = (float(x) for x in sb[name])
        J[:, j] = rng.uniform(lo, hi, n) if name in ("alpha", "c") else rng.uniform(math.log(lo), math.log(hi), n)
    span = prob.span_mT
    grid = {"hall_offset": [-0.2 * span, -0.05 * span, 0.05 * span, 0.2 * span],
            "remanent_start": [-0.3 * span, -0.1 * span, 0.1 * span, 0.3 * span],
            "eddy_lag": [0.1, 0.3, 0.6],
            "thermal_drift": [-0.3 * span, -0.1 * span, 0.1 * span, 0.3 * span],
            "sensor_saturation": [float(np.max(prob.sw.B[mask])) * 1e3],
            "air_gap": [-3e-3, -1e-2, -3e-2]}[e]
    U = np.tile(prob.null, (n * len(grid), 1))
    for g, x in enumerate(grid):
        U[g * n:(g + 1) * n, :5] = J
        U[g * n:(g + 1) * n, EFFECT_COL[e]] = x
    U = np.array([prob.embed(u, (e,)) for u in U])
    _, cost, _ = prob._resid(U, mask.astype(float))
    order = np.argsort(cost, kind="stable")[: int(cfg["n_starts"])]
    return U[order[np.isfinite(cost[order])]]


def _excess(rms, sigma: float):
    if rms is None or not math.isfinite(rms):
        return None
    return math.sqrt(max(rms * rms - sigma * sigma, 0.0))


def _frac(a, b):
    return (a - b) / a if a is not None and b is not None and a > 0 else None


def _finite(x):
    return None if x is None or not math.isfinite(x) else float(x)


# --------------------------------------------------------------------------------------------
# the diagnosis
# --------------------------------------------------------------------------------------------
def _score_candidates(prob: Problem, base: Fit, fits: dict) -> dict:
    """BIC and delta BIC (vs plain J-A) of every fitted candidate."""
    cfg = prob.cfg
    nv = int(prob.sw.valid.sum())
    floor = float(cfg["rss_floor_T"])
    b0 = bic(base.rss, nv, 5, floor)
    out = {}
    for e, f in fits.items():
        b = bic(f.rss, nv, n_params(f.effects), floor)
        ja_d, eff = prob.physical(f.u, f.effects)
        out[e] = {"effect": e, "n_params": n_params(f.effects), "rss_T2": f.rss, "rms_T": f.rms, "bic": b,
                  "delta_bic": b0 - b, "ja_params": ja_d, "params": eff[e], "ok": f.ok}
    return out


def _select(prob: Problem, base: Fit, fits: dict, cands: dict) -> dict:
    """Which candidates earn their parameters, the winner and the ties (see the module docstring)."""
    cfg = prob.cfg
    margin, tie = float(cfg["bic_margin"]), float(cfg["tie_margin"])
    earners = sorted([e for e in cands if cands[e]["delta_bic"] > margin], key=lambda e: -cands[e]["delta_bic"])
    checked = earners[: int(cfg["cv_max_candidates"])]
    ho = holdout(prob, {"none": base, **{e: fits[e] for e in checked}}, kinds=("interleaved",))
    for e in checked:
        cands[e].update(ho[e])
    cv0 = ho["none"]["cv_interleaved_T"]
    for e, c in cands.items():
        if e not in earners:
            c["verdict"] = f"does not earn its parameters (delta BIC {c['delta_bic']:.1f} <= margin {margin:g})"
        elif e not in checked:
            c["verdict"] = "earns its parameters by BIC but is not among the leading ones cross-validated"
        elif not c["cv_interleaved_T"] < cv0:
            c["verdict"] = (f"earns its parameters by BIC but does not predict held-out samples better "
                            f"(interleaved CV RMS {c['cv_interleaved_T'] * 1e3:.4f} mT vs {cv0 * 1e3:.4f} mT plain)")
        else:
            c["verdict"] = "earns its parameters (BIC margin and interleaved cross-validation)"
    passed = [e for e in checked if cands[e]["cv_interleaved_T"] < cv0]
    sel = {"holdout": ho, "passed": passed, "effect": "none", "ambiguous": [], "why": ""}
    if not passed:
        ho["none"].update(holdout(prob, {"none": base}, kinds=("blocks", "branch"))["none"])
        return sel
    # the lowest BIC names the effect; earners within the tie margin of it are ambiguous_with it. (Measured on
    # 85 tied offset / remanent-start rig cases: the lower BIC named the injected one in 60 %, the lower
    # block-CV error in 48 %; the block CV is reported, not used.)
    effect = min(passed, key=lambda e: cands[e]["bic"])
    amb = [e for e in sorted(passed, key=lambda e: cands[e]["bic"])
           if e != effect and cands[e]["bic"] - cands[effect]["bic"] < tie]
    # extrapolation (contiguous blocks) and the branch hold-out, for the reference and what is reported
    more = holdout(prob, {"none": base, **{e: fits[e] for e in [effect, *amb]}}, kinds=("blocks", "branch"))
    for name, h in more.items():
        ho[name].update(h)
        if name in cands:
            cands[name].update(h)
    sel.update(effect=effect, ambiguous=amb, why=_why(cands, effect, amb, tie))
    return sel


def _why(cands: dict, effect: str, amb: list, tie: float) -> str:
    """Why the effects in ``amb`` cannot be told apart from ``effect``."""
    why = "; ".join(
        f"{e} fits almost as well (BIC {cands[e]['bic'] - cands[effect]['bic']:+.1f} vs {effect}, within the tie "
        f"margin {tie:g}; block CV RMS {cands[e].get('cv_blocks_T', math.nan) * 1e3:.4f} vs "
        f"{cands[effect].get('cv_blocks_T', math.nan) * 1e3:.4f} mT)" for e in amb)
    if amb and {"hall_offset", "remanent_start"} <= set(amb) | {effect}:
        why += ("; a constant Hall offset and a remanent start both move the 0 A start, and the shape of the "
                "low-field ascending branch does not decide between them here")
    return why


def diagnose(sweep: Sweep, config: dict | None = None, *, form: str | None = None, seed: int = 0,
             ja_fit: dict | None = None) -> dict:
    """The diagnosis of one channel (a JSON-ready dict; see the module docstring).

    ``ja_fit``: optional J-A parameters {Ms, a, alpha, c, k} of a fit made elsewhere (e.g. by
    ``mrhyst fit``); it is then "this fit" of the gap budget, the one whose optimizer shortfall is
    measured. Without it, this fit is the multi-start fit of ``seed``.
    """
    cfg = resolve_config(config)
    form = form or cfg["form"]
    if form not in ja.FORMS:
        raise InputError(f"form must be one of {', '.join(ja.FORMS)}, got {form!r}")
    prob = Problem(sweep, cfg, form)
    v = sweep.valid
    nv = int(v.sum())
    floor = float(cfg["rss_floor_T"])
    margin, factor = float(cfg["bic_margin"]), float(cfg["unexplained_factor"])

    # ---- plain J-A: this fit (seed), other seeds, the best ----
    seeds = [int(seed) + s for s in range(max(int(cfg["budget_seeds"]), 1))]
    by_seed = fit_plain(prob, seeds)
    this = by_seed.get(int(seed)) or _best(list(by_seed.values()))
    this_src = f"multi-start least squares, seed {seed}"
    plain = list(by_seed.values())
    if ja_fit is not None:
        u = prob.null.copy()
        u[:5] = [math.log(ja_fit["Ms"]), math.log(ja_fit["a"]), ja_fit["alpha"], ja_fit["c"], math.log(ja_fit["k"])]
        _, c, Bt = prob._resid(u[None, :], v.astype(float))
        this = Fit((), u, float(c[0]) * 1e-6, nv, bool(np.isfinite(c[0])), Bt[0])
        this_src = "given fit"
        plain += prob.lm(u[None, :], [()], v.astype(float))
    base = _best(plain)

    # ---- every candidate effect, refitted from the plain fit ----
    cands_e = [e for e in CANDIDATES if not (e == "thermal_drift" and not prob.dt > 0)]
    fits = {e: f for (e,), f in fit_augmented(prob, [(e,) for e in cands_e], base).items()}

    def polish(base, fits):
        """Plain J-A refitted from the leading candidates' J-A part: no candidate may win only because
        it found a better J-A optimum than the plain multi-start did."""
        lead = sorted(fits, key=lambda e: fits[e].rss)[: int(cfg["cv_max_candidates"])]
        pol = _best(prob.lm(np.array([prob.embed(fits[e].u, ()) for e in lead]), [()] * len(lead), v.astype(float)))
        if pol.ok and pol.rss < base.rss * (1 - 1e-9):
            base = pol
            worse = [e for e in fits if fits[e].rss > base.rss]
            if worse:
                fits.update({e: f for (e,), f in fit_augmented(prob, [(e,) for e in worse], base).items()})
        return base

    base = polish(base, fits)
    cands = _score_candidates(prob, base, fits)
    if max(c["delta_bic"] for c in cands.values()) > margin:
        # cross-seeding: when an effect is present, every leading candidate is refitted from the J-A part of
        # the others (two effects that explain a loop alike, e.g. an offset and a remanent start, then reach
        # the same quality instead of one of them stopping in a poorer local minimum)
        lead = sorted(fits, key=lambda e: fits[e].rss)[: int(cfg["cv_max_candidates"])]
        cross = fit_augmented(prob, [(e,) for e in lead], [[fits[f] for f in lead if f != e] for e in lead])
        for (e,), f in cross.items():
            if f.ok and f.rss < fits[e].rss:
                fits[e] = f
        cands = _score_candidates(prob, base, fits)
    sigma = noise_floor(sweep.B - base.B, sweep, float(cfg["noise_clip"]))
    sel = _select(prob, base, fits, cands)
    escalated = False
    final = fits[sel["effect"]] if sel["effect"] in fits else base
    if final.rms > factor * sigma:
        # structure left: search every candidate again from random J-A starts with a grid of effect sizes
        escalated = True
        rows, effs = [], []
        for e in fits:
            st = deep_starts(prob, e, seed, v)
            rows += list(st)
            effs += [(e,)] * len(st)
        deep = prob.lm(np.array(rows), effs, v.astype(float))
        changed = False
        for e in fits:
            f = _best([d for d, m in zip(deep, effs) if m == (e,)] + [fits[e]])
            changed |= f is not fits[e]
            fits[e] = f
        if changed:
            base = polish(base, fits)
            sigma = noise_floor(sweep.B - base.B, sweep, float(cfg["noise_clip"]))
            cands = _score_candidates(prob, base, fits)
            sel = _select(prob, base, fits, cands)
    ho = sel["holdout"]
    effect, ambiguous, why, note = sel["effect"], sel["ambiguous"], sel["why"], ""
    after = fits[effect] if effect in fits else base
    b0 = bic(base.rss, nv, 5, floor)
    rms_before, rms_after = base.rms, after.rms
    ex0, ex1 = _excess(rms_before, sigma), _excess(rms_after, sigma)
    # ---- a second effect on top of the winner (a sweep may carry more than one) ----
    # Pairs are tried with the named effect and with every effect tied with it; when the best pair is built on
    # a tied one, that one is named (the fuller model decides among the tied), the others stay ambiguous_with.
    secondary, pair_fit = None, None
    if effect in fits and rms_after > float(cfg["secondary_factor"]) * sigma:
        b1 = bic(after.rss, nv, n_params(after.effects), floor)
        prim = [effect, *ambiguous]
        models = [(p, e2) for p in prim for e2 in fits if e2 not in prim]
        models += [(effect, e2) for e2 in ambiguous]
        f2s = fit_augmented(prob, models, [[fits[m[0]], fits[m[1]]] for m in models])
        gains = {m: b1 - bic(f.rss, nv, n_params(m), floor) for m, f in f2s.items()}
        m2 = max(gains, key=gains.get)
        if gains[m2] > margin:
            f2 = f2s[m2]
            if m2[0] != effect:
                best_with = {p: max(g for m, g in gains.items() if m[0] == p and m[1] == m2[1]) for p in prim
                             if (p, m2[1]) in gains}
                ambiguous = [effect] + [e for e in ambiguous if e != m2[0]]
                note_swap = (f"; with {m2[1]} added, {m2[0]} + {m2[1]} fits better than {effect} + {m2[1]} "
                             f"(BIC {best_with[m2[0]] - best_with.get(effect, math.nan):.1f} lower), so {m2[0]} is "
                             f"named")
                effect = m2[0]
                why = _why(cands, effect, ambiguous, float(cfg["tie_margin"])) + note_swap
                after = fits[effect]
                rms_after = after.rms
                ex1 = _excess(rms_after, sigma)
                b1 = bic(after.rss, nv, n_params(after.effects), floor)
            h2 = holdout(prob, {"pair": f2}, kinds=("interleaved", "branch"))["pair"]
            _, eff2 = prob.physical(f2.u, f2.effects)
            secondary = {"effect": m2[1], "delta_bic_over_primary": b1 - bic(f2.rss, nv, n_params(m2), floor),
                         "rms_after_T": f2.rms, "cv_interleaved_T": _finite(h2["cv_interleaved_T"]),
                         "heldout_rms_T": _finite(h2["heldout_T"]),
                         "params": eff2[m2[1]], "primary_params": eff2[effect],
                         "accepted": bool(h2["cv_interleaved_T"] < cands[effect]["cv_interleaved_T"])}
            pair_fit = f2 if secondary["accepted"] else None
    final_rms = secondary["rms_after_T"] if secondary and secondary["accepted"] else rms_after

    # ---- none, or unexplained: structure left that no candidate (pair) explains ----
    partial = None
    if effect == "none" and rms_before > factor * sigma:
        effect = "unexplained"
        note = (f"plain J-A leaves {rms_before / sigma:.1f}x the noise floor and no candidate effect earns its "
                f"parameters")
    elif effect != "none" and final_rms > factor * sigma and ex0:
        removed = _frac(ex0, _excess(final_rms, sigma))
        if removed < float(cfg["explained_min"]):
            partial = {"effect": effect, "ambiguous_with": ambiguous, "rms_after_T": rms_after,
                       "excess_removed_frac": removed, "secondary": secondary}
            note = (f"the best candidate, {effect}" + (f" (+ {secondary['effect']})" if secondary and
                                                      secondary["accepted"] else "")
                    + f", earns its parameters but removes only {100 * removed:.0f} % of the excess over the noise "
                    f"floor ({final_rms / sigma:.1f}x the floor left)")
            effect, ambiguous, why, secondary, pair_fit = "unexplained", [], "", None, None
            after, rms_after, ex1 = base, rms_before, ex0
            final_rms = rms_before
    structure_remains = bool(final_rms > factor * sigma)

    # ---- size of the effect with its standard error (from the pair when a second effect is accepted) ----
    def size_of(fit, e):
        se = std_errors(prob, fit, v)
        out = {"param": CONTRACT_PARAM[e], "value": prob.to_contract(e, fit.u),
               "stderr": _finite(abs(prob.contract_slope(e, fit.u)) * float(se[EFFECT_COL[e]]))}
        if e == "air_gap":
            out["note"] = (f"an air gap is exactly a shift of alpha; this is the smallest Nd that explains the "
                           f"fitted alpha' = {float(fit.u[2]):.4g} (with alpha = 0)")
        return out

    size = size_alone = None
    if effect in fits:
        size = size_alone = size_of(after, effect)
        if pair_fit is not None:
            size = dict(size_of(pair_fit, effect), fitted_with=secondary["effect"])
            secondary["size"] = size_of(pair_fit, secondary["effect"])

    # ---- how far it shrinks: fitted and held-out ----
    h0 = ho["none"]
    h1 = ho[effect] if effect in ho else h0
    shrink = {
        "excess_before_T": ex0,
        "excess_after_T": ex1,
        "excess_removed_frac": _frac(ex0, ex1),
        "rms_after_over_noise": rms_after / sigma if sigma > 0 else None,
        "heldout_scheme": "fit the ascending branch and the turning point, predict the descending branch",
        "heldout_rms_before_T": _finite(h0["heldout_T"]),
        "heldout_rms_after_T": _finite(h1["heldout_T"]),
        "heldout_excess_removed_frac": _frac(_excess(_finite(h0["heldout_T"]), sigma),
                                             _excess(_finite(h1["heldout_T"]), sigma)),
        "cv_scheme": (f"{int(cfg['cv_folds'])}-fold: interleaved (sample j in fold j mod K) and contiguous blocks "
                      f"along the path; each fold predicted from a fit to the rest"),
        "cv_interleaved_before_T": _finite(h0["cv_interleaved_T"]),
        "cv_interleaved_after_T": _finite(h1["cv_interleaved_T"]),
        "cv_blocks_before_T": _finite(h0["cv_blocks_T"]),
        "cv_blocks_after_T": _finite(h1["cv_blocks_T"]),
    }
    if pair_fit is not None:  # the same with the accepted second effect
        shrink["with_secondary"] = {
            "effects": list(pair_fit.effects),
            "rms_after_T": pair_fit.rms,
            "excess_removed_frac": _frac(ex0, _excess(pair_fit.rms, sigma)),
            "heldout_rms_after_T": secondary["heldout_rms_T"],
            "heldout_excess_removed_frac": _frac(_excess(_finite(h0["heldout_T"]), sigma),
                                                 _excess(secondary["heldout_rms_T"], sigma)),
        }

    # ---- gap budget along the chain (quadrature) ----
    Bref, okr = prob.forward(base.u[None, :], substeps=int(cfg["ref_substeps"]))
    integ = float(np.sqrt(np.mean((Bref[0, v] - base.B[v]) ** 2))) if okr[0] else None
    this_rms = this.rms if this.ok else None
    short = math.sqrt(max(this_rms**2 - base.rms**2, 0.0)) if this_rms is not None else None
    noise_in_fit = sigma * math.sqrt(max(nv - 5, 1) / nv)
    budget = {
        "this_fit": this_src,
        "rms_this_fit_T": this_rms,
        "rms_best_fit_T": base.rms,
        "seeds": seeds,
        "noise_floor_T": sigma,
        "noise_in_fit_T": noise_in_fit,
        "integration_error_T": integ,
        "optimizer_shortfall_T": short,
        "model_form_T": math.sqrt(max(base.rms**2 - noise_in_fit**2 - (integ or 0.0) ** 2, 0.0)),
        "explained_by_effect_T": math.sqrt(max(rms_before**2 - rms_after**2, 0.0)),
        "note": ("quadrature: rms_this_fit^2 = noise_in_fit^2 + integration^2 + optimizer_shortfall^2 + model_form^2, "
                 "noise_in_fit = noise_floor sqrt((n-5)/n); explained_by_effect is the part of model_form that the "
                 "named effect removes"),
    }

    reg0 = region_breakdown(sweep.B - base.B, sweep)
    reg1 = region_breakdown(sweep.B - after.B, sweep)
    worst = max(REGIONS, key=lambda k: reg0[k]["share"])
    where = {
        "regions": {k: {"n": reg0[k]["n"], "share_before": reg0[k]["share"], "share_after": reg1[k]["share"],
                        "rms_before_T": reg0[k]["rms_T"], "rms_after_T": reg1[k]["rms_T"],
                        "mean_before_T": reg0[k]["mean_T"], "mean_after_T": reg1[k]["mean_T"]} for k in REGIONS},
        "largest_share_before": worst,
        "region_order": list(REGIONS),
        "region_bounds": {"low_below": cfg["regions"]["low_frac"], "high_from": cfg["regions"]["high_frac"],
                          "units": "fraction of the largest current"},
        "budget": budget,
        "saturated_samples": int((~v).sum()),
    }
    cand_list = [{"effect": "none", "n_params": 5, "rss_T2": base.rss, "rms_T": base.rms, "bic": b0,
                  "delta_bic": 0.0, "ja_params": prob.physical(base.u, ())[0], "params": {}, "ok": base.ok,
                  "verdict": "plain J-A (the reference)", **h0}]
    for e in sorted(cands, key=lambda e: cands[e]["bic"]):
        cand_list.append(dict(cands[e]))
    for c in cand_list:
        for k in ("cv_interleaved_T", "cv_blocks_T", "heldout_T"):
            if k in c:
                c[k] = _finite(c[k])

    if effect == "none":
        verdict = (f"none: plain J-A fits to {rms_before * 1e3:.3f} mT, {rms_before / sigma:.2f}x the noise floor "
                   f"({sigma * 1e3:.3f} mT); no candidate effect earns its parameters")
    elif effect == "unexplained":
        verdict = f"unexplained: {note}; the largest share of the gap is in {worst}"
    else:
        verdict = (f"{effect}: RMS {rms_before * 1e3:.3f} -> {rms_after * 1e3:.3f} mT (noise floor "
                   f"{sigma * 1e3:.3f} mT), delta BIC {cands[effect]['delta_bic']:.1f}; the largest share of the gap "
                   f"before is in {worst}")
        if ambiguous:
            verdict += f"; ambiguous with {', '.join(ambiguous)}"
        if secondary and secondary["accepted"]:
            verdict += f"; plus {secondary['effect']} (RMS -> {secondary['rms_after_T'] * 1e3:.3f} mT)"
        if note:
            verdict += f"; {note}"

    ja_after, eff_after = prob.physical(after.u, after.effects)
    out = {
        "effect": effect,
        "ambiguous_with": ambiguous,
        "ambiguity_reason": why,
        "rms_before_T": rms_before,
        "rms_after_T": rms_after,
        "noise_floor_T": sigma,
        "effect_size": size,
        "effect_size_alone": size_alone,
        "secondary": secondary,
        "partial": partial,
        "structure_remains": structure_remains,
        "note": note,
        "verdict": verdict,
        "shrink": shrink,
        "where": where,
        "candidates": cand_list,
        "fit_before": {"ja_params": prob.physical(base.u, ())[0]},
        "fit_after": {"ja_params": ja_after, "effect_params": eff_after},
        "search": {"escalated": escalated, "model_evaluations": int(prob.n_evals)},
        "input": {"raw": sweep.source, "sensor": sweep.sensor, "n_samples": sweep.n, "n_valid": nv,
                  "n_over_le": sweep.n_over_le, "form": form, "seed": int(seed),
                  "protocol": "0 -> max -> 0 (one ascent, one descent)"},
        "settings": {k: cfg[k] for k in sorted(cfg) if k != "series"},
    }
    if cfg.get("series", True):
        out["series"] = {
            "current_A": sweep.current, "time_s": sweep.time, "B_T": sweep.B, "valid": sweep.valid.astype(int),
            "region": [str(x) for x in sweep.region], "B_before_T": base.B, "B_after_T": after.B,
            "B_with_secondary_T": pair_fit.B if pair_fit is not None else None,
        }
    return out


def diagnose_file(raw_path, sensor: str, out=None, form: str = "physical", seed: int = 0,
                  config: dict | None = None, ja_fit: dict | None = None) -> dict:
    """``mrhyst diagnose RAW.csv --sensor S --out DIAG.json``: read, diagnose, write (atomic)."""
    cfg = resolve_config(config)
    sweep = load_sweep(raw_path, sensor, cfg)
    d = diagnose(sweep, cfg, form=form, seed=seed, ja_fit=ja_fit)
    if out is not None:
        write_json(d, Path(out))
    return d
