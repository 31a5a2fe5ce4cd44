"""Issue 24 item 4 as a workflow target (`snakemake gdlaws`): gadolinium temperature laws with one temperature
withheld, that loop diagnosed against the laws in reference mode, and ours beside the peer's figures.

Three steps, one rule each (workflow/rules/gdlaws.smk): ``fit`` (mrhyst.materials.templaws on the loops of one field
amplitude but the withheld temperature's), ``withheld_loop`` + mrhyst.diagnose.refdiag (the withheld loop as a
plain B(H) file, its temperature column dropped, so the diagnosis must name the temperature itself) and ``table``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from mrhyst.data.io import InputError, read_json


def gdlaws_config(config=None):
    """The gdlaws section: schema defaults under a config mapping or config.yaml path, frozen."""
    from mrhyst.settings import frozen

    return frozen(config, "gdlaws")


def loop_table(path, amplitude: float) -> pd.DataFrame:
    """loop_index -> temperature_C of the loops at ``amplitude`` (A/m), ordered by temperature."""
    d = pd.read_csv(path, usecols=["temperature_C", "field_amplitude_A_per_m", "loop_index"])
    d = d[np.isclose(d.field_amplitude_A_per_m, amplitude)].drop_duplicates("loop_index")
    if d.empty:
        raise InputError(f"{path}: no loop at field_amplitude_A_per_m {amplitude:g}")
    return d.sort_values("temperature_C")[["loop_index", "temperature_C"]].reset_index(drop=True)


def split(path, cfg: dict) -> tuple[list[int], int]:
    """The loops the laws see and the withheld one (gdlaws.withheld_C at gdlaws.amplitude_A_per_m)."""
    t = loop_table(path, float(cfg["amplitude_A_per_m"]))
    hit = np.isclose(t.temperature_C, float(cfg["withheld_C"]))
    if not hit.any():
        raise InputError(f"{path}: no loop at {cfg['withheld_C']:g} C (have {', '.join(map(str, t.temperature_C))})")
    held = int(t.loop_index[hit].iloc[0])
    return [int(i) for i in t.loop_index if int(i) != held], held


def fit_config(config: dict, cfg: dict) -> dict:
    """The config the law fit runs with: temperature_laws.samples_per_loop from gdlaws.samples_per_loop."""
    tl = dict(config.get("temperature_laws") or {})
    tl["samples_per_loop"] = int(cfg["samples_per_loop"])
    return {**config, "temperature_laws": tl}


def withheld_loop(path, loop_index: int, n: int) -> pd.DataFrame:
    """The withheld loop as a B(H) file without its temperature: ``n`` samples evenly spaced in sample index."""
    d = pd.read_csv(path)
    g = d[d.loop_index == loop_index]
    k = np.unique(np.round(np.linspace(0, len(g) - 1, n)).astype(int))
    return pd.DataFrame({"H_A_per_m": g.H_A_per_m.to_numpy()[k], "B_T": g.B_T.to_numpy()[k]})


def table(fit_json, diag_json, peer_json, withheld_C: float) -> pd.DataFrame:
    """Per temperature: our law fit's and per-loop fit's RMS (mT, on the fit's resampled loops), the peer's
    figures, and for the withheld temperature the diagnosis (verdict, temperature +- stderr, RMS after)."""
    fit, diag, peer = read_json(fit_json), read_json(diag_json), read_json(peer_json)
    rows = {float(r["temperature_C"]): {"temperature_C": float(r["temperature_C"]),
                                        "peer_laws_rms_mT": r["peer_laws_rms_mT"],
                                        "peer_per_temperature_rms_mT": r["peer_per_temperature_rms_mT"]}
            for r in peer["rows"]}
    for p in fit["per_loop"]:
        r = rows.setdefault(float(p["temperature_C"]), {"temperature_C": float(p["temperature_C"])})
        r.update(role="fitted", ours_laws_rms_mT=1e3 * p["rms_T"], ours_per_loop_rms_mT=1e3 * p["own_fit"]["rms_T"])
    r = rows.setdefault(float(withheld_C), {"temperature_C": float(withheld_C)})
    es = diag.get("effect_size") or {}
    named = es.get("param") == "temperature_C"
    r.update(role="withheld", verdict=diag["effect"], ours_laws_rms_mT=1e3 * diag["rms_after_T"],
             rms_before_mT=1e3 * diag["rms_before_T"],
             named_temperature_C=es.get("value") if named else None,
             named_temperature_stderr_C=es.get("stderr") if named else None)
    cols = ["temperature_C", "role", "ours_laws_rms_mT", "ours_per_loop_rms_mT", "peer_laws_rms_mT",
            "peer_per_temperature_rms_mT", "verdict", "named_temperature_C", "named_temperature_stderr_C",
            "rms_before_mT"]
    return pd.DataFrame([rows[t] for t in sorted(rows)]).reindex(columns=cols).round(3)


def summary(table_csv, diag_json) -> dict:
    """What the report shows: the table's rows and the withheld diagnosis's verdict."""
    d = read_json(diag_json)
    t = pd.read_csv(table_csv)
    return {"rows": t.astype(object).where(t.notna(), None).to_dict("records"), "effect": d["effect"],
            "effect_size": d.get("effect_size"), "verdict": d.get("verdict"),
            "reference_temperature_C": (d.get("reference") or {}).get("reference_temperature_C")}


__all__ = ["gdlaws_config", "loop_table", "split", "fit_config", "withheld_loop", "table", "summary"]
