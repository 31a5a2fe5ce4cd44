"""N/Le, the coil turns per metre of magnetic path (Eq. 12), inferred from the reported peaks.

Li & Gong (2019) never state N or L_e, yet every simulated B(I) loop needs
H = (N/L_e) I (Eq. 12). What they do state is the peak flux density of each
group at I = 2 A ("around 0.09 / 0.045 Tesla", Fig. 6 text) and, in Table 1,
the J-A parameters fitted to each group. So for each of the four Table 1 sets
(group 1/2 x LSM/PSO) we take the N/Le at which the simulated peak B along the
paper's current path (27 values 0 -> 2 A and back, Eqs. 4-13 with the model
choices of config ``ja``) equals that group's reported peak.

The peak lies on the initial (virgin) ascent, where delta = +1 throughout, so
it is the same for both J-A forms (they differ only after a reversal) and it
grows monotonically with N/Le (dM/dH >= 0 on the ascent): the root is unique
and :func:`scipy.optimize.brentq` in ``nle.bracket`` finds it. The value used
downstream is chosen by ``nle.use`` (the mean of the four by default).

For the report the inference also records what each set then gives for B at
0 A after the descent (the remanence the paper reports as 0.026 / 0.015 T),
in both J-A forms.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from mrhyst.model import ja

SETS = ("group1_lsm", "group1_pso", "group2_lsm", "group2_pso")
USE_CHOICES = ("mean", "median", *SETS)
# brentq tolerance on N/Le (1/m). dB_peak/d(N/Le) ~ 3e-5 T m, so 1e-9 /m is ~3e-14 T on the peak.
XTOL = 1e-9


def _set_params(config: dict) -> dict:
    """{"group1_lsm": (5,) array, ...} from config paper.table1."""
    t1 = config["paper"]["table1"]
    return {f"{g}_{m}": ja.as_param_array(t1[g][m]) for g in ("group1", "group2") for m in ("lsm", "pso")}


def _path(config: dict) -> np.ndarray:
    p = config["paper"]
    return ja.paper_current_path(float(p["i_max_A"]), int(p["n_up"]))


def simulate_set(params, n_over_le: float, config: dict, form: str | None = None):
    """B (T) along the paper's current path for one parameter set; raises if J-A fails."""
    jc = config["ja"]
    B, ok = ja.simulate(params, _path(config), float(n_over_le), form=form or jc["form"],
                        substeps=int(jc["substeps"]), dman=jc["dman"])
    if not ok:
        raise ValueError(f"J-A integration failed at N/Le = {n_over_le:g} /m (form {form or jc['form']})")
    return B


def peak_B(params, n_over_le: float, config: dict) -> float:
    """Largest B (T) along the paper's current path (reached at the 2 A turning point)."""
    return float(np.max(simulate_set(params, n_over_le, config)))


def solve_set(params, peak_T: float, config: dict) -> float:
    """N/Le (1/m) at which ``peak_B`` equals ``peak_T``, by brentq in config nle.bracket."""
    lo, hi = (float(x) for x in config["nle"]["bracket"])
    if not 0 < lo < hi:
        raise ValueError(f"nle.bracket must be 0 < lower < upper, got [{lo}, {hi}]")

    def f(n):
        return peak_B(params, n, config) - peak_T

    flo, fhi = f(lo), f(hi)
    if not flo < 0 < fhi:
        raise ValueError(f"nle.bracket [{lo:g}, {hi:g}] /m does not bracket the peak {peak_T} T "
                         f"(peak there: {flo + peak_T:.4g} T, {fhi + peak_T:.4g} T)")
    return float(brentq(f, lo, hi, xtol=XTOL, rtol=4 * np.finfo(float).eps, maxiter=200))


def infer_n_over_le(config: dict) -> dict:
    """N/Le per Table 1 set and the value downstream uses (config ``nle.use``).

    Returns a JSON-ready dict::

        {"n_over_le": float, "use": "mean", "per_set": {"group1_lsm": .., ...},
         "spread_rel": (max - min) / mean of the four, "peak_target_T": {...},
         "remanence_T": {set: {"paper": measured, "model_paper_form": .., "model_physical_form": ..}},
         "method": "...", "form": .., "dman": .., "substeps": ..}
    """
    use = config["nle"].get("use", "mean")
    if use not in USE_CHOICES:
        raise ValueError(f"nle.use must be one of {USE_CHOICES}, got {use!r}")
    peaks = config["paper"]["peak_B_T"]
    rems = config["paper"]["remanence_B_T"]
    per_set, remanence = {}, {}
    for name, p in _set_params(config).items():
        group = name.split("_")[0]
        n = solve_set(p, float(peaks[group]), config)
        per_set[name] = n
        remanence[name] = {
            "paper": float(rems[group]),
            "model_paper_form": float(simulate_set(p, n, config, form="paper")[-1]),
            "model_physical_form": float(simulate_set(p, n, config, form="physical")[-1]),
        }
    vals = np.array([per_set[s] for s in SETS])
    chosen = {"mean": float(np.mean(vals)), "median": float(np.median(vals))}.get(use)
    if chosen is None:
        chosen = per_set[use]
    jc = config["ja"]
    return {
        "n_over_le": chosen,
        "use": use,
        "per_set": per_set,
        "spread_rel": float((vals.max() - vals.min()) / np.mean(vals)),
        "peak_target_T": {g: float(v) for g, v in peaks.items()},
        "remanence_T": remanence,
        "method": ("per Table 1 set: brentq on N/Le in nle.bracket so that max B along the paper's current "
                   "path (Eq. 12, H = (N/Le) I; J-A Eqs. 4-13, config ja) equals the group's reported peak"),
        "form": jc["form"],
        "dman": jc["dman"],
        "substeps": int(jc["substeps"]),
    }
