"""Per-sample model curves beside a result JSON (issue 26): ``--out F.json`` writes ``F.curve.csv``.

A fit JSON keeps the numbers a person reads (parameters, RMS, loop figures); the model's B at every sample
(``B_model_T``: 5,000 numbers for one long loop) goes to a CSV beside it, one row per sample and loop:

    loop_index,sample,B_model_T

(``loop_index`` empty for a file with one loop; ``sample`` counts the loop's rows from 0; a loop whose
integration failed has no rows). :func:`read_fit` puts the curves back where the JSON had them, so readers
(report, notebooks, tests) see the old shape.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

CURVE_KEY = "B_model_T"
SUFFIX = ".curve.csv"


def curve_path(out) -> Path:
    """F.json -> F.curve.csv (any other name: NAME.curve.csv beside it)."""
    p = Path(out)
    return p.with_name((p.name[:-5] if p.name.endswith(".json") else p.name) + SUFFIX)


def split_curves(res: dict) -> tuple[dict, list]:
    """(the result without its per-sample curves, [(loop_index, B_model_T list)]). Curves live at the top
    (a one-loop fit) and in ``per_loop[]``; the top one repeats per_loop[0]'s, so it is dropped."""
    out = dict(res)
    rows = []
    top = out.pop(CURVE_KEY, None)
    per = out.get("per_loop")
    if per:
        out["per_loop"] = []
        for e in per:
            e = dict(e)
            b = e.pop(CURVE_KEY, None)
            if b is not None:
                rows.append((e.get("loop_index"), b))
            out["per_loop"].append(e)
    elif top is not None:
        rows.append((res.get("loop_index") if isinstance(res.get("loop_index"), int) else None, top))
    return out, rows


def curve_text(rows: list) -> str:
    """The curve CSV of ``[(loop_index or None, B list)]`` (the bytes pandas' ``to_csv(index=False,
    float_format="%.10g")`` wrote, without importing pandas: a fit starts faster, issue 26)."""
    out = ["loop_index,sample," + CURVE_KEY]
    for li, b in rows:
        tag = "" if li is None else str(int(li))
        out += [f"{tag},{k},{v:.10g}" for k, v in enumerate(np.asarray(b, dtype=float).tolist())]
    return "\n".join(out) + "\n"


def write_with_curves(res: dict, out) -> None:
    """The JSON without curves at ``out`` and the curves at curve_path(out), each written atomically (the CSV
    first: a JSON on disk always has its curves beside it)."""
    from mrhyst.data.io import atomic_path, write_json

    body, rows = split_curves(res)
    if rows:
        # the suffix, not the name: the same fit gives the same bytes whatever --out is called
        body["curves"] = {"file": "<this file's name without .json>" + SUFFIX, "columns": ["loop_index", "sample",
                                                                                          CURVE_KEY]}
        with atomic_path(curve_path(out)) as tmp:
            tmp.write_text(curve_text(rows))
    else:
        body.pop("curves", None)
    write_json(body, out)


def read_fit(path) -> dict:
    """A fit JSON with its curves back in place (``per_loop[].B_model_T`` and, for one loop, ``B_model_T``);
    a JSON without a ``curves`` entry (older, or no curve) is returned as it is."""
    import pandas as pd

    from mrhyst.data.io import InputError, read_json

    res = read_json(path)
    ref = res.get("curves")
    if not ref:
        return res
    cp = curve_path(path)
    if not cp.is_file():
        raise InputError(f"{cp}: file not found (the model curves of {path})")
    df = pd.read_csv(cp, dtype={"loop_index": "Int64"})
    by = {None if pd.isna(k) else int(k): g.sort_values("sample")[CURVE_KEY].tolist()
          for k, g in df.groupby("loop_index", dropna=False, sort=False)}
    for e in res.get("per_loop") or []:
        e[CURVE_KEY] = by.get(e.get("loop_index"))
    if res.get("per_loop") and len(res["per_loop"]) == 1 and "joint_objective_T" not in res:
        res[CURVE_KEY] = res["per_loop"][0][CURVE_KEY]
    elif not res.get("per_loop") and by:
        res[CURVE_KEY] = next(iter(by.values()))
    return res
