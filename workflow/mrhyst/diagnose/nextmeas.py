"""``next_measurement`` (issue 13): the protocol change that best separates the top candidates.

Each candidate's *fitted* model (plain J-A, J-A + an effect, a model-form candidate) becomes a predictor of
B along any current path (:mod:`mrhyst.diagnose.protocols`), built from the one forward model in physical units: an
effect keeps its contract size (a drift its rate per second, an eddy lag its time constant, so a longer
dwell gives lag' = lag^(dwell'/dwell)), a model-form candidate its parameters. The variants of the
measured protocol are simulated and the one with the largest predicted difference between the candidates,
in units of the noise floor, is named.
"""

from __future__ import annotations

import math

import numpy as np

from mrhyst.diagnose import protocols
from mrhyst.diagnose.modelform import build as build_model_form
from mrhyst.diagnose.problem import Problem
from mrhyst.diagnose.sweep import sweep_from_arrays
from mrhyst.model import effects as fx


def _effect_predictor(prob: Problem, fit):
    ja_d, eff = prob.physical(fit.u, fit.effects)
    P = np.array([ja_d[k] for k in ("Ms", "a", "alpha", "c", "k")])
    if "air_gap" in eff:  # alpha' below 0: physical() reports alpha = 0 and the smallest Nd
        P[2] = float(fit.u[2])
        eff = {k: v for k, v in eff.items() if k != "air_gap"}
    dwell0 = prob.sw.dwell_s or 1.0
    sw = prob.sw

    def predict(current, time_s, dwell_s):
        e = {k: dict(v) for k, v in eff.items()}
        if "eddy_lag" in e:
            e["eddy_lag"]["lag"] = float(e["eddy_lag"]["lag"]) ** (float(dwell_s) / dwell0)
        B, ok = fx.forward(P, current, time_s, sw.n_over_le, e, form=prob.form, substeps=prob.substeps,
                           dman=prob.dman, M0=sw.M0)
        return B if ok else np.full(np.shape(current), np.nan)

    return predict


def _model_form_predictor(prob: Problem, name: str, x):
    def predict(current, time_s, dwell_s):
        sw2 = sweep_from_arrays(current, time_s, np.zeros(np.size(current)), prob.sw.n_over_le, cfg=prob.cfg,
                                source="variant")
        model = build_model_form(Problem(sw2, prob.cfg), [name])[0]
        B, ok = model.forward(np.asarray(x)[None, :])
        return B[0] if ok[0] else np.full(np.shape(current), np.nan)

    return predict


def rivals(verdict: dict, ev: dict) -> list[str]:
    """The candidates a next measurement must tell apart: the named effect and its ambiguous rivals; for an
    unexplained gap the two best explanations by BIC (effects, pairs aside, and model-form candidates)."""
    if verdict["ambiguous_with"]:
        return [verdict["effect"], *verdict["ambiguous_with"]]
    if verdict["effect"] != "unexplained":
        return []
    scored = [(c["bic"], e) for e, c in ev["candidates"].items() if c.get("bic") is not None]
    scored += [(m["bic"], "model_form:" + k) for k, m in ev["model_form"].items() if m.get("bic") is not None]
    scored.append((ev["none"]["bic"], "none"))
    scored = [s for s in scored if s[0] is not None and math.isfinite(s[0])]
    return [e for _, e in sorted(scored)[:2]]


def next_measurement(prob: Problem, verdict: dict, ev: dict, base, fits: dict, mf_fits: dict) -> dict | None:
    """The contract's ``next_measurement`` block, or None when the verdict is neither ambiguous nor
    unexplained (or fewer than two candidates could be simulated)."""
    names = rivals(verdict, ev)
    models = {}
    for n in names:
        if n == "none":
            models[n] = _effect_predictor(prob, base)
        elif n.startswith("model_form:") and "x" in mf_fits.get(n.split(":", 1)[1], {}):
            models[n] = _model_form_predictor(prob, n.split(":", 1)[1], mf_fits[n.split(":", 1)[1]]["x"])
        elif n in fits:
            models[n] = _effect_predictor(prob, fits[n])
    if len(models) < 2:
        return None
    sw = prob.sw
    return protocols.next_measurement(models, sw.current[sw.start:], sw.time[sw.start:], sw.dwell_s or 1.0,
                                      ev["noise_floor_T"])
