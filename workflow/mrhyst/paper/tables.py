"""Error measures (Table 2), objective values at fixed iterations (Table 3), the side-by-side tables
with the paper's values, seed spread, identifiability, and a consistency check of the paper's own
numbers.

Definitions (Li & Gong 2019 name the measures but do not define them; choices in config ``metrics``):

* e_i = B_m,i - B_d,i over the valid (unsaturated) samples;
* J (Eq. 15) = sqrt(mean e_i^2);
* max absolute error = max |e_i|; mean ("average") error = mean |e_i|;
* relative error, ``relative: peak`` (default): |e_i| / max_i |B_m,i|, i.e. relative to the peak of
  the measured loop. The pointwise |e_i| / |B_m,i| is undefined at the virgin start (B = 0 at 0 A).
  The paper's own Table 2 supports the peak definition: max_abs / max_rel and mean_abs / mean_rel
  give 0.083-0.097 T for group 1 and 0.042-0.044 T for group 2, its stated peaks 0.09 / 0.045 T
  (see :func:`paper_consistency_findings`);
* ``relative: pointwise``: |e_i| / |B_m,i| over the samples with |B_m,i| >= floor_frac * peak only.
  Both are always reported (``max_rel_pointwise``, ``mean_rel_pointwise``); ``max_rel`` /
  ``mean_rel`` follow the configured definition.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mrhyst.settings import schema_or

if TYPE_CHECKING:
    import pandas

PARAM_NAMES = ("Ms", "a", "alpha", "c", "k")
T2_KEYS = ("max_abs_T", "max_rel", "mean_abs_T", "mean_rel")


def _frame(rows: list):
    import pandas  # the tables only: a fit, which uses the error measures, starts without it (issue 26)

    return pandas.DataFrame(rows)


# --------------------------------------------------------------------------------------------
# error measures
# --------------------------------------------------------------------------------------------
def rms(B_meas, B_model, valid=None) -> float:
    """J of Eq. (15): sqrt(sum (B_m - B_d)^2 / N) over the valid samples."""
    Bm, Bd = np.asarray(B_meas, float), np.asarray(B_model, float)
    v = np.ones(Bm.size, bool) if valid is None else np.asarray(valid, bool)
    e = Bm[v] - Bd[v]
    return float(np.sqrt(np.mean(e * e)))


def error_measures(B_meas, B_model, valid=None, *, relative: str | None = None,
                   floor_frac: float | None = None) -> dict:
    """Table 2's four measures plus J and the alternative relative-error definition (relative, floor_frac not
    given: config metrics's schema defaults, relative and pointwise_floor_frac).

    relative: 'peak' -> |e| / max|B_m|; 'pointwise' -> |e| / |B_m| where |B_m| >= floor_frac * max|B_m|.
    """
    s = schema_or("metrics", relative=relative, pointwise_floor_frac=floor_frac)
    relative, floor_frac = s["relative"], s["pointwise_floor_frac"]
    if relative not in ("peak", "pointwise"):
        raise ValueError(f"relative must be 'peak' or 'pointwise', got {relative!r}")
    Bm, Bd = np.asarray(B_meas, float), np.asarray(B_model, float)
    if Bm.shape != Bd.shape:
        raise ValueError(f"B_meas and B_model differ in shape: {Bm.shape} vs {Bd.shape}")
    v = np.ones(Bm.size, bool) if valid is None else np.asarray(valid, bool)
    bm, bd = Bm[v], Bd[v]
    if bm.size == 0:
        raise ValueError("no valid samples")
    e = np.abs(bm - bd)
    peak = float(np.max(np.abs(bm)))
    # undefined relative errors (an all-zero measured loop) are None, never NaN
    keep = (np.abs(bm) >= floor_frac * peak) & (np.abs(bm) > 0)
    rel_peak = e / peak if peak > 0 else None
    rel_pw = e[keep] / np.abs(bm[keep]) if keep.any() else None
    out = {
        "rms_T": float(np.sqrt(np.mean(e * e))),
        "max_abs_T": float(e.max()),
        "mean_abs_T": float(e.mean()),
        "max_rel_peak": None if rel_peak is None else float(np.max(rel_peak)),
        "mean_rel_peak": None if rel_peak is None else float(np.mean(rel_peak)),
        "max_rel_pointwise": None if rel_pw is None else float(np.max(rel_pw)),
        "mean_rel_pointwise": None if rel_pw is None else float(np.mean(rel_pw)),
        "n_pointwise": int(keep.sum()),
        "peak_T": peak,
        "n": int(bm.size),
        "relative": relative,
        "pointwise_floor_frac": float(floor_frac),
    }
    out["max_rel"] = out["max_rel_peak" if relative == "peak" else "max_rel_pointwise"]
    out["mean_rel"] = out["mean_rel_peak" if relative == "peak" else "mean_rel_pointwise"]
    return out


def j_at_iteration(history, iteration: int) -> tuple[float, bool]:
    """(J after ``iteration`` iterations (1-based), converged_before) from a history.

    If the optimiser stopped earlier (LSM converged), J stays at its final value and the flag is
    True.
    """
    h = list(history)
    if not h:
        raise ValueError("empty history")
    if iteration < 1:
        raise ValueError("iteration counts from 1")
    if iteration <= len(h):
        return float(h[iteration - 1]), False
    return float(h[-1]), True


def _iterations(iterations) -> tuple:
    return tuple(int(i) for i in schema_or("metrics", iterations=iterations)["iterations"])


def table3_values(history, iterations=None) -> dict:
    """{'it20': J, 'it50': J, 'it20_after_stop': bool, ...} (Table 3; ``iterations``: None = config
    metrics.iterations, the schema's)."""
    out = {}
    for it in _iterations(iterations):
        v, stopped = j_at_iteration(history, it)
        out[f"it{it}"] = v
        out[f"it{it}_after_stop"] = stopped
    return out


# --------------------------------------------------------------------------------------------
# loading and selecting fits
# --------------------------------------------------------------------------------------------
def load_fits(paths) -> list[dict]:
    """Fit JSONs -> list of dicts (each with '_path')."""
    import json

    out = []
    for p in paths:
        d = json.loads(Path(p).read_text())
        d["_path"] = str(p)
        out.append(d)
    return out


def fit_key(fit: dict) -> tuple:
    """(group, method, setting) of a fit dict."""
    method = fit.get("method", "?")
    setting = fit.get("setting") or ("paper" if method == "pso" else method)
    return (fit.get("group"), method, setting)


def group_fits(fits) -> dict:
    out: dict = {}
    for f in fits:
        out.setdefault(fit_key(f), []).append(f)
    for k in out:
        out[k].sort(key=lambda f: (f.get("seed") is None, f.get("seed") if f.get("seed") is not None else 0))
    return out


def median_fit(fits: list[dict]) -> dict:
    """The fit with the median J over seeds (lower median for an even count; ties -> smaller seed)."""
    if not fits:
        raise ValueError("no fits")
    order = sorted(fits, key=lambda f: (f["rms_T"], f.get("seed") if f.get("seed") is not None else -1))
    return order[(len(order) - 1) // 2]


def select_median(fits) -> dict:
    """{(group, method, setting): median-J fit}."""
    return {k: median_fit(v) for k, v in group_fits(fits).items()}


# --------------------------------------------------------------------------------------------
# the paper-vs-ours tables (long format)
# --------------------------------------------------------------------------------------------
def _row(group, method, setting, quantity, paper, ours, **extra):
    paper = None if paper is None else float(paper)
    ours = None if ours is None else float(ours)
    diff = None if (paper is None or ours is None) else ours - paper
    rel = None if (diff is None or paper == 0) else diff / abs(paper)
    return {"group": group, "method": method, "setting": setting, "quantity": quantity, "paper": paper,
            "ours": ours, "diff": diff, "rel_diff": rel, **extra}


def _paper_method(method: str) -> str:
    return "lsm" if method == "lsm" else "pso"


def table1(selected: dict, paper: dict) -> pandas.DataFrame:
    """Parameters: paper Table 1 beside the median-J fit of each (group, method, setting)."""
    rows = []
    t1 = paper.get("table1", {})
    for (g, m, s), fit in sorted(selected.items(), key=lambda kv: tuple(str(x) for x in kv[0])):
        pp = t1.get(g, {}).get(_paper_method(m), {})
        for q in PARAM_NAMES:
            rows.append(_row(g, m, s, q, pp.get(q), fit["params"][q], seed=fit.get("seed")))
    return _frame(rows)


def table2(selected: dict, paper: dict) -> pandas.DataFrame:
    """Error measures: paper Table 2 beside ours (definitions in the module docstring)."""
    rows = []
    t2 = paper.get("table2", {})
    for (g, m, s), fit in sorted(selected.items(), key=lambda kv: tuple(str(x) for x in kv[0])):
        pp = t2.get(g, {}).get(_paper_method(m), {})
        mt = fit.get("metrics") or {}
        for q in T2_KEYS:
            rows.append(_row(g, m, s, q, pp.get(q), mt.get(q), seed=fit.get("seed"),
                             relative=mt.get("relative")))
        rows.append(_row(g, m, s, "rms_T", None, fit.get("rms_T"), seed=fit.get("seed")))
    return _frame(rows)


def table3(selected: dict, paper: dict, iterations=None) -> pandas.DataFrame:
    """J after 20 and 50 iterations: paper Table 3 beside ours (after_stop: the optimiser had
    already stopped, the value is its final J)."""
    rows = []
    t3, iterations = paper.get("table3", {}), _iterations(iterations)
    for (g, m, s), fit in sorted(selected.items(), key=lambda kv: tuple(str(x) for x in kv[0])):
        pp = t3.get(g, {}).get(_paper_method(m), {})
        vals = table3_values(fit["history"], iterations)
        for it in iterations:
            rows.append(_row(g, m, s, f"J_it{it}_T", pp.get(f"it{it}"), vals[f"it{it}"], seed=fit.get("seed"),
                             after_stop=vals[f"it{it}_after_stop"], n_iterations=len(fit["history"])))
    return _frame(rows)


def seed_spread_table(fits) -> pandas.DataFrame:
    """Per (group, method, setting): min / median / max over seeds of J and of each parameter."""
    rows = []
    for (g, m, s), fl in sorted(group_fits(fits).items(), key=lambda kv: tuple(str(x) for x in kv[0])):
        med = median_fit(fl)
        for q in ("rms_T",) + PARAM_NAMES:
            v = np.array([f["rms_T"] if q == "rms_T" else f["params"][q] for f in fl], float)
            md = float(np.median(v))
            rows.append({"group": g, "method": m, "setting": s, "quantity": q, "n_seeds": len(fl),
                         "min": float(v.min()), "median": md, "max": float(v.max()),
                         "rel_range": float((v.max() - v.min()) / abs(md)) if md != 0 else None,
                         "median_seed_value": float(med["rms_T"] if q == "rms_T" else med["params"][q]),
                         "median_seed": med.get("seed")})
    return _frame(rows)


def identifiability_table(profiles, fits=()) -> pandas.DataFrame:
    """Per parameter: the profile's range where J <= threshold * J_min (relative width, open ends =
    box edge), the curvature-based relative standard error, and (if fits are given) the spread over
    seeds of the same (group, method, setting)."""
    spread = {}
    for (g, m, s), fl in group_fits(list(fits)).items():
        for q in PARAM_NAMES:
            v = np.array([f["params"][q] for f in fl], float)
            md = float(np.median(v))
            spread[(g, m, s, q)] = (len(fl), float((v.max() - v.min()) / abs(md)) if md else None)
    rows = []
    for pr in profiles:
        key = fit_key(pr)
        box = pr.get("box") or {}
        for q in PARAM_NAMES:
            p = pr["params"][q]
            n, rr = spread.get(key + (q,), (None, None))
            x = pr["x_opt"][q]
            lo, hi = (box.get("lo") or {}).get(q), (box.get("hi") or {}).get(q)
            edge = None if lo is None or hi is None else bool(
                x <= lo + 1e-6 * (hi - lo) or x >= hi - 1e-6 * (hi - lo))
            rows.append({"group": key[0], "method": key[1], "setting": key[2], "parameter": q,
                         "x_opt": x, "x_opt_at_box_edge": edge, "J_opt_T": pr["J_opt_T"],
                         "threshold": pr["threshold"],
                         "range_lo": p["range_lo"], "range_hi": p["range_hi"],
                         "range_open_lo": p["range_open_lo"], "range_open_hi": p["range_open_hi"],
                         "rel_width": p["rel_width"], "rel_se_curvature": p["rel_se_curvature"],
                         "profile_J_min_T": p["J_min_T"], "seed_rel_range": rr, "n_seeds": n,
                         "condition_rel": pr.get("condition_rel")})
    return _frame(rows)


def make_tables(fit_paths, paper: dict, out_dir, profile_paths=(), iterations=None) -> dict:
    """Write table1/2/3.csv, seed_spread.csv and (with profiles) identifiability.csv; return paths."""
    from mrhyst.data.io import write_csv

    fits = load_fits(fit_paths)
    sel = select_median(fits)
    out_dir = Path(out_dir)
    out = {}
    for name, df in (("table1", table1(sel, paper)), ("table2", table2(sel, paper)),
                     ("table3", table3(sel, paper, iterations)), ("seed_spread", seed_spread_table(fits))):
        p = out_dir / f"{name}.csv"
        write_csv(df, p)
        out[name] = p
    if profile_paths:
        profs = load_fits(profile_paths)
        p = out_dir / "identifiability.csv"
        write_csv(identifiability_table(profs, fits), p)
        out["identifiability"] = p
    return out


# --------------------------------------------------------------------------------------------
# the paper's numbers against each other
# --------------------------------------------------------------------------------------------
def _interval(v: float) -> tuple[float, float]:
    """The interval a printed value stands for, assuming it is rounded to two significant digits
    (Table 2 and 3 print 2-3; two is the conservative, wider reading)."""
    v = float(v)
    if v == 0:
        return 0.0, 0.0
    e = math.floor(math.log10(abs(v))) - 1
    h = 0.5 * 10.0**e
    return v - h, v + h


def paper_consistency_findings(paper: dict) -> list[dict]:
    """Checks of Tables 2 and 3 (and the stated peaks) against each other, assuming, as the paper
    implies, that both tables describe the same fit on the same N = 53 samples.

    For any error vector: mean|e| <= RMS = J <= sqrt(max|e| * mean|e|) <= max|e|
    (the upper bound: sum e^2 <= max|e| * sum |e|). Each check widens the printed values by their
    rounding. Returns a list of {"check", "group", "method", "ok", "text", numbers...}.
    """
    out = []
    t2, t3 = paper.get("table2", {}), paper.get("table3", {})
    n = 2 * int(paper.get("n_up", 27)) - 1  # samples on the paper's path (53)
    for g in sorted(t2):
        for m in sorted(t2[g]):
            if g not in t3 or m not in t3[g]:
                continue
            e = t2[g][m]
            out += _rms_bound_checks(g, m, e, t3[g][m], n)
            if e.get("max_rel") and e.get("mean_rel"):
                out.append(_relative_denominator_check(g, m, e, paper.get("peak_B_T", {}).get(g)))
    for g in sorted(t3):
        if "lsm" in t3[g] and "pso" in t3[g] and g in t2 and "lsm" in t2[g] and "pso" in t2[g]:
            out.append(_lsm_pso_ratio_check(g, t2[g], t3[g]))
    return out


def _rms_bound_checks(g: str, m: str, e: dict, t3gm: dict, n: int) -> list[dict]:
    """Table 3's J (both iterations) inside [mean|e|, sqrt(max|e| mean|e|)] of Table 2; and the one reading
    that would reconcile a too-small J: sqrt(sum e^2) / N instead of Eq. (15)'s sqrt(sum e^2 / N)."""
    out = []
    mean_lo, mean_hi = _interval(e["mean_abs_T"])
    _, max_hi = _interval(e["max_abs_T"])
    upper = math.sqrt(max_hi * mean_hi)
    for it in ("it20", "it50"):
        J = float(t3gm[it])
        J_lo, J_hi = _interval(J)
        ok_low, ok_up = J_hi >= mean_lo, J_lo <= upper
        out.append({
            "check": "rms_vs_mean_abs", "group": g, "method": m, "iteration": it, "ok": bool(ok_low),
            "J_T": J, "mean_abs_T": e["mean_abs_T"], "ratio": J / e["mean_abs_T"],
            "text": (f"{g} {m.upper()}: Table 3 J({it[2:]}) = {J:.3g} T "
                     f"{'>=' if ok_low else '<'} Table 2 mean abs error {e['mean_abs_T']:.2g} T; "
                     + ("consistent (RMS >= mean |e|)." if ok_low else
                        f"impossible for one fit on the same samples: RMS >= mean |e| always "
                        f"(J is {J / e['mean_abs_T']:.2f} x the mean abs error).")),
        })
        out.append({
            "check": "rms_vs_max_abs", "group": g, "method": m, "iteration": it, "ok": bool(ok_up),
            "J_T": J, "upper_bound_T": upper, "max_abs_T": e["max_abs_T"],
            "text": (f"{g} {m.upper()}: Table 3 J({it[2:]}) = {J:.3g} T "
                     f"{'<=' if ok_up else '>'} sqrt(max abs x mean abs) = {upper:.3g} T "
                     f"(Table 2); " + ("consistent." if ok_up else
                                       "impossible for one fit on the same samples "
                                       "(sum e^2 <= max|e| sum|e|)")
                     + (f". J also exceeds the max abs error {e['max_abs_T']:.2g} T itself."
                        if J_lo > max_hi else "")),
        })
    J = float(t3gm["it50"])
    J_lo, J_hi = _interval(J)
    ok_alt = J_hi * math.sqrt(n) >= mean_lo and J_lo * math.sqrt(n) <= upper
    out.append({
        "check": "rms_over_sqrtN_reading", "group": g, "method": m, "ok": bool(ok_alt),
        "J_times_sqrtN_T": J * math.sqrt(n), "feasible_lo_T": mean_lo, "feasible_hi_T": upper, "N": n,
        "text": (f"{g} {m.upper()}: if Table 3 printed sqrt(sum e^2)/N (= RMS/sqrt(N), N = {n}), the RMS "
                 f"would be {J * math.sqrt(n):.3g} T, "
                 + ("inside" if ok_alt else "outside")
                 + f" the range Table 2 allows [{mean_lo:.3g}, {upper:.3g}] T."),
    })
    return out


def _relative_denominator_check(g: str, m: str, e: dict, pk) -> dict:
    """Table 2's abs/rel pairs imply the denominator of its relative errors: is it the stated peak B?"""
    d_max = e["max_abs_T"] / e["max_rel"]
    d_mean = e["mean_abs_T"] / e["mean_rel"]
    ok = pk is not None and abs(d_max - pk) <= 0.15 * pk and abs(d_mean - pk) <= 0.15 * pk
    return {
        "check": "relative_error_denominator", "group": g, "method": m, "ok": bool(ok),
        "implied_from_max_T": d_max, "implied_from_mean_T": d_mean, "peak_T": pk,
        "text": (f"{g} {m.upper()}: abs/rel gives {d_max:.3g} T (max) and {d_mean:.3g} T (mean); "
                 f"stated peak {pk} T: the relative errors are "
                 + ("consistent with |e| / peak B (our 'peak' definition)."
                    if ok else "not explained by |e| / peak B.")),
    }


def _lsm_pso_ratio_check(g: str, t2g: dict, t3g: dict) -> dict:
    """LSM/PSO in Table 3's J against LSM/PSO in Table 2's mean abs error (a factor 3 apart: inconsistent)."""
    rj = t3g["lsm"]["it50"] / t3g["pso"]["it50"]
    rm = t2g["lsm"]["mean_abs_T"] / t2g["pso"]["mean_abs_T"]
    ok = abs(math.log(rj / rm)) < math.log(3.0)
    return {
        "check": "lsm_pso_ratio", "group": g, "ok": bool(ok), "J_ratio": rj, "mean_abs_ratio": rm,
        "text": (f"{g}: LSM/PSO ratio {rj:.1f}x (J) vs {rm:.1f}x (mean abs): similar." if ok else
                 f"{g}: LSM/PSO is {rj:.1f}x in Table 3's J but {rm:.1f}x in Table 2's mean abs "
                 f"error; the two tables do not describe the same pair of fits the same way."),
    }


def remanence_findings(paper: dict, nle: dict) -> list[dict]:
    """Table 1 against Table 2 and the Fig. 6 text: each Table 1 set, simulated in the paper's own form
    (Eq. 13 as printed) at the N/Le that reproduces its group's stated peak (``nle``: the infer_nle JSON),
    gives B(0 A) after the descent; the fit it stands for cannot miss the measured remanence by more than
    Table 2's max abs error of that fit (widened by its printed rounding)."""
    out = []
    t2 = paper.get("table2", {})
    for name, r in sorted((nle.get("remanence_T") or {}).items()):
        g, m = name.rsplit("_", 1)
        e = t2.get(g, {}).get(m)
        if e is None or r.get("model_paper_form") is None:
            continue
        d = float(r["model_paper_form"]) - float(r["paper"])
        _, max_hi = _interval(e["max_abs_T"])
        ok = abs(d) <= max_hi
        n = (nle.get("per_set") or {}).get(name)
        out.append({
            "check": "remanence_vs_max_abs", "group": g, "method": m, "ok": bool(ok),
            "B0_model_T": float(r["model_paper_form"]), "B0_paper_T": float(r["paper"]), "diff_T": d,
            "max_abs_T": float(e["max_abs_T"]), "n_over_le": n,
            "text": (f"{g} {m.upper()}: the Table 1 set gives B(0 A, descent) = {1e3 * r['model_paper_form']:.3g} mT "
                     f"(paper form, N/Le = {n:.5g} /m from the stated peak) against the {1e3 * r['paper']:.3g} mT "
                     f"measured: {1e3 * abs(d):.2g} mT off, "
                     + (f"larger than the paper's own Table 2 max abs error {1e3 * e['max_abs_T']:.2g} mT for "
                        "this fit: Table 1 and Table 2 cannot both describe it." if not ok else
                        f"within the Table 2 max abs error {1e3 * e['max_abs_T']:.2g} mT.")),
        })
    return out


# which checks are independent statements about the paper, and which only follow from them (issue 14):
# it20 and it50 print the same LSM J and nearly the same PSO J (one finding per fit, not two); the RMS/sqrt(N)
# reading is an attempt to reconcile, not a finding; the LSM/PSO ratio check follows from the per-fit ones.
INDEPENDENT_CHECKS = ("rms_vs_mean_abs", "rms_vs_max_abs", "remanence_vs_max_abs")


def independent_inconsistencies(findings: list[dict]) -> list[dict]:
    """The failed checks reduced to independent inconsistencies, each stated once: per (check, group,
    method) the failed iterations (20, 50) are merged into one finding; reconciliation attempts
    (``rms_over_sqrtN_reading``) and derived ratio checks (``lsm_pso_ratio``) are left out."""
    merged: dict = {}
    for f in findings:
        if f["ok"] or f["check"] not in INDEPENDENT_CHECKS:
            continue
        key = (f["check"], f.get("group"), f.get("method"))
        if key in merged:
            merged[key]["iterations"].append(f.get("iteration"))
            merged[key]["J_T"].append(f.get("J_T"))
            continue
        merged[key] = {"check": f["check"], "group": f.get("group"), "method": f.get("method"),
                       "iterations": [f.get("iteration")] if f.get("iteration") else [],
                       "J_T": [f.get("J_T")] if f.get("iteration") else [], "text": f["text"]}
    out = []
    for key in sorted(merged, key=lambda k: (INDEPENDENT_CHECKS.index(k[0]), str(k[1]), str(k[2]))):
        x = merged[key]
        if len(x["iterations"]) > 1:
            first = f"J({x['iterations'][0][2:]}) = {x['J_T'][0]:.3g} T"
            both = ", ".join(f"J({it[2:]}) = {J:.3g} T" for it, J in zip(x["iterations"], x["J_T"]))
            if len(set(x["J_T"])) == 1:
                both = "J(" + " and ".join(it[2:] for it in x["iterations"]) + f") = {x['J_T'][0]:.3g} T"
            x["text"] = x["text"].replace(first, both)
        out.append(x)
    return out


def paper_check(paper: dict, nle: dict | None = None) -> dict:
    """What results/tables/paper_check.json holds: every check, and the independent inconsistencies."""
    checks = paper_consistency_findings(paper) + (remanence_findings(paper, nle) if nle else [])
    return {"independent": independent_inconsistencies(checks), "checks": checks,
            "n_checks": len(checks), "n_failed": sum(not c["ok"] for c in checks)}
