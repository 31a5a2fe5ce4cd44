"""The paper's damper after use (issue 24, point 5): a blind benchmark of reference mode.

The reference is the paper's Table 1 model (config ``aftercare.reference``, e.g. ``table1:group1_pso``); every case
is a virtual-rig sweep (:func:`mrhyst.rig.simulate_case`: J-A truth -> effects -> A1304 -> noise -> ADC) of the
SAME damper after one change: the core heated (Ms lower by a drawn ratio), the gap shifted (an added demagnetising
factor Nd), the Hall sensor drifted (a thermal drift of its zero) or offset, the flux lagging (eddy currents), or
nothing changed. :func:`generate` writes the cases (raw sweep + sidecar, anonymous ids) and, apart, the key;
:func:`diagnose_cases` runs ``mrhyst diagnose CASE --sensor hall1 --reference REF`` on each case from its own files
(never the key); :func:`score` alone reads the key: the change named, and its size against the truth.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mrhyst.data import io
from mrhyst.model import ja

CHANGES = ("none", "core_temperature", "air_gap", "thermal_drift", "hall_offset", "eddy_lag")
SIZE_PARAM = {"core_temperature": "Ms_ratio", "air_gap": "Nd", "thermal_drift": "drift_T_per_s",
              "hall_offset": "offset_T", "eddy_lag": "lag"}


def aftercare_config(config=None):
    """The aftercare section, frozen (mrhyst.settings.frozen)."""
    from mrhyst.settings import frozen

    return frozen(config, "aftercare")


def current_path(cfg: dict) -> np.ndarray:
    from mrhyst.blind.cases import current_path as blind_path

    return blind_path({"i_max_A": cfg["i_max_A"], "n_up": cfg["n_up"], "protocol": cfg["protocol"]})


def _draw(rng, lo, hi, log: bool) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi)))) if log else float(rng.uniform(lo, hi))


def apply_change(change: str, size: dict, ref) -> tuple[np.ndarray, list]:
    """(truth J-A parameters, rig effects) of the damper of parameters ``ref`` after ``change`` of ``size``
    ({SIZE_PARAM[change]: value}): a heated core scales Ms, every other change is the rig's effect of that name.
    The one place a change becomes the rig's input (the aftercare cases and mrhyst.diagnose.later use it)."""
    p = np.array(ref, dtype=float)
    if change not in CHANGES:
        raise ValueError(f"aftercare: no change {change!r} (have {', '.join(CHANGES)})")
    if change == "none":
        return p, []
    x = float(size[SIZE_PARAM[change]])
    if change == "core_temperature":
        p[0] *= x
        return p, []
    return p, [(change, {SIZE_PARAM[change]: x})]


def _draw_size(rng, change: str, cfg: dict, peak_T: float) -> dict:
    r = cfg["ranges"]
    if change == "none":
        return {}
    if change == "core_temperature":
        return {"Ms_ratio": _draw(rng, *r["Ms_ratio"], False)}
    if change == "air_gap":
        return {"Nd": _draw(rng, *r["Nd"], True)}
    if change == "thermal_drift":
        return {"drift_T_per_s": _draw(rng, *r["drift_T_per_s"], True) * (1 if rng.uniform() < 0.5 else -1)}
    if change == "hall_offset":
        return {"offset_T": _draw(rng, *r["offset_frac_peak"], False) * peak_T * (1 if rng.uniform() < 0.5 else -1)}
    if change == "eddy_lag":
        return {"lag": _draw(rng, *r["lag"], False)}
    raise ValueError(f"aftercare: no change {change!r} (have {', '.join(CHANGES)})")


def draw_change(rng, change: str, cfg: dict, ref: np.ndarray, peak_T: float) -> tuple[np.ndarray, list, dict]:
    """(truth J-A parameters, rig effects, the truth's size) of one case."""
    size = _draw_size(rng, change, cfg, peak_T)
    return (*apply_change(change, size, ref), size)


def case_ids(cfg: dict) -> list[str]:
    n = len(CHANGES) * int(cfg["n_per_change"])
    return [f"after_{i:03d}" for i in range(n)]


def generate(cfg: dict, ref_params, n_over_le: float, cases_dir, key_path) -> dict:
    """Write every case (CSV + sidecar) into ``cases_dir`` and the key to ``key_path``; the cases in a shuffled
    order, so that an id says nothing of its change."""
    from mrhyst import rig

    rng = np.random.default_rng(int(cfg["seed"]))
    cur = current_path(cfg)
    ref = np.asarray(ref_params, dtype=float)
    B0, ok = ja.simulate(ref, cur, float(n_over_le), **rig.kernel())  # the rig's own integration
    peak = float(np.max(np.abs(B0)))
    plan = [c for c in CHANGES for _ in range(int(cfg["n_per_change"]))]
    order = rng.permutation(len(plan))
    key = {"reference": cfg["reference"], "n_over_le": float(n_over_le), "settings": dict(cfg), "cases": {}}
    Path(cases_dir).mkdir(parents=True, exist_ok=True)
    for cid, j in zip(case_ids(cfg), order):
        change = plan[j]
        p, eff, size = draw_change(rng, change, cfg, ref, peak)
        V, t, I, side = rig.simulate_case(p, eff, float(cfg["noise_sigma_T"]), rng, cur, n_over_le=float(n_over_le),
                                        dwell_s=float(cfg["dwell_s"]))
        side = dict(side, provenance=rig.PROVENANCE)  # the figures mark the sweep synthetic (plotstyle)
        rig.write_case(Path(cases_dir) / f"{cid}.csv", V, t, I, side)
        key["cases"][cid] = {"change": change, "size": size, "truth": ja.as_param_dict(p)}
    io.write_json(key, key_path)
    return key


def diagnose_cases(cases, outs, reference: str, config: dict | None = None, log=print) -> None:
    """Reference-mode diagnosis of each case from its own files (the key is never read)."""
    import time

    from mrhyst.diagnose import refdiag

    cfg = None if config is None else config.get("diagnose")
    paper = None if config is None else config.get("paper")
    rc = refdiag.ref_config(config)
    for c, o in zip(cases, outs):
        t0 = time.perf_counter()
        d = refdiag.reference_file(c, reference, sensor="hall1", config=cfg, paper=paper, rcfg=rc)
        io.write_json(d, o)
        log(f"{Path(c).name}: {d['effect']} in {time.perf_counter() - t0:.2f} s")


def draw_figures(diag_paths, png_paths, log=print) -> None:
    """The figure of each reference diagnosis (mrhyst.report.diagfig: what `mrhyst diagnose ... --figure` draws),
    from its JSON alone (never the key), the case id in the title; in one process, as matplotlib starts once."""
    import time

    from mrhyst.data.io import read_json
    from mrhyst.report import diagfig

    for d, png in zip(map(Path, diag_paths), png_paths):
        t0 = time.perf_counter()
        diagfig.save(read_json(d), png, name=d.stem)
        log(f"{Path(png).name} in {time.perf_counter() - t0:.2f} s")


def summaries(diag_paths) -> dict:
    """{case id: the plain summary `mrhyst diagnose` prints} of each reference diagnosis (the report's appendix)."""
    from mrhyst.data.io import read_json
    from mrhyst.report.summary import diagnosis_summary

    return {Path(p).stem: diagnosis_summary(read_json(p)) for p in diag_paths}


def size_error(change: str, truth: dict, size: dict | None) -> float | None:
    """Relative error of the named size: of the Ms change (1 - ratio) for a heated core, else of the size."""
    if not size or size.get("value") is None or change not in SIZE_PARAM:
        return None
    t = truth[SIZE_PARAM[change]]
    v = float(size["value"])
    if change == "core_temperature":
        return abs((1 - v) - (1 - t)) / abs(1 - t)
    return abs(v - t) / abs(t)


def score(diag_paths, key_path, tol: float) -> dict:
    """The change named (top-1), its size within ``tol``, per change and overall."""
    key = io.read_json(key_path)["cases"]
    rows = []
    for p in map(Path, diag_paths):
        d = io.read_json(p)
        k = key[p.stem]
        right = d["effect"] == k["change"]
        err = size_error(k["change"], k["size"], d.get("effect_size")) if right else None
        rows.append({"case": p.stem, "change": k["change"], "named": d["effect"],
                     "ambiguous_with": d.get("ambiguous_with") or [], "right": right, "size_truth": k["size"],
                     "size": (d.get("effect_size") or {}).get("value"), "size_error": err,
                     "size_ok": None if err is None else bool(err <= tol), "rms_before_T": d["rms_before_T"],
                     "rms_after_T": d["rms_after_T"]})
    per = {}
    for c in CHANGES:
        rs = [r for r in rows if r["change"] == c]
        errs = [r["size_error"] for r in rs if r["size_error"] is not None]
        per[c] = {"n": len(rs), "named": sum(r["right"] for r in rs),
                  "size_within_tol": sum(bool(r["size_ok"]) for r in rs),
                  "size_error_max": max(errs) if errs else None}
    n = len(rows)
    return {"n": n, "named_frac": sum(r["right"] for r in rows) / n if n else None, "size_tol": tol,
            "per_change": per, "cases": sorted(rows, key=lambda r: r["case"])}
