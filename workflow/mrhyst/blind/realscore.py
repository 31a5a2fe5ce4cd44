"""Scoring of the benchmark "real cores, known faults" (issue 23 item 5; cases by :mod:`mrhyst.blind.realcores`):
the only reader of its key.

Per case: the **fault named** (the verdict's effect, its accepted ``secondary``, or the fault in ``ambiguous_with``
together with a ``next_measurement`` that separates them), its **size recovered** (``effect_size.value``, or the
secondary's ``size.value``, within ``size_tol`` of the injected size, relative), and on a clean case a **false
alarm** (a measurement-chain fault named as the verdict or as its accepted second effect:
``hall_offset``, ``thermal_drift``, ``eddy_lag``, ``sensor_saturation``; a remanent start of a core that was not
demagnetised is physics, not a false alarm). The **split** is the diagnosis's layered ``budget``: what a
material model removes of plain J-A's RMS, what the measurement effect removes on top, what is left.
"""

from __future__ import annotations

import math
from pathlib import Path

from mrhyst.data import io

FAULTS = ("hall_offset", "thermal_drift", "eddy_lag", "sensor_saturation")
GOALS = {"named": 0.90, "size_within": 0.90, "clean_false_alarm": 0.05}


def judge(k: dict, d: dict, size_tol: float) -> dict:
    """One case: {"named", "size_ok", "false_alarm", "size", "effect", ...} (None where it does not apply)."""
    eff = d.get("effect")
    fault = k["fault"]
    b = d.get("budget") or {}
    row = {"core": k["core"], "protocol": k["protocol"], "fault": fault, "level": k.get("level"),
           "true_size": k.get("size"), "effect": eff, "ambiguous_with": ",".join(d.get("ambiguous_with") or []),
           "material_T": b.get("material_T"), "measurement_T": b.get("measurement_T"), "left_T": b.get("left_T"),
           "base": b.get("base"), "rms_before_T": d.get("rms_before_T"), "named": None, "size": None,
           "size_ok": None, "false_alarm": None}
    sec = d.get("secondary") or {}
    sec = sec if sec.get("accepted") else {}
    row["secondary"] = sec.get("effect")
    if fault == "none":  # a remanent start + an eddy lag on a clean core: the lag is a false alarm too
        row["false_alarm"] = eff in FAULTS or sec.get("effect") in FAULTS
        return row
    amb = fault in (d.get("ambiguous_with") or []) and bool((d.get("next_measurement") or {}).get("protocol"))
    row["named"] = eff == fault or sec.get("effect") == fault or amb
    es = d.get("effect_size") if eff == fault else (sec.get("size") if sec.get("effect") == fault else None)
    es = es or {}
    if es.get("value") is not None and k.get("size"):
        row["size"] = float(es["value"])
        row["size_ok"] = abs(row["size"] - k["size"]) <= size_tol * abs(k["size"])
    return row


def _rate(xs):
    xs = [x for x in xs if x is not None]
    return (sum(bool(x) for x in xs) / len(xs)) if xs else None


def _count(xs) -> list:
    """[hits, cases] over the cases a measure applies to (None: it does not)."""
    xs = [bool(x) for x in xs if x is not None]
    return [sum(xs), len(xs)]


def _mean(xs):
    xs = [float(x) for x in xs if x is not None and math.isfinite(float(x))]
    return sum(xs) / len(xs) if xs else None


def summary(rows: list) -> dict:
    """Per (protocol, fault) class and overall: named, size within tolerance, false alarms, mean split (T); per
    source (the material): named and clean false alarms."""
    classes = {}
    for r in rows:
        classes.setdefault(f"{r['protocol']}:{r['fault']}", []).append(r)
    out = {}
    for c, sel in sorted(classes.items()):
        out[c] = {"n": len(sel), "named": _rate(r["named"] for r in sel),
                  "size_within": _rate(r["size_ok"] for r in sel),
                  "false_alarm": _rate(r["false_alarm"] for r in sel),
                  "material_T": _mean(r["material_T"] for r in sel),
                  "measurement_T": _mean(r["measurement_T"] for r in sel), "left_T": _mean(r["left_T"] for r in sel),
                  "effects": sorted(str(r["effect"]) for r in sel)}
    faulted = [r for r in rows if r["fault"] != "none"]
    by_source = {}
    for r in rows:  # the material of each source (a core is NAME_LIDX): e.g. the gadolinium cores beside the rest
        by_source.setdefault(str(r["core"]).rsplit("_L", 1)[0], []).append(r)
    sources = {k: {"n": len(v), "named": _rate(r["named"] for r in v if r["fault"] != "none"),
                   "clean_false_alarm": _rate(r["false_alarm"] for r in v if r["fault"] == "none")}
               for k, v in sorted(by_source.items())}
    overall = {"n": len(rows), "named": _rate(r["named"] for r in faulted),
               "size_within": _rate(r["size_ok"] for r in faulted if r["named"]),
               "clean_false_alarm": _rate(r["false_alarm"] for r in rows if r["fault"] == "none")}
    overall["counts"] = {"named": _count(r["named"] for r in faulted),  # [hits, cases]: the rates' fractions
                         "size_within": _count(r["size_ok"] for r in faulted if r["named"]),
                         "clean_false_alarm": _count(r["false_alarm"] for r in rows if r["fault"] == "none")}
    overall["goals_met"] = {k: (overall[k] is not None and (overall[k] <= g if k == "clean_false_alarm"
                                                            else overall[k] >= g)) for k, g in GOALS.items()}
    return {"overall": overall, "classes": out, "sources": sources}


def score(diag_paths, key_path, size_tol: float) -> dict:
    """{"overall", "classes", "rows", "goals"} of every diagnosed case against the key."""
    key = io.read_json(key_path)["cases"]
    rows = []
    for p in sorted(diag_paths, key=str):
        cid = Path(p).stem
        rows.append({"case": cid, **judge(key[cid], io.read_json(p), size_tol)})
    return {**summary(rows), "rows": rows, "goals": GOALS, "size_tol": size_tol}
