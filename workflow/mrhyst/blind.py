"""Blind benchmark of the diagnosis: cases with a withheld effect, a key, and the score.

Three steps, three rules, and only the last one may read the key:

* :func:`generate` (rule ``blind_generate``) draws ``n_per_class`` cases for every class (the effect
  vocabulary without ``unexplained``) with the virtual rig (:func:`mrhyst.rig.simulate_case`): a J-A
  truth drawn from ``truth_box``, a drive level N/Le, a noise level, one effect of a magnitude from
  barely detectable to large. It writes anonymous raw sweeps ``case_000.csv/.json`` ... in shuffled
  order (the sidecar has nothing an effect could be read from: no output limits, one sensor name,
  the same keys for every case) and the key ``key.json``. The key also records whether each injected
  effect is *detectable* (ARCHITECTURE 6): plain J-A refitted to the noise-free, effect-laden loop from
  the true parameters leaves an RMS of at least ``detectable_factor`` times the noise; and which other
  candidate effects explain that loop equally well (their refit leaves less than ``equivalent_factor``
  times the noise: e.g. a remanent start and a constant Hall offset at low drive).
* the diagnosis of one case (rule ``blind_diagnose``) is :func:`mrhyst.diagnose.diagnose_file`; it
  never sees the key.
* :func:`score` (rule ``blind_score``) reads the diagnoses and the key: confusion matrix, top-1
  accuracy per class (strict: the named effect is the injected one; fair: on cases whose effect is
  absorbed by the J-A refit, ``none`` is accepted as well, and an equivalent effect is accepted when
  the diagnosis names the truth in ``ambiguous_with``), the false-alarm rate on ``none``, the
  recovered effect size against the truth, and the residual left against the noise floor.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from . import diagnose as dg
from . import effects as fx
from . import io, ja, rig

CLASSES = tuple(e for e in fx.VOCABULARY if e != "unexplained")
SENSOR = "hall1"
KEY_FILENAME = "key.json"  # results/blind/key.json: read by score() only


def case_ids(cfg: dict) -> list[str]:
    """case_000 ... in the order the files are numbered (N = n_per_class * number of classes)."""
    n = int(cfg["n_per_class"]) * len(cfg["classes"])
    width = max(3, len(str(n - 1)))
    return [f"case_{i:0{width}d}" for i in range(n)]


def _loguniform(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _current_path(cfg: dict) -> np.ndarray:
    return ja.paper_current_path(float(cfg["i_max_A"]), int(cfg["n_up"]))


def _truth(rng, cfg) -> dict:
    tb = cfg["truth_box"]
    return {name: _loguniform(rng, *tb[name]) for name in ja.PARAM_NAMES}


def _effect(cls: str, rng, cfg: dict, sigma: float, base_B: np.ndarray, truth: dict):
    """(eparams, magnitude record) of class ``cls`` for one case."""
    m = cfg["magnitude"]
    sign = 1.0 if rng.uniform() < 0.5 else -1.0
    peak = float(np.max(base_B))
    if cls == "hall_offset":
        k = _loguniform(rng, *m["hall_offset_sigmas"])
        return {"offset_T": sign * k * sigma}, {"sigmas": k}
    if cls == "thermal_drift":  # the drift over the whole sweep; divided by its duration by the caller
        k = _loguniform(rng, *m["thermal_drift_sigmas"])
        total = min(k * sigma, float(m["thermal_drift_max_frac"]) * peak)
        return {"drift_T_per_s": sign * total}, {"sigmas": total / sigma}
    if cls == "remanent_start":
        k = _loguniform(rng, *m["remanent_start_sigmas"])
        return {"M0_A_per_m": sign * k * sigma / ja.MU0}, {"sigmas": k}
    if cls == "eddy_lag":
        return {"lag": _loguniform(rng, *m["eddy_lag"])}, {}
    if cls == "sensor_saturation":
        k = _loguniform(rng, *m["sensor_saturation_sigmas"])
        depth = min(k * sigma, float(m["sensor_saturation_max_frac"]) * peak)
        return {"B_sat_T": peak - depth}, {"sigmas": depth / sigma}
    if cls == "air_gap":
        x = _loguniform(rng, *m["air_gap_above_alpha"])
        return {"Nd": truth["alpha"] + x}, {"above_alpha": x}
    return {}, {}


def draw_cases(cfg: dict, diag_cfg: dict | None = None) -> list[dict]:
    """Every case's specification (truth, effect, noise, drive), shuffled and numbered; deterministic in cfg.

    With ``detectable_only`` an effect case is drawn again until its effect is detectable (the rule of
    :func:`detectability`), so that magnitudes run from barely detectable to large and top-1 is scored on
    cases where naming the effect is possible at all (ARCHITECTURE 6)."""
    dcfg = dg.resolve_config(diag_cfg)
    detectable_only = bool(cfg.get("detectable_only", False))
    rng = np.random.default_rng(int(cfg["seed"]))
    current = _current_path(cfg)
    specs = []
    for cls in cfg["classes"]:
        if cls not in CLASSES:
            raise io.InputError(f"blind.classes: {cls!r} is not an injectable effect (expected {CLASSES})")
        made, tries, absorbed = 0, 0, 0
        while made < int(cfg["n_per_class"]):
            tries += 1
            if tries > 200 * int(cfg["n_per_class"]):
                raise io.InputError(f"blind: could not draw {cfg['n_per_class']} cases of class {cls!r} whose J-A "
                                 f"truth integrates" + (" and whose effect is detectable" if detectable_only else "")
                                 + "; check blind.truth_box, blind.n_over_le_ranges and blind.magnitude")
            truth = _truth(rng, cfg)
            ranges = cfg["n_over_le_ranges"]
            nle = _loguniform(rng, *ranges[int(rng.integers(0, len(ranges)))])
            sigma = float(rng.choice(np.asarray(cfg["noise_sigma_T"], dtype=float)))
            dwell = _loguniform(rng, *cfg["dwell_s"])
            time_s = rig.sample_times(current.size, dwell)
            P = ja.as_param_array(truth)
            base_B, ok = rig.observe(P, current, time_s, nle, [], substeps=int(cfg["rig_substeps"]))
            if not ok or not np.all(np.isfinite(base_B)) or np.max(base_B) <= 0:
                continue  # a truth J-A cannot integrate at this drive: draw again
            ep, mag = _effect(cls, rng, cfg, sigma, base_B, truth)
            if cls == "thermal_drift":
                ep["drift_T_per_s"] /= float(time_s[-1] - time_s[0])
            effects = [] if cls == "none" else [(cls, ep)]
            B, ok = rig.observe(P, current, time_s, nle, effects, substeps=int(cfg["rig_substeps"]))
            if not ok or not np.all(np.isfinite(B)):
                continue
            # the sensor's range is chosen for the core's own loop (what a lab would do), not for the effect
            sens = min(float(cfg["sensitivity_V_per_T"]), float(cfg["full_scale_V"]) / float(np.max(np.abs(base_B))))
            sens = float(f"{sens:.2g}")
            spec = {"class": cls, "effects": effects, "truth": truth, "n_over_le": nle,
                    "noise_sigma_T": sigma, "dwell_s": dwell, "sensitivity_V_per_T": sens,
                    "magnitude": mag, "peak_T": float(np.max(base_B)),
                    "noise_seed": int(rng.integers(0, 2**31 - 1))}
            if detectable_only and cls != "none":
                left, _, _ = _plain_refit(spec, cfg, dcfg, B=B, time_s=time_s)
                if not left >= float(cfg["detectable_factor"]) * effective_sigma(spec):
                    absorbed += 1
                    continue  # absorbed by the J-A parameters: nothing to name; draw again
            spec["absorbed_before"], absorbed = absorbed, 0  # the key reports how many draws were absorbed
            specs.append(spec)
            made += 1
    order = rng.permutation(len(specs))
    ids = case_ids(cfg)
    out = []
    for cid, k in zip(ids, order):
        s = dict(specs[k])
        s["id"] = cid
        out.append(s)
    return out


def simulate(spec: dict, cfg: dict):
    """The raw sweep of one case: (volts, time_s, current_A, sidecar), via the rig."""
    current = _current_path(cfg)
    volts, time_s, cur, side = rig.simulate_case(
        ja.as_param_array(spec["truth"]), spec["effects"], spec["noise_sigma_T"], spec["noise_seed"], current,
        n_over_le=spec["n_over_le"], sensor=SENSOR, dwell_s=spec["dwell_s"], substeps=int(cfg["rig_substeps"]),
        sensitivity_V_per_T=spec["sensitivity_V_per_T"], declare_limits=False)
    return volts, time_s, cur, side


def effective_sigma(spec: dict) -> float:
    """Noise of the case as the data carry it: white noise plus ADC quantisation (LSB^2 / 12), in T."""
    q = rig.adc_lsb() / spec["sensitivity_V_per_T"]
    return math.sqrt(spec["noise_sigma_T"] ** 2 + q * q / 12.0)


def _plain_refit(spec: dict, cfg: dict, dcfg: dict, B=None, time_s=None):
    """(RMS left, fit, problem): plain J-A refitted from the true parameters to the noise-free effect-laden loop."""
    current = _current_path(cfg)
    if B is None:
        time_s = rig.sample_times(current.size, spec["dwell_s"])
        B, _ = rig.observe(ja.as_param_array(spec["truth"]), current, time_s, spec["n_over_le"], spec["effects"],
                           substeps=int(cfg["rig_substeps"]))
    P = ja.as_param_array(spec["truth"])
    sw = dg.sweep_from_arrays(current, time_s, B, spec["n_over_le"], cfg=dcfg, source=spec.get("id", "draw"))
    prob = dg.Problem(sw, dcfg, dcfg["form"])
    u = prob.null.copy()
    u[:5] = [math.log(P[0]), math.log(P[1]), P[2], P[3], math.log(P[4])]
    fit = prob.lm(u[None, :], [()], sw.valid.astype(float))[0]
    return (fit.rms if fit.ok else math.inf), fit, prob


def detectability(spec: dict, cfg: dict, diag_cfg: dict | None = None) -> dict:
    """Plain J-A refitted (from the true parameters) to the noise-free effect-laden loop: RMS left vs noise."""
    dcfg = dg.resolve_config(diag_cfg)
    rms_left, fit, prob = _plain_refit(spec, cfg, dcfg)
    sig = effective_sigma(spec)
    out = {"rms_left_T": rms_left if math.isfinite(rms_left) else None, "sigma_eff_T": sig,
           "detectable": bool(spec["class"] != "none" and rms_left >= float(cfg["detectable_factor"]) * sig),
           "alternatives_rms_T": {}, "equivalent_to": []}
    if spec["class"] == "none" or not fit.ok:
        return out
    # every other candidate effect refitted to the same noise-free loop: one that leaves less than
    # equivalent_factor x sigma explains the loop as well as the truth does, and no single sweep can
    # tell the two apart
    others = [e for e in dg.CANDIDATES if e != spec["class"]]
    alt = dg.fit_augmented(prob, [(e,) for e in others], fit)
    for (e,), f in alt.items():
        out["alternatives_rms_T"][e] = f.rms if f.ok else None
        if f.ok and f.rms < float(cfg["equivalent_factor"]) * sig:
            out["equivalent_to"].append(e)
    return out


def true_size(spec: dict) -> tuple[str, float] | tuple[None, None]:
    """(contract parameter, value) of the injected effect, as the diagnosis reports it."""
    if not spec["effects"]:
        return None, None
    name, ep = spec["effects"][0]
    if name == "air_gap":  # the diagnosis reports the smallest Nd that explains alpha' (with alpha = 0)
        ae = float(fx.air_gap_alpha(spec["truth"]["alpha"], ep["Nd"]))
        return "Nd", max(0.0, -ae / (1.0 - ae))
    key = fx.EFFECTS[name].params[0]
    return key, float(ep[key])


def generate(cfg: dict, out_dir, key_path, diag_cfg: dict | None = None) -> dict:
    """Write every case (raw sweep CSV + sidecar) into out_dir and the key to key_path; return the key."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    specs = draw_cases(cfg, diag_cfg)
    cases = {}
    for s in specs:
        volts, time_s, cur, side = simulate(s, cfg)
        rig.write_case(out_dir / f"{s['id']}.csv", volts, time_s, cur, side)
        det = detectability(s, cfg, diag_cfg)
        pname, pval = true_size(s)
        cases[s["id"]] = {
            "class": s["class"],
            "effect_params": dict(s["effects"][0][1]) if s["effects"] else {},
            "size_param": pname,
            "size_value": pval,
            "truth": s["truth"],
            "n_over_le": s["n_over_le"],
            "noise_sigma_T": s["noise_sigma_T"],
            "sigma_eff_T": det["sigma_eff_T"],
            "dwell_s": s["dwell_s"],
            "sensitivity_V_per_T": s["sensitivity_V_per_T"],
            "peak_T": s["peak_T"],
            "magnitude": s["magnitude"],
            "rms_left_T": det["rms_left_T"],
            "detectable": det["detectable"],
            "alternatives_rms_T": det["alternatives_rms_T"],
            "equivalent_to": det["equivalent_to"],
            "noise_seed": s["noise_seed"],
            "absorbed_draws_before": s["absorbed_before"],
        }
    key = {"cases": cases, "settings": {k: cfg[k] for k in sorted(cfg)},
           "detectable_rule": (f"plain J-A refitted from the true parameters to the noise-free effect-laden loop "
                               f"leaves RMS >= {cfg['detectable_factor']} x sigma_eff (white noise + ADC LSB^2/12)")}
    io.write_json(key, key_path)
    return key


# --------------------------------------------------------------------------------------------
# scoring (the only reader of the key)
# --------------------------------------------------------------------------------------------
def _rate(hits, n):
    return hits / n if n else None


_DIAG_FIELDS = ("effect", "rms_before_T", "rms_after_T", "noise_floor_T")  # what score reads of a diagnosis


def score(diag_paths, key_path, cfg: dict) -> dict:
    """Score the diagnoses in ``diag_paths`` (one JSON per case, named <case id>.json) against the key."""
    key = io.read_json(key_path)
    if not (isinstance(key, dict) and isinstance(key.get("cases"), dict)):
        raise io.InputError(f"{key_path}: not a blind key (expected an object with 'cases', as blind generate writes)")
    key = key["cases"]
    default_sigma = float(cfg["default_noise_sigma_T"])
    factor = float(cfg["residual_factor"])
    labels = list(CLASSES) + ["unexplained"]
    rows = []
    for p in diag_paths:
        cid = Path(p).stem
        if cid not in key:
            raise io.InputError(f"{p}: case {cid!r} is not in the key {key_path}")
        d = io.read_json(p)
        missing = [f for f in _DIAG_FIELDS if not isinstance(d, dict) or f not in d]
        if missing:
            raise io.InputError(f"{p}: not a diagnosis (missing {', '.join(missing)}; expected mrhyst diagnose output)")
        k = key[cid]
        truth, pred = k["class"], d["effect"]
        amb = list(d.get("ambiguous_with", []))
        strict = pred == truth
        # an effect that another candidate explains as well on the noise-free loop: naming that other one
        # is fair when the diagnosis says the two cannot be told apart (truth in ambiguous_with)
        stand_in = pred in k.get("equivalent_to", []) and truth in amb
        if truth == "none":
            fair = pred == "none"
        elif k["detectable"]:
            fair = strict or stand_in
        else:
            fair = pred in (truth, "none") or stand_in
        size = d.get("effect_size") or {}
        rec = {"id": cid, "class": truth, "predicted": pred, "ambiguous_with": amb, "detectable": k["detectable"],
               "strict": strict, "fair": fair, "in_ambiguous": pred == truth or truth in amb,
               "noise_sigma_T": k["noise_sigma_T"], "sigma_eff_T": k["sigma_eff_T"],
               "default_noise": math.isclose(k["noise_sigma_T"], default_sigma, rel_tol=1e-9),
               "rms_before_T": d["rms_before_T"], "rms_after_T": d["rms_after_T"],
               "noise_floor_T": d["noise_floor_T"], "rms_left_T": k["rms_left_T"], "n_over_le": k["n_over_le"],
               "after_over_floor": d["rms_after_T"] / d["noise_floor_T"] if d["noise_floor_T"] > 0 else None,
               "after_over_sigma": d["rms_after_T"] / k["sigma_eff_T"],
               "size_param": k["size_param"], "size_true": k["size_value"],
               "size_fit": size.get("value") if strict else None, "size_stderr": size.get("stderr") if strict else None}
        rec["residual_ok"] = rec["after_over_floor"] is not None and rec["after_over_floor"] <= factor
        if rec["size_fit"] is not None and rec["size_true"]:
            rec["size_ratio"] = rec["size_fit"] / rec["size_true"]
            se = rec["size_stderr"]
            rec["size_z"] = (rec["size_fit"] - rec["size_true"]) / se if se else None
        rows.append(rec)
    rows.sort(key=lambda r: r["id"])

    def summary(sel):
        n = len(sel)
        none_cases = [r for r in sel if r["class"] == "none"]
        det = [r for r in sel if r["class"] != "none" and r["detectable"]]
        return {
            "n": n,
            "top1_strict": _rate(sum(r["strict"] for r in sel), n),
            "top1_fair": _rate(sum(r["fair"] for r in sel), n),
            "top1_detectable": _rate(sum(r["strict"] for r in det), len(det)),
            "n_detectable": len(det),
            "top1_or_ambiguous": _rate(sum(r["in_ambiguous"] for r in sel), n),
            "false_alarm_none": _rate(sum(r["predicted"] != "none" for r in none_cases), len(none_cases)),
            "residual_within_factor": _rate(sum(r["residual_ok"] for r in sel), n),
            "residual_within_factor_of_true_sigma": _rate(sum(r["after_over_sigma"] <= factor for r in sel), n),
        }

    per_class = {}
    for cls in cfg["classes"]:
        sel = [r for r in rows if r["class"] == cls]
        s = summary(sel)
        sizes = [r for r in sel if r.get("size_ratio") is not None]
        if sizes:
            ratios = np.array([r["size_ratio"] for r in sizes])
            zs = np.array([r["size_z"] for r in sizes if r.get("size_z") is not None])
            s["size_ratio_median"] = float(np.median(ratios))
            s["size_ratio_iqr"] = [float(np.percentile(ratios, 25)), float(np.percentile(ratios, 75))]
            s["size_z_rms"] = float(np.sqrt(np.mean(zs**2))) if zs.size else None
        s["detectable_frac"] = _rate(sum(r["detectable"] for r in sel), len(sel)) if cls != "none" else None
        # draws of this class thrown away before the scored ones because J-A absorbed the effect (detectable_only)
        s["absorbed_draws"] = sum(int(key[r["id"]].get("absorbed_draws_before", 0)) for r in sel)
        per_class[cls] = s
    confusion = {t: {p: 0 for p in labels} for t in cfg["classes"]}
    for r in rows:
        confusion[r["class"]][r["predicted"]] += 1
    confusions = [{"truth": r["class"], "predicted": r["predicted"], "id": r["id"], "detectable": r["detectable"],
                   "ambiguous_with": r["ambiguous_with"], "noise_sigma_T": r["noise_sigma_T"],
                   "n_over_le": r["n_over_le"], "rms_left_over_sigma": (r["rms_left_T"] / r["sigma_eff_T"]
                                                                       if r["rms_left_T"] is not None else None)}
                  for r in rows if not r["fair"]]
    # every strict miss in one of four kinds (the report explains the score with them)
    kinds = {"none_on_undetectable": 0, "none_on_detectable": 0, "other_flagged_ambiguous": 0, "other_unflagged": 0,
             "pairs": {}}
    for r in rows:
        if r["strict"]:
            continue
        if r["predicted"] == "none":
            kinds["none_on_detectable" if r["detectable"] else "none_on_undetectable"] += 1
        else:
            kinds["other_flagged_ambiguous" if r["class"] in r["ambiguous_with"] else "other_unflagged"] += 1
            pair = f"{r['class']} -> {r['predicted']}"
            kinds["pairs"][pair] = kinds["pairs"].get(pair, 0) + 1
    kinds["pairs"] = dict(sorted(kinds["pairs"].items()))
    return {
        "overall": summary(rows),
        "strict_misses": kinds,
        "detectable_factor": float(cfg["detectable_factor"]),
        "detectable_only": bool(cfg.get("detectable_only", False)),
        "default_noise": summary([r for r in rows if r["default_noise"]]),
        "per_class": per_class,
        "confusion": confusion,
        "classes": list(cfg["classes"]),
        "labels": labels,
        "misses": confusions,
        "cases": rows,
        "goals": {"top1": 0.95, "false_alarm_none": 0.05, "residual_within_factor": 0.90, "factor": factor},
    }
