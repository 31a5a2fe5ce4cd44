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
    P, eff = prob.forward_params(fit.u, fit.effects)
    dwell0 = prob.sw.dwell_s or 1.0
    sw = prob.sw

    def predict(current, time_s, dwell_s):
        e = {k: dict(v) for k, v in eff.items()}
        for k, ep in e.items():  # an effect whose size is per current step scales with the dwell (registry)
            at = fx.REGISTRY[k].at_dwell
            if at is not None:
                p = fx.REGISTRY[k].param
                ep[p] = at(ep[p], float(dwell_s) / dwell0)
        B, ok = fx.forward(P, current, time_s, sw.n_over_le, e, form=prob.form, substeps=prob.substeps,
                           dman=prob.dman, M0=sw.M0)
        return B if ok else np.full(np.shape(current), np.nan)

    return predict


def _model_form_predictor(prob: Problem, name: str, x, shapes: dict):
    """``shapes``: {current bytes: PathShape} shared by every predictor of one next_measurement, so that each
    protocol variant's path is derived once (the measured path's is the sweep's own)."""

    def predict(current, time_s, dwell_s):
        cur = np.asarray(current, dtype=float)
        sw2 = sweep_from_arrays(cur, time_s, np.zeros(cur.size), prob.sw.n_over_le, cfg=prob.cfg,
                                source="variant", shape=shapes.get(cur.tobytes()))
        shapes[cur.tobytes()] = sw2.shape
        sw2.M0 = prob.sw.M0  # the start state the fit had (a B(H) loop's first sample's; 0 = demagnetised)
        model = build_model_form(Problem(sw2, prob.cfg), [name])[0]
        B, ok = model.forward(np.asarray(x)[None, :])
        return B[0] if ok[0] else np.full(np.shape(current), np.nan)

    return predict


def after_prefix(predict, pre_current, pre_time, step: float | None = None):
    """``predict`` run after the sweep's conditioning prefix (a B(H) loop's own passes, a declared preconditioning),
    returning the part after it: the start state the fit had. Without it a loop that starts at its tip was simulated
    from the state before the prefix (M0 at the tip: J-A fails there, and every separation read 0 until
    protocols.separation said so; measured on the real-cores benchmark: 3 B(H) cases and 2 ferrite loops had no
    computable variant). A path that does not start where the prefix ends (a bipolar variant from 0 A after a loop
    that ends at its tip) is reached by a ramp at ``step`` (the sweep's own current step), as a lab would drive
    it, not in one jump (measured: 58 of the 204 held-out real-core diagnoses had a variant J-A could not integrate
    across the jump); the ramp is not returned."""
    pre_c, pre_t = np.asarray(pre_current, dtype=float), np.asarray(pre_time, dtype=float)
    if pre_c.size == 0:
        return predict

    def run(current, time_s, dwell_s):
        cur, t = np.asarray(current, dtype=float), np.asarray(time_s, dtype=float)
        gap = float(cur[0] - pre_c[-1])
        n = int(math.ceil(abs(gap) / step)) - 1 if step and abs(gap) > step else 0
        frac = np.arange(1, n + 1) / (n + 1)
        c = np.concatenate([pre_c, pre_c[-1] + gap * frac, cur])
        tt = np.concatenate([pre_t, pre_t[-1] + (t[0] - pre_t[-1]) * frac, t])
        return np.asarray(predict(c, tt, dwell_s))[pre_c.size + n:]

    return run


def _model_form_name(n: str, verdict: dict, ev: dict) -> str | None:
    """``model_form`` as the name of its named (or lowest-BIC) candidate, ``model_form:NAME``; other names as
    they are; None when no model-form candidate was fitted."""
    if n != "model_form":
        return n
    mf = {k: m for k, m in (ev.get("model_form") or {}).items() if m.get("bic") is not None}
    best = verdict.get("model_form") or (min(mf, key=lambda k: mf[k]["bic"]) if mf else None)
    return f"model_form:{best}" if best else None


def rivals(verdict: dict, ev: dict) -> list[str]:
    """The candidates a next measurement must tell apart: the named effect and its ambiguous rivals; for an
    unexplained gap the two best explanations by BIC (effects, pairs aside, and model-form candidates)."""
    if verdict["ambiguous_with"]:  # "model_form" (a declared confound, diagnose.confounds): its best candidate
        names = [_model_form_name(n, verdict, ev) for n in [verdict["effect"], *verdict["ambiguous_with"]]]
        return [n for n in names if n]
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
    models, shapes = {}, {s.path.tobytes(): s for s in (prob.sw.shape, prob.sw.pass_shape) if s is not None}
    for n in names:
        if n == "none":
            models[n] = _effect_predictor(prob, base)
        elif n.startswith("model_form:") and "x" in mf_fits.get(n.split(":", 1)[1], {}):
            models[n] = _model_form_predictor(prob, n.split(":", 1)[1], mf_fits[n.split(":", 1)[1]]["x"], shapes)
        elif n in fits:
            models[n] = _effect_predictor(prob, fits[n])
    if len(models) < 2:
        return None
    sw = prob.sw
    step = protocols.step_of(sw.current[sw.start:])
    models = {n: after_prefix(m, sw.current[:sw.start], sw.time[:sw.start], step) for n, m in models.items()}
    return protocols.next_measurement(models, sw.current[sw.start:], sw.time[sw.start:], sw.dwell_s or 1.0,
                                      ev["noise_floor_T"])
