"""The tables of the third-party loops' fits (rule external_table): one row per loop and fit, the peers' published
fits beside them, and one row per file and J-A variant of the ``--model auto`` comparison (issue 26). Read from the
fit JSONs of :mod:`mrhyst.materials.external`; nothing is fitted here."""

from __future__ import annotations

import numpy as np
import pandas as pd

from mrhyst.data.io import InputError, read_json, write_csv

SUMMARY_PARAMS = ("Ms", "a", "alpha", "c", "k")
FIGURES = (("Hc_A_per_m", "Hc"), ("Br_T", "Br"), ("loop_area_J_per_m3", "area"), ("mu_r_diff_max", "mu_r_max"))


def _figure_cols(lf: dict | None) -> dict:
    """Loop figures of the data and of the fit, side by side (mrhyst.data.loopfigures)."""
    out = {}
    for key, short in FIGURES:
        for side in ("data", "fit"):
            v = ((lf or {}).get(side) or {}).get(key)
            out[f"{short}_{side}"] = np.nan if v is None else v
    return out


def _loop_row(res: dict, lp: dict) -> dict:
    row = {
        "source": res["source"],
        "loop_index": -1 if lp["loop_index"] is None else lp["loop_index"],
        "n_samples": lp["n_samples"],
        "H_amplitude_A_per_m": lp["H_amplitude_A_per_m"],
        "B_amplitude_T": lp["B_amplitude_T"],
        "start": lp["start"],
        "method": lp["method"],
        "rms_T": lp["rms_T"],
        "rms_rel": lp["rms_rel"],
        "fit": "per-loop",
        "model": lp.get("model", "ja"),
        "rms_rel_peak": lp.get("rms_rel_peak", np.nan),
        "substeps": lp.get("substeps", np.nan),
        "rms_lsm_data_start_T": lp["candidates"]["lsm_data_start"]["J_T"],
        "rms_lsm_multistart_T": lp["candidates"]["lsm_multistart"]["J_T"],
        "rms_pso_T": lp["candidates"]["pso"]["J_T"],
        "rms_pso_lsm_T": lp["candidates"]["pso+lsm"]["J_T"],
        "rms_lsm_from_other_loops_T": lp["candidates"].get("lsm_from_other_loops", {}).get("J_T", np.nan),
    }
    row.update({n: lp["params"].get(n, np.nan) for n in SUMMARY_PARAMS})
    row["m0"] = np.nan if lp["m0"] is None else lp["m0"]
    row["cyclic_drift_T"] = lp["cyclic_drift_T"]
    row["integration_error_T"] = lp["integration_error_T"]
    row["at_box_edge"] = ";".join(lp["at_box_edge"])
    row.update(_figure_cols(lp.get("loop_figures")))
    return row


def _joint_rows(res: dict, j: dict | None) -> list[dict]:
    """One row per loop of one of the file's joint fits (one parameter set), beside the per-loop rows."""
    if not j:
        return []
    amp = {lp["loop_index"]: lp for lp in res["loops"]}
    rows = []
    for e in j["per_loop"]:
        lp = amp.get(e["loop_index"], {})
        rows.append({"source": res["source"], "loop_index": -1 if e["loop_index"] is None else e["loop_index"],
                     "n_samples": e["n_samples"], "H_amplitude_A_per_m": lp.get("H_amplitude_A_per_m", np.nan),
                     "B_amplitude_T": lp.get("B_amplitude_T", np.nan), "start": e["start"], "method": "lsm",
                     "rms_T": e["rms_T"], "rms_rel": e["rms_T"] / lp["B_amplitude_T"] if lp else np.nan,
                     "fit": "joint", "model": j.get("model", "ja"),
                     "rms_rel_peak": np.nan if e["rms_rel"] is None else e["rms_rel"], "substeps": j["substeps"],
                     **{n: j["params"].get(n, np.nan) for n in SUMMARY_PARAMS},
                     "m0": e.get("m0", np.nan), "integration_error_T": j["integration_error_T"],
                     "at_box_edge": ";".join(j["at_box_edge"]), **_figure_cols(e.get("loop_figures")),
                     # the joint fit's RMS over the loop's own per-loop fit's (issue 17: <= 2 for the ferrite)
                     "rms_over_own": e["rms_T"] / lp["rms_T"] if lp.get("rms_T") else np.nan,
                     # a variant's own parameters (amplitude: the exponents), beside the classic five
                     "variant_params": ";".join(f"{n}={v:.4g}" for n, v in j["params"].items()
                                                if n not in SUMMARY_PARAMS)})
    return rows


def peer_rows(path) -> list[dict]:
    """Other tools' fits of the same loops (data/external/peers.csv: source, tool, fit, loop_index,
    rms_rel_peak, time, note), for comparison in the report."""
    df = pd.read_csv(path, dtype={"time": str}, keep_default_na=False)
    need = {"source", "tool", "fit", "loop_index", "rms_rel_peak"}
    if not need <= set(df.columns):
        raise InputError(f"{path}: needs columns {', '.join(sorted(need))}")
    return df.to_dict("records")


def summary_table(results, peers=None) -> pd.DataFrame:
    """One row per loop and fit (per-loop, and joint for files with several loops) from fit_source
    results (dicts or JSON paths), in the order given; then the peers' rows (tool column) of those sources."""
    rows = []
    for res in results:
        if not isinstance(res, dict):
            res = read_json(res)
        rows += [_loop_row(res, lp) | {"tool": "mrhyst"} for lp in res["loops"]]
        for j in [res.get("joint")] + list((res.get("joint_variants") or {}).values()):
            rows += [r | {"tool": "mrhyst"} for r in _joint_rows(res, j)]
    if peers:
        ours = {r["source"] for r in rows}
        rows += [r for r in peer_rows(peers) if r["source"] in ours]  # only for materials fitted here
    return pd.DataFrame(rows)


def model_rows(results) -> pd.DataFrame:
    """One row per file and J-A variant of its `--model auto` comparison (block "auto", :func:`select_variant`):
    RMS over all samples and per loop in % of the loop's peak |B|, BIC, held-out RMS, the choice, and how the
    chosen variant's held-out RMS compares with the best of all (a fixed choice of any one variant)."""
    rows = []
    for res in results:
        res = res if isinstance(res, dict) else read_json(res)
        auto = res.get("auto")
        if not auto:
            continue
        peaks = [e["B_peak_T"] for e in auto["fit"]["per_loop"]]
        best_ho = min(r["heldout_T"] for r in auto["model_selection"] if r["heldout_T"] is not None)
        for r in auto["model_selection"]:
            rows.append({"source": res["source"], "variant": r["variant"], "n_params": r["n_params"],
                         "rms_T": r["rms_T"], "bic": r["bic"], "heldout_T": r["heldout_T"],
                         "heldout_over_best": None if r["heldout_T"] is None else r["heldout_T"] / best_ho,
                         "chosen": r["variant"] == auto["model_choice"]["variant"],
                         "rms_rel_peak_per_loop": ";".join(f"{100 * v / p:.3g}" for v, p in zip(r["per_loop_rms_T"],
                                                                                              peaks))})
    return pd.DataFrame(rows)


def write_summary(json_paths, out, peers=None) -> pd.DataFrame:
    df = summary_table(json_paths, peers)
    write_csv(df, out)
    return df
