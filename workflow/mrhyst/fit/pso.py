"""PSO (Eq. 14) with pyswarms 1.3.0, quietly; and its least-squares polish (the CLI's convergent setting)."""

from __future__ import annotations

import atexit
import contextlib
import logging
import os
import tempfile

import numpy as np

from mrhyst.data.io import InputError
from mrhyst.fit.box import Box
from mrhyst.fit.lsq import run_lsm
from mrhyst.fit.problem import Problem
from mrhyst.fit.settings import BH_STRATEGIES
from mrhyst.settings import schema_or

# --------------------------------------------------------------------------------------------
# pyswarms, quietly
# --------------------------------------------------------------------------------------------
_LOG_CFG_PATH: str | None = None
# Incremental dictConfig: touches only the 'pyswarms' logger. A non-incremental config (pyswarms'
# default, or any config with a handlers section) would close every handler of the process
# (logging.config._clearExistingHandlers) each time pyswarms builds a Reporter (4 per optimizer).
_LOG_CFG_TEXT = (
    '{"version": 1, "incremental": true,'
    ' "loggers": {"pyswarms": {"level": "WARNING", "propagate": false}}}\n'
)


def _log_cfg_path() -> str:
    global _LOG_CFG_PATH
    if _LOG_CFG_PATH is None or not os.path.isfile(_LOG_CFG_PATH):
        fd, path = tempfile.mkstemp(prefix="mrhyst-pyswarms-log-", suffix=".yaml")
        with os.fdopen(fd, "w") as f:
            f.write(_LOG_CFG_TEXT)
        atexit.register(lambda p=path: os.path.exists(p) and os.unlink(p))
        _LOG_CFG_PATH = path
    return _LOG_CFG_PATH


@contextlib.contextmanager
def _quiet_pyswarms():
    """LOG_CFG -> our config while pyswarms is imported/constructed: no ./report.log, root untouched.

    pyswarms' Reporter reads LOG_CFG at import (module-level reporters) and at every optimizer
    construction; without it, it writes ./report.log and puts a StreamHandler on the root logger.
    Its messages go to a NullHandler on the 'pyswarms' logger (level WARNING, no propagation).
    """
    lg = logging.getLogger("pyswarms")
    if not any(isinstance(h, logging.NullHandler) for h in lg.handlers):
        lg.addHandler(logging.NullHandler())
    lg.propagate = False
    lg.setLevel(logging.WARNING)
    old = os.environ.get("LOG_CFG")
    os.environ["LOG_CFG"] = _log_cfg_path()
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("LOG_CFG", None)
        else:
            os.environ["LOG_CFG"] = old


def _global_best_pso():
    with _quiet_pyswarms():
        from pyswarms.single.global_best import GlobalBestPSO
    return GlobalBestPSO



# --------------------------------------------------------------------------------------------
# PSO (Eq. 14)
# --------------------------------------------------------------------------------------------
def run_pso(prob: Problem, box: Box, *, seed: int | None = None, n_particles: int | None = None,
            iterations: int | None = None, w: float | None = None, c1: float | None = None, c2: float | None = None,
            v_max_frac: float | None = None, bh_strategy: str | None = None, oh_strategy: dict | None = None) -> dict:
    """GlobalBestPSO on the normalised box. Returns x (physical), J, history, n_evals. The settings not given
    (None): config pso's schema defaults (seed: the first of pso.seeds; w, c1, c2: those of pso.setting).

    Seeding: pyswarms 1.3.0 has no seed argument; it draws the start positions and velocities in
    the constructor and r1, r2 of Eq. (14) every iteration from numpy's global RNG. We seed it right
    before construction and restore the caller's global RNG state afterwards.
    v_max (the paper's clamp after Eq. 14) = v_max_frac * box width, per coordinate.
    """
    d = schema_or("pso", seeds=None, settings=None, setting=None, n_particles=n_particles, iterations=iterations,
                  v_max_frac=v_max_frac, bh_strategy=bh_strategy)
    own = {k: v for k, v in d["settings"][d["setting"]].items() if k in ("w", "c1", "c2")}
    seed = d["seeds"][0] if seed is None else seed
    w, c1, c2 = (own[k] if v is None else v for k, v in (("w", w), ("c1", c1), ("c2", c2)))
    n_particles, iterations, v_max_frac, bh_strategy = (d[k] for k in ("n_particles", "iterations", "v_max_frac",
                                                                        "bh_strategy"))
    if bh_strategy not in BH_STRATEGIES:
        raise InputError(f"bh_strategy must be one of {BH_STRATEGIES} (keeps particles physical), got {bh_strategy!r}")
    if not (0 < v_max_frac <= 1):
        raise InputError(f"v_max_frac must be in (0, 1], got {v_max_frac}")
    GlobalBestPSO = _global_best_pso()
    D = box.dim
    bounds = (np.zeros(D), np.ones(D))
    vmax = float(v_max_frac)
    n0 = prob.n_evals

    def objective(U):
        return prob.cost(box.to_x(U))

    state = np.random.get_state()
    try:
        np.random.seed(int(seed))
        with _quiet_pyswarms():
            opt = GlobalBestPSO(n_particles=int(n_particles), dimensions=D,
                                options={"c1": float(c1), "c2": float(c2), "w": float(w)},
                                bounds=bounds, bh_strategy=bh_strategy, velocity_clamp=(-vmax, vmax),
                                oh_strategy=dict(oh_strategy) if oh_strategy else None)
        best_cost, best_u = opt.optimize(objective, iters=int(iterations), verbose=False)
    finally:
        np.random.set_state(state)
    x = box.to_x(best_u)
    J = float(prob.cost(x[None, :])[0])
    hist = [float(v) for v in opt.cost_history]
    return {"x": x, "J": J, "history": hist, "best_cost": float(best_cost), "n_evals": prob.n_evals - n0}



def polish_pso(prob: Problem, box: Box, r: dict, lc: dict, out: dict) -> dict:
    """Local polish of a PSO result: least_squares (config lsm: method, tolerances, max_iterations)
    from the swarm's best point, in the same box. The polish's iterations are appended to the PSO
    history (so history[-1] is the returned J); ``out["polish"]`` records where the swarm stopped and
    what the polish added. The polished point is kept only if it is not worse."""
    p = run_lsm(prob, box, r["x"], max_iterations=int(lc["max_iterations"]), method=lc["method"],
                ftol=float(lc["ftol"]), xtol=float(lc["xtol"]), gtol=float(lc["gtol"]),
                diff_step=lc.get("diff_step"))
    better = p["J"] <= r["J"]
    hist = list(r["history"]) + [min(v, r["J"]) for v in p["history"]]
    out["polish"] = {"method": "least_squares " + lc["method"], "J_swarm_T": float(r["J"]),
                     "J_polished_T": float(p["J"]), "kept": bool(better), "n_pso_iterations": len(r["history"]),
                     "n_polish_iterations": len(p["history"]), "n_polish_evaluations": int(p["n_evals"])}
    return {"x": p["x"] if better else r["x"], "J": min(p["J"], r["J"]), "history": hist,
            "best_cost": r["best_cost"], "n_evals": r["n_evals"] + p["n_evals"]}


# --------------------------------------------------------------------------------------------
