"""Identifiability: the profile of J along each parameter, curvature-based standard errors."""

from __future__ import annotations

import numpy as np

from mrhyst.data.io import read_json, read_loop, write_json
from mrhyst.fit.box import Box, box_for, box_from_record
from mrhyst.fit.lsq import run_lsm
from mrhyst.fit.problem import Problem, _read_n_over_le, problem_from_loop
from mrhyst.fit.settings import JA_NAMES, M0_NAME, resolve_config
from mrhyst.model import ja
from mrhyst.settings import schema_or


# --------------------------------------------------------------------------------------------
# identifiability: profile of J along each parameter + curvature-based standard errors
# --------------------------------------------------------------------------------------------
def _profile_grid(box: Box, i: int, xi: float, n_grid: int, refine_rel) -> np.ndarray:
    u = np.linspace(0.0, 1.0, int(n_grid))
    g = list(box.to_x(np.outer(u, np.ones(box.dim)))[:, i])
    for r in refine_rel:
        for s in (-1.0, 1.0):
            g.append(xi * (1.0 + s * r))
    g.append(xi)
    g = np.array(g)
    g = g[(g >= box.lo[i]) & (g <= box.hi[i])]
    return np.unique(g)


def _crossing(xs, Js, i_min, level):
    """Interpolated x where the profile first rises above ``level`` going left/right from i_min;
    None if it stays below to the end of the grid (the box edge)."""
    out = []
    for step in (-1, 1):
        j = i_min
        found = None
        while 0 <= j + step < len(xs):
            if Js[j + step] > level:
                x0, x1, J0, J1 = xs[j], xs[j + step], Js[j], Js[j + step]
                found = float(x0 + (level - J0) / (J1 - J0) * (x1 - x0)) if J1 != J0 else float(x1)
                break
            j += step
        out.append(found)
    return out


def profile(prob: Problem, box: Box, x_opt, *, threshold: float | None = None, n_grid: int | None = None,
            refine_rel=None, max_iterations: int | None = None, polish: bool = True) -> dict:
    """Profile J along each J-A parameter: fix it at a grid of values, re-minimise the others with
    least_squares (continuation from the optimum outwards), and report the range where
    J <= threshold * J_min, plus the linearised relative standard error sqrt(diag(s^2 (J^T J)^-1)) / x
    with s^2 = RSS / (N - D), from the Jacobian at the (polished) optimum. The settings not given (None): config
    identifiability's schema defaults.
    """
    s = schema_or("identifiability", threshold=threshold, n_grid=n_grid, refine_rel=refine_rel,
                  max_iterations=max_iterations)
    threshold, n_grid, refine_rel, max_iterations = (s[k] for k in ("threshold", "n_grid", "refine_rel",
                                                                    "max_iterations"))
    x_opt = np.asarray(x_opt, dtype=float)
    if polish:
        pr = run_lsm(prob, box, x_opt, max_iterations=200)
        x_star, J_star = (pr["x"], pr["J"]) if pr["J"] <= float(prob.cost(x_opt[None])[0]) else (x_opt, None)
    else:
        x_star = x_opt
    J_star = float(prob.cost(x_star[None])[0])
    # curvature: Jacobian in physical units by central differences in log x (relative steps)
    D = box.dim
    r0 = prob.residuals(x_star)
    Jac = np.empty((r0.size, D))
    for i in range(D):
        h = 1e-5 * max(abs(x_star[i]), 1e-12)
        xp, xm = x_star.copy(), x_star.copy()
        xp[i] += h
        xm[i] -= h
        Jac[:, i] = (prob.residuals(xp) - prob.residuals(xm)) / (2 * h) * max(abs(x_star[i]), 1e-12)
    dof = max(r0.size - D, 1)
    s2 = float(r0 @ r0) / dof
    with np.errstate(all="ignore"):
        try:
            cov_rel = s2 * np.linalg.pinv(Jac.T @ Jac)
            rse = np.sqrt(np.clip(np.diag(cov_rel), 0.0, None))
        except np.linalg.LinAlgError:
            rse = np.full(D, np.inf)
        corr = cov_rel / np.sqrt(np.outer(np.diag(cov_rel), np.diag(cov_rel)))
    sv = np.linalg.svd(Jac, compute_uv=False)
    level = threshold * J_star
    params = {}
    for i, name in enumerate(JA_NAMES):
        grid = _profile_grid(box, i, x_star[i], n_grid, refine_rel)
        Js = np.full(grid.size, np.nan)
        xs_at = [None] * grid.size
        k0 = int(np.argmin(np.abs(grid - x_star[i])))
        for direction in (range(k0, grid.size), range(k0 - 1, -1, -1)):
            xs = x_star.copy()
            for k in direction:
                r = run_lsm(prob, box, xs, max_iterations=max_iterations, fixed={i: float(grid[k])})
                Js[k] = r["J"]
                xs_at[k] = r["x"]
                xs = r["x"]
        im = int(np.nanargmin(Js))
        lo, hi = _crossing(grid, Js, im, level)
        params[name] = {
            "grid": [float(v) for v in grid],
            "J_T": [float(v) for v in Js],
            "others": [[float(v) for v in xx] for xx in xs_at],
            "J_min_T": float(Js[im]),
            "x_at_min": float(grid[im]),
            "range_lo": lo,
            "range_hi": hi,
            "range_open_lo": lo is None,
            "range_open_hi": hi is None,
            "rel_width": (None if lo is None or hi is None else float((hi - lo) / abs(x_star[i]))),
            "rel_se_curvature": float(rse[i]) if np.isfinite(rse[i]) else None,
        }
    return {
        "x_opt": {n: float(v) for n, v in zip(box.names, x_star)},
        "J_opt_T": J_star,
        "threshold": float(threshold),
        "level_T": level,
        "singular_values_rel": [float(v) for v in sv],
        "condition_rel": float(sv[0] / sv[-1]) if sv[-1] > 0 else None,
        "correlation": [[float(v) if np.isfinite(v) else None for v in row] for row in corr],
        "box": box.as_dict(),
        "params": params,
    }


def profile_file(loop_path, fit_path, out=None, n_over_le=None, config=None, group=None) -> dict:
    """Identifiability profile of a fit JSON on its loop (same form/box/start as the fit)."""
    cfg = resolve_config(config)
    fit = read_json(fit_path)
    loop = read_loop(loop_path)
    jc = cfg["ja"]
    prob, _ = problem_from_loop(loop, n_over_le=_read_n_over_le(n_over_le), form=fit.get("form", jc["form"]),
                                dman=fit.get("dman", jc["dman"]), substeps=int(fit.get("substeps", jc["substeps"])),
                                start=fit.get("start"), cfg=cfg)
    box = box_from_record(fit, JA_NAMES + ((M0_NAME,) if prob.start == "fit" else ()))
    if box is None:
        box, _ = box_for(cfg, group or fit.get("group"), fit.get("method", "pso"))
        if prob.start == "fit":
            box = box.with_m0(tuple(cfg["pso"]["m0_range"]))
    x = ja.as_param_array(fit["params"])
    if prob.start == "fit":
        x = np.append(x, fit.get("m0", 0.0))
    ic = cfg["identifiability"]
    res = profile(prob, box, x, threshold=float(ic["threshold"]), n_grid=int(ic["n_grid"]),
                  refine_rel=tuple(ic["refine_rel"]), max_iterations=int(ic["max_iterations"]))
    res.update({"group": fit.get("group"), "method": fit.get("method"), "setting": fit.get("setting"),
                "seed": fit.get("seed"), "fit_rms_T": fit.get("rms_T"), "form": prob.form})
    if out is not None:
        write_json(res, out)
    return res
