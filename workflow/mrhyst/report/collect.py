"""The report: collect every number the report shows into one JSON, and export the executed notebook
to one self-contained HTML file.

The report notebook (notebooks/report.ipynb) only reads and tabulates; everything it shows is either
an artefact of an earlier stage (tables, fits, diagnosis, blind score) or computed here:

* :func:`provenance` - commit, config hash, seeds, package versions, what the virtual rig contains;
* :func:`loop_summary`, :func:`fig2_summary` - the numbers the paper states beside Figs. 2 and 6;
* :func:`form_comparison` - what the physical J-A form changes against Eq. (13) as printed: the
  Table 1 sets re-simulated in both forms, and our fits evaluated and refitted in the physical form;
* :func:`collect` - all of it in one dict (rule ``report_data`` -> results/report/report_data.json);
* :func:`export_html` - nbconvert with a template that fetches nothing from the network, checked by
  :func:`external_refs`.

No Snakemake imports; the rules in workflow/rules/report.smk call these through workflow/scripts/report_*.py.
"""

from __future__ import annotations

import hashlib
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from mrhyst.data.io import read_json, read_loop, read_raw
from mrhyst.materials.gdlaws import summary as gdlaws_summary
from mrhyst.model import ja
from mrhyst.report.offline import export_html, external_refs  # noqa: F401 (the report API; rule report_html imports offline)

# package versions the report lists (issue 4)
PACKAGES = ("numpy", "scipy", "pandas", "matplotlib", "pyswarms", "numba", "snakemake", "papermill",
            "nbconvert", "mrhyst")
ZERO_TOL_A = 1e-9  # |I| below this is "0 A"
RK4_REF_SUBSTEPS = 400  # the reference of the RK4 error statement (README, config ja.substeps)


# --------------------------------------------------------------------------------------------
# provenance
# --------------------------------------------------------------------------------------------
def git_commit(repo_dir) -> str:
    """HEAD of the git repository whose top level is ``repo_dir``; "unknown" otherwise (no git, not a
    repository, or ``repo_dir`` only lies somewhere inside another repository)."""
    repo = Path(repo_dir).resolve()
    try:
        top = subprocess.run(["git", "-C", str(repo), "rev-parse", "--show-toplevel"], capture_output=True,
                             text=True, timeout=20)
        if top.returncode != 0 or Path(top.stdout.strip()).resolve() != repo:
            return "unknown"
        head = subprocess.run(["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=20)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    h = head.stdout.strip()
    return h if head.returncode == 0 and re.fullmatch(r"[0-9a-f]{40}", h) else "unknown"


def git_state(repo_dir) -> str:
    """The commit as the report prints it: the HEAD hash, with " + uncommitted changes" when tracked files differ
    from it (untracked files, e.g. results/, do not count); "unknown" outside a git repository."""
    head = git_commit(repo_dir)
    if head == "unknown":
        return head
    try:
        st = subprocess.run(["git", "-C", str(Path(repo_dir).resolve()), "status", "--porcelain",
                             "--untracked-files=no"], capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.SubprocessError):
        return head
    return head + (" + uncommitted changes" if st.returncode == 0 and st.stdout.strip() else "")


def file_sha256(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def package_versions(names=PACKAGES) -> dict:
    """{package: version} from the installed distributions ("not installed" if absent), plus python."""
    from importlib import metadata

    out = {}
    for n in names:
        try:
            out[n] = metadata.version(n)
        except metadata.PackageNotFoundError:
            out[n] = "not installed"
    out["python"] = ".".join(str(v) for v in sys.version_info[:3])
    return out


def seeds(config: dict) -> dict:
    """Every seed the study uses, by config key (absent sections are left out)."""
    out = {}
    if "pso" in config and "seeds" in config["pso"]:
        out["pso.seeds"] = [int(s) for s in config["pso"]["seeds"]]
    for sec in ("rig", "blind", "external"):
        if isinstance(config.get(sec), dict) and "seed" in config[sec]:
            out[f"{sec}.seed"] = int(config[sec]["seed"])
    return out


def rig_description(config: dict, raw_paths) -> dict:
    """What the measurements are: per raw sweep its provenance field, protocol and sensors (from the files
    themselves), and what the virtual rig put into them (config ``rig``): J-A truth per sensor, the effects
    J-A leaves out with their sizes, the noise and the ADC."""
    sweeps = []
    for p in raw_paths:
        raw = read_raw(p)
        cur = raw.current_A
        side = raw.sidecar
        sweeps.append({
            "file": Path(p).name,
            "sha256_csv": file_sha256(p),
            "sha256_json": file_sha256(Path(p).with_suffix(".json")),
            "provenance": side.get("provenance", "not stated (treated as a measurement)"),
            "synthetic": "SYNTHETIC" in str(side.get("provenance", "")).upper(),
            "n_samples": int(cur.size),
            "i_max_A": float(np.max(np.abs(cur))),
            "n_up": int(np.argmax(cur) + 1),
            "dwell_s": raw.dwell_s,
            "supply_V": raw.supply_V,
            "coil_turns_per_m": raw.coil_turns_per_m,
            "sensors": {n: {"sensitivity_V_per_T": s.sensitivity_V_per_T, "quiescent_V": s.quiescent_V,
                            "output_min_V": s.output_min_V, "output_max_V": s.output_max_V}
                        for n, s in sorted(raw.sensors.items())},
        })
    rig = config.get("rig") or {}
    sensors = {}
    for name, s in sorted((rig.get("sensors") or {}).items()):
        sensors[name] = {"truth": dict(s.get("truth", {})), "effects": dict(s.get("effects") or {}),
                         "sensitivity_V_per_T": s.get("sensitivity_V_per_T")}
    effects = {}
    if rig.get("eddy_tau_s") is not None and rig.get("dwell_s") is not None:
        effects["eddy_lag"] = {"sensors": sorted(sensors), "tau_s": float(rig["eddy_tau_s"]),
                               "lag_per_step": math.exp(-float(rig["dwell_s"]) / float(rig["eddy_tau_s"]))}
    for name, s in sensors.items():
        for eff, pars in s["effects"].items():
            effects.setdefault(eff, {"sensors": [], "per_sensor": {}})
            effects[eff]["sensors"].append(name)
            effects[eff]["per_sensor"][name] = pars
    adc = rig.get("adc") or {}
    lsb = 2.0 * float(adc["range_V"]) / 2 ** int(adc["bits"]) if adc else None
    return {
        "sweeps": sweeps,
        "synthetic": any(s["synthetic"] for s in sweeps),
        "rig": {
            "seed": rig.get("seed"), "form": rig.get("form"), "dman": rig.get("dman"), "substeps": rig.get("substeps"),
            "dwell_s": rig.get("dwell_s"), "supply_V": rig.get("supply_V"), "noise_sigma_T": rig.get("noise_sigma_T"),
            "adc_bits": adc.get("bits"), "adc_range_V": adc.get("range_V"), "adc_lsb_V": lsb,
            "sensors": sensors, "effects": effects,
        },
    }


def provenance(config: dict, config_path, raw_paths, repo_dir=".", commit: str | None = None,
               versions: dict | None = None) -> dict:
    """Commit, sha256 of config.yaml, seeds, package versions, and the rig description."""
    return {
        "commit": commit if commit is not None else git_commit(repo_dir),
        "config_file": Path(config_path).name,
        "config_sha256": file_sha256(config_path),
        "seeds": seeds(config),
        "versions": versions if versions is not None else package_versions(),
        "measurements": rig_description(config, raw_paths),
    }


# --------------------------------------------------------------------------------------------
# loops: the numbers the paper states beside Figs. 2 and 6
# --------------------------------------------------------------------------------------------
def _descending_zero_crossing(current, B):
    """Current (A) where B changes sign going down (linear interpolation), or None."""
    for j in range(len(B) - 1):
        if current[j + 1] < current[j] and B[j] > 0 >= B[j + 1]:
            return float(current[j] + (0 - B[j]) / (B[j + 1] - B[j]) * (current[j + 1] - current[j]))
    return None


def negative_slopes(current, B) -> dict:
    """Intervals where B moves against the current (dB/dI < 0): impossible for a physical core, the
    signature of Eq. (13) without the guard after a reversal. Returns count and the most negative
    dB/dI (T/A) among them."""
    dI, dB = np.diff(np.asarray(current, float)), np.diff(np.asarray(B, float))
    m = dI != 0
    s = dB[m] / dI[m]
    neg = s < 0
    return {"n": int(neg.sum()), "min_slope_T_per_A": float(s[neg].min()) if neg.any() else None,
            "n_intervals": int(m.sum())}


def remanence_after_peak(current, B):
    """B at the first 0 A sample after the largest current (the descent's remanence), or None."""
    cur = np.asarray(current, float)
    j0 = int(np.argmax(cur))
    z = np.flatnonzero(np.abs(cur[j0:]) <= ZERO_TOL_A)
    return float(B[j0 + z[0]]) if z.size else None


def monotone_legs(branch) -> list[tuple[str, int, int]]:
    """Each monotone leg of a loop file, a run of one ``branch`` value, as (branch, first, last) sample indices; a
    leg after the first starts at the turning point before it. Fig. 6 draws each leg apart: a bipolar sweep has
    several legs of each direction, and one line through all samples of a direction would cross the loop."""
    br = [str(b) for b in branch]
    starts = [j for j in range(len(br)) if j == 0 or br[j] != br[j - 1]]
    ends = [*(j - 1 for j in starts[1:]), len(br) - 1]
    return [(br[a], max(a - 1, 0), b) for a, b in zip(starts, ends)]


def falling_zero(current, B, branch) -> tuple[float, float] | None:
    """(I, B) of the falling sample nearest 0 A, the last of equals (on a bipolar sweep: the last falling leg's
    crossing; on 0 -> max -> 0: B at 0 A after the descent), or None when no sample falls (Fig. 6's title)."""
    cur, b = np.asarray(current, float), np.asarray(B, float)
    down = np.flatnonzero(np.asarray([str(x) for x in branch]) == "down")
    if down.size == 0:
        return None
    a = np.abs(cur[down])
    j = int(down[np.flatnonzero(a == a.min())[-1]])
    return float(cur[j]), float(b[j])


def loop_summary(loop_path, paper_peak=None, paper_remanence=None) -> dict:
    """Peak B, B at the start, B at 0 A after the descent, against the paper's stated values (Fig. 6)."""
    lp = read_loop(loop_path)
    cur, B = np.asarray(lp.current_A, float), np.asarray(lp.B_T, float)
    v = lp.valid
    peak = float(np.max(B[v]))
    rem = remanence_after_peak(cur, B)
    out = {"file": Path(loop_path).name, "n_samples": int(B.size), "n_saturated": int((~v).sum()),
           "i_max_A": float(cur.max()), "peak_T": peak, "i_at_peak_A": float(cur[v][np.argmax(B[v])]),
           "start_T": float(B[0]), "remanence_T": rem, "paper_peak_T": paper_peak,
           "paper_remanence_T": paper_remanence}
    out["peak_rel_diff"] = None if paper_peak is None else (peak - paper_peak) / paper_peak
    out["remanence_rel_diff"] = (None if paper_remanence is None or rem is None
                                 else (rem - paper_remanence) / paper_remanence)
    return out


def fig2_summary(fig2_csv) -> dict:
    """Per J-A form on the Fig. 2 path: peak B, remanence (0 A on the descent), coercive current, the
    intervals with dB/dI < 0, and the largest difference between the forms."""
    df = pd.read_csv(fig2_csv)
    cur = df["current_A"].to_numpy(float)
    out = {"n_samples": int(cur.size), "i_max_A": float(cur.max()), "i_min_A": float(cur.min()),
           "di_A": float(abs(cur[1] - cur[0])), "forms": {}}
    forms = [f for f in ja.FORMS if f"B_{f}_T" in df.columns]
    for f in forms:
        B = df[f"B_{f}_T"].to_numpy(float)
        out["forms"][f] = {"peak_T": float(B.max()), "min_T": float(B.min()),
                           "remanence_T": remanence_after_peak(cur, B), "coercive_A": _descending_zero_crossing(cur, B),
                           "negative_slopes": negative_slopes(cur, B)}
    if len(forms) == 2:
        d = df[f"B_{forms[0]}_T"].to_numpy(float) - df[f"B_{forms[1]}_T"].to_numpy(float)
        j = int(np.argmax(np.abs(d)))
        out["max_abs_diff_T"] = float(abs(d[j]))
        out["max_abs_diff_at_A"] = float(cur[j])
        out["max_abs_diff_branch"] = str(df["branch"].iloc[j]) if "branch" in df else None
    return out


# --------------------------------------------------------------------------------------------
# paper form vs physical form
# --------------------------------------------------------------------------------------------
def _compare_forms(params, current, n_over_le, substeps, dman) -> dict:
    """One parameter set along one current path in both forms."""
    out = {}
    Bs = {}
    for f in ja.FORMS:
        B, ok = ja.simulate(ja.as_param_array(params), current, n_over_le, form=f, substeps=substeps, dman=dman)
        Bs[f] = B
        out[f] = {"ok": bool(ok)}
        Bref, okr = ja.simulate(ja.as_param_array(params), current, n_over_le, form=f, substeps=RK4_REF_SUBSTEPS,
                                dman=dman)
        out[f]["rk4_error_T"] = float(np.max(np.abs(B - Bref))) if ok and okr else None
        if ok:
            out[f].update({"peak_T": float(np.max(B)), "remanence_T": remanence_after_peak(current, B),
                           "negative_slopes": negative_slopes(current, B)})
    if all(out[f]["ok"] for f in ja.FORMS):
        d = Bs["paper"] - Bs["physical"]
        j = int(np.argmax(np.abs(d)))
        out["max_abs_diff_T"] = float(abs(d[j]))
        out["max_abs_diff_at_A"] = float(current[j])
        out["rms_diff_T"] = float(np.sqrt(np.mean(d * d)))
    return out


def form_comparison(config: dict, n_over_le: float, loops: dict, selected: list, lsm_max_iterations: int) -> dict:
    """What the physical form changes.

    ``sets``: every Table 1 set (config paper.table1) re-simulated along the paper's path at the inferred
    N/Le (``n_over_le``) in both forms: peak, remanence (against the paper's), intervals with dB/dI < 0, largest |dB|.
    ``fits``: each selected (median-J) fit of ``selected`` (records of results/tables/selected_fits.json)
    on its group's loop: J as fitted (config ja.form), J of the same parameters in the other form, and J
    after a least-squares refit in the other form started from the fitted parameters, in the same box.
    """
    from mrhyst.data.curves import read_fit
    from mrhyst.fit import identify

    cfg = identify.resolve_config(config)
    jc = cfg["ja"]
    substeps, dman, form0 = int(jc["substeps"]), jc["dman"], jc["form"]
    other = "physical" if form0 == "paper" else "paper"
    paper = config["paper"]
    path = ja.paper_current_path(float(paper["i_max_A"]), int(paper["n_up"]))
    sets = {}
    for g in sorted(paper["table1"]):
        for m in sorted(paper["table1"][g]):
            r = _compare_forms(paper["table1"][g][m], path, n_over_le, substeps, dman)
            r["paper_remanence_T"] = float(paper["remanence_B_T"][g]) if g in paper.get("remanence_B_T", {}) else None
            r["paper_peak_T"] = float(paper["peak_B_T"][g]) if g in paper.get("peak_B_T", {}) else None
            sets[f"{g}_{m}"] = r
    fits = []
    for rec in sorted(selected, key=lambda r: (str(r["group"]), str(r["method"]), str(r["setting"]))):
        g = rec["group"]
        if g not in loops:
            continue
        fit = read_fit(rec["path"])  # with its model curve (F.curve.csv beside it)
        x = ja.as_param_array(fit["params"])
        lp = read_loop(loops[g])
        row = {"group": g, "method": rec["method"], "setting": rec["setting"], "seed": rec.get("seed"),
               "form_fitted": fit.get("form", form0), "form_other": other, "J_fitted_T": float(fit["rms_T"])}
        prob, _ = identify.problem_from_loop(lp, n_over_le=None, form=other, dman=dman, substeps=substeps,
                                             start="demagnetised", cfg=cfg)  # H as fitted: the loop's own
        row["J_same_params_other_form_T"] = float(prob.cost(x[None, :])[0])
        box, _ = identify.box_for(cfg, g, "lsm" if rec["method"] == "lsm" else "pso")
        r = identify.run_lsm(prob, box, x, max_iterations=int(lsm_max_iterations), method=cfg["lsm"]["method"],
                             ftol=float(cfg["lsm"]["ftol"]), xtol=float(cfg["lsm"]["xtol"]),
                             gtol=float(cfg["lsm"]["gtol"]), diff_step=cfg["lsm"].get("diff_step"))
        row["J_refit_other_form_T"] = float(r["J"])
        row["refit_params"] = ja.as_param_dict(r["x"])
        row["refit_rel_change"] = {n: float((r["x"][i] - x[i]) / x[i]) if x[i] != 0 else None
                                   for i, n in enumerate(ja.PARAM_NAMES)}
        row["refit_iterations"] = int(r["n_iterations"])
        Bd, ok = prob.model(r["x"][None, :])
        row["refit_remanence_T"] = remanence_after_peak(lp.current_A, Bd[0]) if ok[0] else None
        row["fitted_remanence_T"] = remanence_after_peak(lp.current_A, np.asarray(fit["B_model_T"], float)) \
            if "B_model_T" in fit else None
        row["measured_remanence_T"] = remanence_after_peak(lp.current_A, lp.B_T)
        fits.append(row)
    return {"form_fitted": form0, "form_other": other, "n_over_le": float(n_over_le), "substeps": substeps,
            "dman": dman, "path": {"i_max_A": float(paper["i_max_A"]), "n_up": int(paper["n_up"]),
                                   "n_samples": int(path.size)},
            "sets": sets, "fits": fits}


# --------------------------------------------------------------------------------------------
# the other stages' results, trimmed to what the report shows
# --------------------------------------------------------------------------------------------
def records(csv_path) -> list[dict]:
    """A CSV as a list of dicts, NaN -> None (JSON has no NaN)."""
    df = pd.read_csv(csv_path)
    out = []
    for r in df.to_dict(orient="records"):
        out.append({k: (None if isinstance(v, float) and not math.isfinite(v) else
                        (v.item() if hasattr(v, "item") else v)) for k, v in r.items()})
    return out


def diagnosis_summary(path) -> dict:
    """The contract fields of one diagnosis (ARCHITECTURE 4) plus what the report tabulates."""
    d = read_json(path)
    where = d.get("where") or {}
    keep = ("effect", "ambiguous_with", "ambiguity_reason", "rms_before_T", "rms_after_T", "noise_floor_T",
            "effect_size", "secondary", "verdict", "shrink", "note", "structure_remains", "partial", "model_form",
            "policy")
    out = {k: d[k] for k in keep if k in d}
    out["file"] = Path(path).name
    out["input"] = d.get("input")
    out["where"] = {k: where[k] for k in ("largest_share_before", "region_bounds", "budget", "saturated_samples")
                    if k in where}
    # along the loop (ascending low ... remanence point): a JSON object would come back in key order
    regions = where.get("regions") or {}
    order = where.get("region_order") or sorted(regions)
    out["where"]["regions"] = [{"region": k, **regions[k]} for k in order if k in regions]
    out["candidates"] = [{k: c.get(k) for k in ("effect", "n_params", "rms_T", "delta_bic", "verdict")}
                         for c in d.get("candidates", [])]
    out["fit_before"] = d.get("fit_before")
    out["fit_after"] = d.get("fit_after")
    return out


def blind_summary(path) -> dict:
    """The blind score without the per-case list."""
    s = read_json(path)
    return {k: v for k, v in s.items() if k != "cases"} | {"n_cases": len(s.get("cases", []))}


def variant_summary(name: str, config: dict, tables: dict, loops: dict) -> dict:
    """One rig variant (config rig.variants.NAME): what it changes, its loops' peak and remanence, and its
    Tables 1-3 (tables: {"table1": csv, ...}; loops: {group: loop csv})."""
    paper = config["paper"]
    v = dict(((config.get("rig") or {}).get("variants") or {}).get(name) or {})
    return {"name": name, "changes": {k: x for k, x in v.items() if k != "pso_seeds"},
            "base": {k: (config.get("rig") or {}).get(k) for k in v if k != "pso_seeds"},
            "pso_seeds": v.get("pso_seeds"),
            "loops": {g: loop_summary(p, paper.get("peak_B_T", {}).get(g), paper.get("remanence_B_T", {}).get(g))
                      for g, p in sorted(loops.items())},
            **{k: records(tables[k]) for k in ("table1", "table2", "table3", "seed_spread") if tables.get(k)}}


REPORT_PSO = ("n_particles", "iterations", "settings", "setting", "run_settings", "v_max_frac", "bh_strategy", "box")


def report_settings(config: dict) -> dict:
    """The study's settings the report shows: those that ran (the config's sections over the schema's defaults,
    :func:`mrhyst.config.resolve`), not only the keys the config spells out."""
    from mrhyst.config import resolve

    r = resolve(config, ("ja", "pso", "lsm", "metrics", "identifiability", "fig2", "nle"))
    r["pso"] = {k: r["pso"][k] for k in REPORT_PSO if k in r["pso"]}
    return r


def collect(*, config: dict, config_path, raw_paths, repo_dir=".", commit=None, versions=None, nle, fig2_csv,
            loops: dict, tables: dict, forms=None, diagnosis: dict | None = None, blind=None, external=None,
            variants: dict | None = None, external_diagnosis=None, blind_variants: dict | None = None,
            external_models=None, realcores=None, aftercare=None, gdlaws=None, later=None,
            aftercare_diagnoses=None) -> dict:
    """Everything the report shows, in one JSON-ready dict.

    tables: {"table1": csv, "table2": csv, "table3": csv, "seed_spread": csv, "identifiability": csv,
    "paper_check": json, "selected": json}; diagnosis: {group: json} or None (stage not built);
    blind: score json or None; blind_variants: {name: score json} of config blind.variants or None;
    external: csv or None; external_models: csv of the --model auto comparison or None;
    external_diagnosis: the external_diagnose JSONs (one per
    third-party file) or None; variants: {name: {"tables": {...}, "loops": {...}}} of
    the rig variants (config rig.variants) or None; gdlaws: (table csv, withheld diagnosis json) of target gdlaws
    or None; later: the keyword arguments of :func:`mrhyst.diagnose.later.collect` (target later) or None;
    aftercare_diagnoses: the aftercare cases' diagnosis JSONs (their plain summaries) or None.
    """
    paper = config["paper"]
    out = {
        "provenance": provenance(config, config_path, raw_paths, repo_dir, commit, versions),
        "groups": config.get("groups"),
        "paper": {k: paper[k] for k in ("i_max_A", "n_up", "peak_B_T", "remanence_B_T", "fig2_params") if k in paper},
        "settings": report_settings(config),
        "nle": read_json(nle),
        "fig2": fig2_summary(fig2_csv),
        "fig6": {g: loop_summary(p, paper.get("peak_B_T", {}).get(g), paper.get("remanence_B_T", {}).get(g))
                 for g, p in sorted(loops.items())},
    }
    for k in ("table1", "table2", "table3", "seed_spread", "identifiability"):
        out[k] = records(tables[k]) if tables.get(k) else None
    out["paper_check"] = read_json(tables["paper_check"]) if tables.get("paper_check") else None
    out["selected"] = None
    if tables.get("selected"):
        out["selected"] = []
        for r in read_json(tables["selected"]):
            fit = read_json(r["path"]) if Path(r["path"]).is_file() else {}
            out["selected"].append({**{k: v for k, v in r.items() if k != "path"},
                                    "at_box_edge": list(fit.get("at_box_edge", [])),
                                    "warnings": list(fit.get("warnings", []))})
    out["forms"] = read_json(forms) if forms else None
    out["diagnosis"] = None if diagnosis is None else {g: diagnosis_summary(p) for g, p in sorted(diagnosis.items())}
    out["blind"] = None if blind is None else blind_summary(blind)
    out["blind_variants"] = None if not blind_variants else {
        n: blind_summary(p) for n, p in sorted(blind_variants.items())}
    out["external"] = None if external is None else records(external)
    out["external_models"] = None if external_models is None else records(external_models)  # --model auto
    out["external_diagnosis"] = None if not external_diagnosis else [
        {"source": d["source"], **row} for d in map(read_json, external_diagnosis) for row in d["loops"]]
    rc = None if realcores is None else read_json(realcores)  # issue 23's benchmark: its summary, not its rows
    out["realcores"] = None if rc is None else {k: rc.get(k) for k in ("overall", "classes", "goals", "size_tol",
                                                                       "sources")}
    out["aftercare"] = None if aftercare is None else read_json(aftercare)  # issue 24: the damper after use
    if out["aftercare"] is not None and aftercare_diagnoses:  # issue 26: each case's plain summary
        from mrhyst.blind.aftercare import summaries

        out["aftercare"]["summaries"] = summaries(aftercare_diagnoses)
    out["gdlaws"] = None if gdlaws is None else gdlaws_summary(*gdlaws)  # issue 24: Gd laws, one withheld
    if gdlaws is not None:  # issue 26: the withheld loop's plain summary, as `mrhyst diagnose` prints it
        from mrhyst.report.summary import diagnosis_summary as plain_summary

        out["gdlaws"]["summary"] = plain_summary(read_json(gdlaws[1]))
    if later is not None:  # issue 26: a later sweep against the calibration from the first, and the refit
        from mrhyst.diagnose import later as later_mod

        out["later"] = later_mod.collect(**later)
    else:
        out["later"] = None
    out["variants"] = None if not variants else {
        n: variant_summary(n, config, v["tables"], v["loops"]) for n, v in sorted(variants.items())}
    return out


# --------------------------------------------------------------------------------------------
# HTML export
# --------------------------------------------------------------------------------------------
