"""One material at several temperatures: J-A parameters as smooth laws of the temperature (issue 24, point 3).

``mrhyst fit FILE.csv --loop-index all --temperature-laws --method lsm --out FIT.json`` on a B(H) file whose
loops carry a ``temperature_C`` column (one temperature per loop). The laws (config ``temperature_laws``):

    Ms(T) = Ms0 (1 - T_K / Tc)^beta                          critical power law below the Curie point Tc
    log a(t), log k(t)  polynomials of degree d_a, d_k in t   (t in degrees C; a, k > 0 at every t)
    c(t), alpha(t)      polynomials of degree d_c, d_alpha    (c clipped to [0, c_max], alpha to >= 0)

Each polynomial is given by its values at d + 1 *anchor* temperatures spread evenly over the loops' range
(Lagrange form): these values are the fit's coordinates, so every coordinate has a physical box (the default
J-A box) and a standard error in the parameter's own unit. The fit is the project's LSM (scipy least_squares,
batched J-A residuals with the Jacobian's points prefetched, mrhyst.fit.lsq) over all loops jointly
(:class:`TempLawProblem` is a :class:`mrhyst.fit.joint.JointProblem` whose loops get their parameters
from the laws), from the best of several starts: the laws fitted to each loop's own fit (stage A, as the
published gadolinium analysis, github.com/romanszewczyk/Gd, seeds its global fit) and each loop's own fit
held constant over the temperature. Standard errors come from the Jacobian at the solution,
sqrt(diag(s^2 (J^T J)^-1)) with s^2 the residual variance, widened by sqrt((1 + rho) / (1 - rho)) for the
residuals' lag-1 autocorrelation rho along each loop (model form makes them smooth on every real loop; without
the widening the stderr understated the withheld Gd temperature's miss ~20x). Still approximate: AR(1) is a
model of the correlation, not the correlation.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from mrhyst.data.io import InputError, Loop, json_number, read_loops
from mrhyst.fit.accuracy import correlation_factor
from mrhyst.fit.box import Box, default_box
from mrhyst.fit.joint import JointProblem
from mrhyst.fit.settings import JA_NAMES, resolve_config
from mrhyst.settings import frozen

K0 = 273.15
LAW_PARAMS = ("a", "k", "c", "alpha")
LOG_LAWS = ("a", "k")
MS_NAMES = ("Ms0", "Tc_K", "beta")


def law_config(config=None):
    """The temperature_laws section: schema defaults under a config mapping or config.yaml path, frozen."""
    return frozen(config, "temperature_laws")


class Laws:
    """The laws' shape: each parameter's anchor temperatures (degrees C); coordinates are MS_NAMES then the
    anchors' values, parameter by parameter (LAW_PARAMS order)."""

    def __init__(self, degree: dict, t_range, c_max: float = 0.999):
        lo, hi = float(min(t_range)), float(max(t_range))
        self.degree = {p: int(degree[p]) for p in LAW_PARAMS}
        self.anchors = {p: (np.array([0.5 * (lo + hi)]) if d == 0 else np.linspace(lo, hi, d + 1))
                        for p, d in self.degree.items()}
        self.c_max = float(c_max)
        self.names = MS_NAMES + tuple(f"{p}@{t:g}C" for p in LAW_PARAMS for t in self.anchors[p])
        self.slices, i = {}, len(MS_NAMES)
        for p in LAW_PARAMS:
            self.slices[p] = slice(i, i + self.anchors[p].size)
            i += self.anchors[p].size

    @staticmethod
    def lagrange(anchors: np.ndarray, t: float) -> np.ndarray:
        """Weights w_j(t) of the polynomial through the anchors (sum_j w_j v_j = its value at t)."""
        w = np.ones(anchors.size)
        for j in range(anchors.size):
            for m in range(anchors.size):
                if m != j:
                    w[j] *= (t - anchors[m]) / (anchors[j] - anchors[m])
        return w

    def ms(self, X, t_C) -> np.ndarray:
        X = np.atleast_2d(X)
        red = np.maximum(1.0 - (float(t_C) + K0) / X[:, 1], 1e-12)
        return X[:, 0] * red ** X[:, 2]

    def value(self, X, p: str, t_C) -> np.ndarray:
        X = np.atleast_2d(X)
        w = self.lagrange(self.anchors[p], float(t_C))
        v = X[:, self.slices[p]]
        if p in LOG_LAWS:
            return np.exp(np.log(np.maximum(v, 1e-300)) @ w)
        out = v @ w
        return np.clip(out, 0.0, self.c_max) if p == "c" else np.maximum(out, 0.0)

    def params(self, X, t_C) -> np.ndarray:
        """J-A parameters (n, 5) in ja.PARAM_NAMES order at temperature t_C for every row of X."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        cols = {"Ms": self.ms(X, t_C), **{p: self.value(X, p, t_C) for p in LAW_PARAMS}}
        return np.column_stack([cols[n] for n in JA_NAMES])

    def to_json(self, x, se=None) -> dict:
        x = np.asarray(x, dtype=float)
        se = np.full(x.size, np.nan) if se is None else np.asarray(se, dtype=float)
        out = {"Ms": {"law": "Ms0 * (1 - T_K / Tc_K) ** beta", **{n: float(x[i]) for i, n in enumerate(MS_NAMES)},
                      "stderr": {n: _num(se[i]) for i, n in enumerate(MS_NAMES)}}}
        for p in LAW_PARAMS:
            s = self.slices[p]
            kind = "log-polynomial" if p in LOG_LAWS else "polynomial"
            out[p] = {"law": f"{kind} of degree {self.degree[p]} in t (C) through the anchors",
                      "degree": self.degree[p], "anchors_C": self.anchors[p].tolist(), "values": x[s].tolist(),
                      "stderr": [_num(v) for v in se[s]]}
        return out

    @classmethod
    def from_json(cls, d: dict, c_max: float = 0.999) -> tuple[Laws, np.ndarray]:
        """(laws, coordinates) from a FIT.json's ``temperature_laws``, every entry checked (a file edited by hand:
        numbers as strings, a degree of 10^8, anchors that do not match the degree, a negative Ms0)."""
        try:
            deg = {p: _whole(d[p]["degree"], f"{p}.degree") for p in LAW_PARAMS}
            anchors = {p: _reals(d[p]["anchors_C"], deg[p] + 1, f"{p}.anchors_C") for p in LAW_PARAMS}
            values = {p: _reals(d[p]["values"], deg[p] + 1, f"{p}.values") for p in LAW_PARAMS}
            ms = [_reals([d["Ms"][n]], 1, f"Ms.{n}")[0] for n in MS_NAMES]
        except (KeyError, TypeError) as e:
            raise InputError(f"temperature_laws: malformed ({e.__class__.__name__}: {e})") from None
        if not all(v > 0 for v in ms):
            raise InputError(f"temperature_laws: Ms0, Tc_K and beta must be > 0, got {ms}")
        if any(np.unique(a).size < a.size for a in anchors.values()):
            raise InputError("temperature_laws: a law's anchors_C must be distinct temperatures")
        lw = cls(deg, (0.0, 1.0), c_max)
        lw.anchors = anchors
        return lw, np.asarray(ms + [float(v) for p in LAW_PARAMS for v in values[p]])


def _whole(v, where: str) -> int:
    if not (json_number(v) and isinstance(v, int)) or not 0 <= v <= 10:
        raise InputError(f"temperature_laws: {where} must be a whole number 0-10, got {v!r}")
    return v


def _reals(v, n: int, where: str) -> np.ndarray:
    """``n`` finite JSON numbers (not strings that read as numbers)."""
    ok = isinstance(v, list) and len(v) == n and all(json_number(x) and np.isfinite(x) for x in v)
    if not ok:
        raise InputError(f"temperature_laws: {where} must be {n} number(s) (the degree + 1), got {v!r}")
    return np.asarray(v, dtype=float)


def _num(v) -> float | None:
    return float(v) if np.isfinite(v) else None


class TempLawProblem(JointProblem):
    """A joint problem whose loops take their J-A parameters from the laws at their own temperature."""

    def __init__(self, probs: list, temps_C, laws: Laws):
        super().__init__(probs, weight="none")
        self.temps = [float(t) for t in temps_C]
        self.laws = laws
        self.npar = len(laws.names)
        self.par_names = laws.names
        self.names = laws.names + (tuple(f"m0_{i}" for i in range(len(probs))) if self.fit_m0 else ())

    def sub_x(self, X, i: int) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        P = self.laws.params(X[:, : self.npar], self.temps[i])
        return np.hstack([P, X[:, self.npar + i: self.npar + i + 1]]) if self.fit_m0 else P


# --------------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------------
def read_temperature_loops(path, loop_index, samples: int) -> tuple[list[Loop], list[float]]:
    """The selected loops (``loop_index``: 'all' or a list), each resampled to ``samples`` samples evenly
    spaced in sample index, and each loop's temperature (the ``temperature_C`` column, one value per loop)."""
    loops = read_loops(path)
    idx = [None if lp.loop_index is None else int(lp.loop_index[0]) for lp in loops]
    if idx == [None]:
        raise InputError(f"{path}: no loop_index column; temperature laws need several loops")
    sel = idx if loop_index in (None, "all") else list(loop_index)
    missing = [i for i in sel if i not in idx]
    if missing:
        raise InputError(f"{path}: no loop_index {missing[0]} (have {', '.join(map(str, idx))})")
    df = pd.read_csv(path, usecols=lambda c: c.strip() in ("loop_index", "temperature_C"))
    df.columns = [c.strip() for c in df.columns]
    if "temperature_C" not in df.columns:
        raise InputError(f"{path}: no temperature_C column; --temperature-laws needs each loop's temperature")
    t = pd.to_numeric(df["temperature_C"], errors="coerce")
    if t.isna().any():
        row = int(np.flatnonzero(t.isna().to_numpy())[0]) + 2
        raise InputError(f"{path}: row {row}, column temperature_C: expected a number (degrees C)")
    out, temps = [], []
    for i in sel:
        lp = loops[idx.index(i)]
        ti = t[df["loop_index"] == i].to_numpy()
        if np.ptp(ti) > 0:
            raise InputError(f"{path}: loop_index {i}: temperature_C varies within the loop ({ti.min():g} .. "
                             f"{ti.max():g}); one temperature per loop is expected")
        out.append(resample(lp, samples))
        temps.append(float(ti[0]))
    if len(set(temps)) < 2:
        raise InputError(f"{path}: the selected loops span one temperature; temperature laws need at least two")
    return out, temps


def resample(lp: Loop, n: int) -> Loop:
    """``n`` samples evenly spaced in sample index (first and last kept; a shorter loop is kept whole)."""
    if lp.B_T.size <= n:
        return lp
    k = np.unique(np.round(np.linspace(0, lp.B_T.size - 1, n)).astype(int))

    def pick(a):
        return None if a is None else np.asarray(a)[k]

    return Loop(lp.path, lp.H_A_per_m[k], lp.B_T[k], pick(lp.current_A), pick(lp.branch), pick(lp.saturated),
                pick(lp.loop_index), lp.kind)


# --------------------------------------------------------------------------------------------------
# the box and the starts
# --------------------------------------------------------------------------------------------------
def law_box(laws: Laws, temps, ms_max: float, tc: dict, cfg: dict) -> Box:
    """Ms0 within [0.5, 4] x the largest per-loop Ms; Tc within Tc_K_above of the warmest loop; beta in its range;
    a, k the default J-A box (log); c within [0, c_max]; alpha within [0, alpha_max]."""
    jb = default_box(cfg)
    tmax = max(temps) + K0
    lo = [0.5 * ms_max, tmax + tc["Tc_K_above"][0], tc["beta"][0]]
    hi = [4.0 * ms_max, tmax + tc["Tc_K_above"][1], tc["beta"][1]]
    scale = ["log", "linear", "linear"]
    for p in LAW_PARAMS:
        n = laws.anchors[p].size
        j = JA_NAMES.index(p)
        plo, phi = float(jb.lo[j]), float(jb.hi[j])
        if p == "alpha":
            plo, phi = 0.0, float(tc["alpha_max"])
        lo += [plo] * n
        hi += [phi] * n
        scale += ["log" if p in LOG_LAWS else "linear"] * n
    lo, hi = np.array(lo), np.array(hi)
    return Box(laws.names, lo, hi, tuple(scale), 0.5 * (lo + hi))


def laws_through(laws: Laws, temps, P: np.ndarray, box: Box) -> np.ndarray:
    """Law coordinates that follow per-loop parameters P (n_loops, 5): Ms's power law by least squares in
    log Ms, each other law a least-squares polynomial of its degree (in log for a, k) evaluated at its anchors."""
    t = np.asarray(temps, dtype=float)
    ms = P[:, 0]
    i_lo = box.names.index("Tc_K")

    def res(q):
        return np.log(q[0]) + q[2] * np.log(np.maximum(1.0 - (t + K0) / q[1], 1e-12)) - np.log(ms)

    q0 = np.clip([ms.max() * 1.3, box.lo[i_lo] + 5.0, 0.3], box.lo[:3] * 1.0001, box.hi[:3] * 0.9999)
    q = least_squares(res, q0, bounds=(box.lo[:3], box.hi[:3])).x
    x = list(q)
    for p in LAW_PARAMS:
        y = P[:, JA_NAMES.index(p)]
        y = np.log(np.maximum(y, 1e-300)) if p in LOG_LAWS else y
        d = min(laws.degree[p], len(set(t.tolist())) - 1)
        v = np.polyval(np.polyfit(t, y, d), laws.anchors[p])
        x += list(np.exp(v) if p in LOG_LAWS else v)
    return np.clip(np.asarray(x), box.lo, box.hi)


def constant_laws(laws: Laws, x_ms: np.ndarray, p5, box: Box) -> np.ndarray:
    """One loop's own parameters held at every temperature (Ms keeps the power law's shape)."""
    x = list(x_ms[:3])
    for p in LAW_PARAMS:
        x += [float(p5[JA_NAMES.index(p)])] * laws.anchors[p].size
    return np.clip(np.asarray(x), box.lo, box.hi)


def stderr(prob, box: Box, r: dict, factor: float) -> np.ndarray:
    """Standard errors (physical units) of the fitted coordinates from the Jacobian at the solution, times
    ``factor`` (residuals correlated along the loops: :func:`widening`); nan where the coordinate sits on its
    bound or is not identified."""
    Ju = np.asarray(r["jac_u"], dtype=float)
    x = np.asarray(r["x"], dtype=float)
    m, d = Ju.shape
    s2 = float(r["J"]) ** 2 * prob.nv / max(m - d, 1)
    try:
        cov_u = s2 * np.linalg.pinv(Ju.T @ Ju)
    except np.linalg.LinAlgError:
        return np.full(x.size, np.nan)
    u = box.to_u(x)
    dxdu = np.where(np.array(box.scale) == "log", x * np.log(box.hi / np.maximum(box.lo, 1e-300)), box.hi - box.lo)
    se = np.full(x.size, np.nan)
    free = np.asarray(r.get("free", np.arange(x.size)))
    se[free] = np.abs(dxdu[free]) * np.sqrt(np.maximum(np.diag(cov_u), 0.0))
    col2 = np.sum(Ju**2, axis=0)
    se[free[col2 <= 1e-24 * max(float(col2.max(initial=0.0)), 1e-300)]] = np.nan  # no effect on the fit: pinv's 0
    se[(u <= 1e-6) | (u >= 1 - 1e-6)] = np.nan
    return se * factor


# --------------------------------------------------------------------------------------------------
# the fit
# --------------------------------------------------------------------------------------------------
def _starts(laws: Laws, temps, own: list, box: Box) -> list:
    P = np.array([[f["params"][n] for n in JA_NAMES] for f in own])
    x_law = laws_through(laws, temps, P, box)
    out = [("laws through the loops' own fits", x_law)]
    out += [(f"own fit of the {t:g} C loop at every temperature", constant_laws(laws, x_law, P[j], box))
            for j, t in enumerate(temps)]
    return out


def fit_laws(loops: list, temps: list, *, form=None, config=None, start=None, n_starts: int = 2) -> dict:
    """The joint temperature-law fit (LSM) of ``loops`` at ``temps`` (C): the fit JSON as a dict."""
    from mrhyst.fit import identify

    cfg = resolve_config(config)
    tl = law_config(config)
    form = form or cfg["ja"]["form"]
    start = start or tl["start"]
    own = [identify.fit_loop(lp, "lsm", form=form, config=cfg, start=start) for lp in loops]
    laws = Laws(tl["degree"], temps, c_max=float(cfg["pso"]["box"]["c_max"]))
    box = law_box(laws, temps, max(f["params"]["Ms"] for f in own), tl, cfg)
    subs, infos = identify._problems(loops, n_over_le=None, form=form, dman=cfg["ja"]["dman"],
                                     substeps=max(int(f["substeps"]) for f in own), start=start, cfg=cfg,
                                     variant="ja")
    prob = TempLawProblem(subs, temps, laws)
    starts = _starts(laws, temps, own, box)
    if prob.fit_m0:  # each loop's own m0 from its own fit
        m0 = [float(f.get("m0", 0.0)) for f in own]
        m0r = cfg["pso"]["m0_range"]
        box = Box(prob.names, np.append(box.lo, [m0r[0]] * len(m0)), np.append(box.hi, [m0r[1]] * len(m0)),
                  tuple(box.scale) + ("linear",) * len(m0), np.append(box.centre, m0))
        starts = [(n, np.append(x, m0)) for n, x in starts]
    J0 = prob.cost(np.array([x for _, x in starts]))  # every start screened in one batched call
    order = np.argsort(J0, kind="stable")[: max(int(n_starts), 1)]
    box.centre = starts[order[0]][1]
    noise, tol = identify._accuracy_target(subs, cfg["ja"])
    r, extra = identify._search(prob, box, "lsm", cfg, seed=None, setting=None, pso_overrides=None, tol=tol,
                                starts=[starts[i] for i in order[1:]])
    extra["lsm_start"] = starts[order[0]][0] if extra["lsm_start"] == "box centre" else extra["lsm_start"]
    extra["start_screen"] = [{"start": n, "J_T": float(j)} for (n, _), j in zip(starts, J0)]
    wid = widening(prob, r["x"], float(frozen(config, "diagnose")["stderr_rho_max"]))  # the one cap (diagnose)
    se = stderr(prob, box, r, wid["factor"])
    x = r["x"]
    per = []
    for i, (p, lp, f) in enumerate(zip(subs, loops, own)):
        B, ok = p.model(prob.sub_x(x, i))
        d = B[0][p.valid] - p.Bv
        rms = float(np.sqrt(np.mean(d**2))) if ok[0] else float(p.fail_cost_T)
        per.append({"loop_index": None if lp.loop_index is None else int(lp.loop_index[0]),
                    "temperature_C": temps[i], "n_samples": int(p.H.size), "B_peak_T": float(np.max(np.abs(p.Bv))),
                    "H_peak_A_per_m": float(np.max(np.abs(p.H))), "rms_T": rms,
                    "params": dict(zip(JA_NAMES, map(float, prob.sub_x(x, i)[0][:5]))),
                    "own_fit": {"rms_T": float(f["rms_T"]), "params": f["params"]}})
    t_ref = float(np.median(temps))
    return {"method": "lsm", "form": form, "dman": cfg["ja"]["dman"], "model": "ja", "start": start,
            "loop": str(getattr(loops[0], "path", "")).rsplit("/", 1)[-1], "loop_kind": loops[0].kind,
            "samples_per_loop": int(tl["samples_per_loop"]), "noise_floor_T": noise,
            "temperature_laws": laws.to_json(x, se), "coordinates": dict(zip(box.names, map(float, x))),
            "stderr": {n: _num(v) for n, v in zip(box.names, se)}, "stderr_widening": wid,
            "stderr_null": null_reasons(box, r, se),
            **{k: v for k, v in box_dict(box).items()},
            "reference_temperature_C": t_ref, "params": dict(zip(JA_NAMES, map(float, laws.params(x[:prob.npar],
                                                                                                   t_ref)[0]))),
            "rms_T": prob.rms_all(x), "per_loop": per, "loop_index": [e["loop_index"] for e in per],
            "history": r["history"], "n_iterations": len(r["history"]), "n_model_evaluations": int(r["n_evals"]),
            **{k: v for k, v in extra.items() if k not in ("seed", "setting")}}


def null_reasons(box: Box, r: dict, se) -> dict:
    """{coordinate: why its stderr is null}: a null in FIT.json says why, never just "missing"."""
    u = box.to_u(np.asarray(r["x"], dtype=float))
    free = set(np.asarray(r.get("free", np.arange(u.size))).tolist())
    why = {}
    for i, n in enumerate(box.names):
        if np.isfinite(se[i]):
            continue
        why[n] = ("held (not fitted)" if i not in free else
                  "at its bound (the fit wants it beyond the box; no Jacobian stderr there)"
                  if u[i] <= 1e-6 or u[i] >= 1 - 1e-6 else "not identified (a flat direction of the Jacobian)")
    return why


def widening(prob, x, rho_max: float) -> dict:
    """{"factor", "rho"}: the stderr widening for the residuals' lag-1 autocorrelation within each loop."""
    pieces = [p.residuals(prob.sub_x(x, i)[0]) for i, p in enumerate(prob.probs)]
    k, rho = correlation_factor(pieces, rho_max)
    return {"factor": k, "rho": rho}


def box_dict(box: Box) -> dict:
    return {"box": box.as_dict()}


def check_cli(args) -> None:
    """`mrhyst fit --temperature-laws`: the options it takes, one line each (before any work)."""
    if args.method != "lsm":
        raise InputError(f"{args.loop}: --temperature-laws is a least-squares fit (--method lsm), got --method "
                         f"{args.method}")
    if args.loop_index is None or ("," not in args.loop_index and args.loop_index != "all"):
        raise InputError(f"{args.loop}: --temperature-laws needs several loops: --loop-index all or a list like 0,3,6")
    for opt in ("model", "joint_weight", "pso_setting"):
        if getattr(args, opt, None) is not None:
            raise InputError(f"{args.loop}: --{opt.replace('_', '-')} does not apply to --temperature-laws")
    if args.start is not None and args.start not in ("first_sample", "fit", "demagnetised"):
        raise InputError(f"{args.loop}: --temperature-laws takes --start first_sample, fit or demagnetised")


def fit_file(path, *, loop_index="all", form=None, config=None, start=None, out=None) -> dict:
    """`mrhyst fit FILE.csv --loop-index all|0,3,.. --temperature-laws --method lsm --out FIT.json`."""
    from mrhyst.data.io import write_json

    tl = law_config(config)
    if isinstance(loop_index, str) and loop_index.strip() != "all":
        try:
            loop_index = [int(v) for v in loop_index.split(",")]
        except ValueError:
            raise InputError(f"--loop-index: expected 'all' or a list like 0,3,6; got {loop_index!r}") from None
    loops, temps = read_temperature_loops(path, loop_index, int(tl["samples_per_loop"]))
    res = fit_laws(loops, temps, form=form, config=config, start=start)
    if out is not None:
        write_json(res, out)
    return res


__all__ = ["Laws", "TempLawProblem", "law_config", "read_temperature_loops", "resample", "law_box", "laws_through",
           "constant_laws", "stderr", "fit_laws", "fit_file"]
