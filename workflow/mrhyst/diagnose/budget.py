"""The gap budget along the chain and how far the gap shrinks (fitted and held-out)."""

from __future__ import annotations

import math

import numpy as np

from mrhyst.diagnose.policy import excess, removed_frac
from mrhyst.diagnose.problem import Fit, Problem
from mrhyst.diagnose.sweep import REGIONS, region_breakdown


def finite(x):
    return None if x is None or not math.isfinite(x) else float(x)


def gap_budget(prob: Problem, this: Fit, this_src: str, base: Fit, seeds, sigma: float, rms_after: float) -> dict:
    """RMS split in quadrature: noise in the fit, RK4 integration, the optimizer's shortfall, model form."""
    v = prob.sw.valid
    nv = int(v.sum())
    Bref, okr = prob.forward(base.u[None, :], substeps=int(prob.cfg["ref_substeps"]))
    integ = float(np.sqrt(np.mean((Bref[0, v] - base.B[v]) ** 2))) if okr[0] else None
    this_rms = this.rms if this.ok else None
    short = math.sqrt(max(this_rms**2 - base.rms**2, 0.0)) if this_rms is not None else None
    noise_in_fit = sigma * math.sqrt(max(nv - 5, 1) / nv)
    return {
        "this_fit": this_src,
        "rms_this_fit_T": this_rms,
        "rms_best_fit_T": base.rms,
        "seeds": seeds,
        "noise_floor_T": sigma,
        "noise_in_fit_T": noise_in_fit,
        "integration_error_T": integ,
        "optimizer_shortfall_T": short,
        "model_form_T": math.sqrt(max(base.rms**2 - noise_in_fit**2 - (integ or 0.0) ** 2, 0.0)),
        "explained_by_effect_T": math.sqrt(max(base.rms**2 - rms_after**2, 0.0)),
        "note": ("quadrature: rms_this_fit^2 = noise_in_fit^2 + integration^2 + optimizer_shortfall^2 + model_form^2, "
                 "noise_in_fit = noise_floor sqrt((n-5)/n); explained_by_effect is the part of model_form that the "
                 "named effect (or model-form candidate) removes"),
    }


def shrink(cfg: dict, sigma: float, before: dict, after: dict, rms_before: float, rms_after: float) -> dict:
    """Excess over the noise floor removed, fitted and held-out. ``before``/``after``: held-out statistics."""
    ex0, ex1 = excess(rms_before, sigma), excess(rms_after, sigma)
    h0, h1 = finite(before.get("heldout_T")), finite(after.get("heldout_T"))
    return {
        "excess_before_T": ex0,
        "excess_after_T": ex1,
        "excess_removed_frac": removed_frac(ex0, ex1),
        "rms_after_over_noise": rms_after / sigma if sigma > 0 else None,
        "heldout_scheme": "fit the ascending branch and the turning point, predict the descending branch",
        "heldout_rms_before_T": h0,
        "heldout_rms_after_T": h1,
        "heldout_excess_removed_frac": removed_frac(excess(h0, sigma), excess(h1, sigma)),
        "cv_scheme": (f"{int(cfg['cv_folds'])}-fold: interleaved (sample j in fold j mod K) and contiguous blocks "
                      f"along the path; each fold predicted from a fit to the rest"),
        "cv_interleaved_before_T": finite(before.get("cv_interleaved_T")),
        "cv_interleaved_after_T": finite(after.get("cv_interleaved_T")),
        "cv_blocks_before_T": finite(before.get("cv_blocks_T")),
        "cv_blocks_after_T": finite(after.get("cv_blocks_T")),
    }


def where(prob: Problem, B_before, B_after, budget: dict) -> dict:
    """Regions of the loop: share of the squared residual before and after, and the budget."""
    sw, cfg = prob.sw, prob.cfg
    reg0 = region_breakdown(sw.B - B_before, sw)
    reg1 = region_breakdown(sw.B - B_after, sw)
    return {
        "regions": {k: {"n": reg0[k]["n"], "share_before": reg0[k]["share"], "share_after": reg1[k]["share"],
                        "rms_before_T": reg0[k]["rms_T"], "rms_after_T": reg1[k]["rms_T"],
                        "mean_before_T": reg0[k]["mean_T"], "mean_after_T": reg1[k]["mean_T"]} for k in REGIONS},
        "largest_share_before": max(REGIONS, key=lambda k: reg0[k]["share"]),
        "region_order": list(REGIONS),
        "region_bounds": {"low_below": cfg["regions"]["low_frac"], "high_from": cfg["regions"]["high_frac"],
                          "units": "fraction of the largest current"},
        "budget": budget,
        "saturated_samples": int((~sw.valid).sum()),
    }
