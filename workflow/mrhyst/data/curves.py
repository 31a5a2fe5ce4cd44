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


# --------------------------------------------------------------------------------------------------
# results with several per-sample arrays per loop (the external fits: measured H, B, valid, and each fit's B)
# --------------------------------------------------------------------------------------------------
SAMPLE_KEYS = ("H_A_per_m", "B_T", "valid", CURVE_KEY)  # per-sample arrays of a per-loop record


def _records(obj, path: str = ""):
    """(dotted path without list indices, dict) of every per-loop record (a dict with a ``loop_index`` key)."""
    if isinstance(obj, dict):
        if "loop_index" in obj:
            yield path, obj
        for k, v in obj.items():
            yield from _records(v, f"{path}.{k}" if path else str(k))
    elif isinstance(obj, list):
        for v in obj:
            yield from _records(v, path)


def _is_samples(v) -> bool:
    return isinstance(v, list) and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)


def split_samples(res: dict) -> tuple[dict, list, dict]:
    """(a copy of ``res`` without its per-sample arrays, the columns, {(loop_index, column): values}): every
    SAMPLE_KEYS list of every per-loop record; the column is the record's path and the key, e.g.
    ``loops.B_model_T``, ``joint.per_loop.B_model_T``. A null curve (a failed fit) stays in the JSON."""
    import copy

    body = copy.deepcopy(res)
    columns, values = [], {}
    for path, rec in _records(body):
        for key in SAMPLE_KEYS:
            if not _is_samples(rec.get(key)):
                continue
            col = f"{path}.{key}" if path else key
            cell = (rec["loop_index"], col)
            if cell in values:
                raise ValueError(f"two per-loop records at {path} with loop_index {rec['loop_index']}")
            values[cell] = rec.pop(key)
            if col not in columns:
                columns.append(col)
    columns.sort(key=lambda c: (c.endswith(CURVE_KEY), c))  # the measured arrays first, then the models' B
    return body, columns, values


def samples_text(columns: list, values: dict) -> str:
    """One row per loop and sample: ``loop_index,sample,<columns>`` (loop_index empty for a file with one loop,
    an empty cell where a record has no such array); numbers as JSON wrote them (repr: exact, ints as ints)."""
    loops = list(dict.fromkeys(li for li, _ in values))
    out = [",".join(["loop_index", "sample", *columns])]
    for li in loops:
        cols = [values.get((li, c)) for c in columns]
        n = max(len(v) for v in cols if v is not None)
        if any(v is not None and len(v) != n for v in cols):
            raise ValueError(f"loop_index {li}: per-sample arrays of different lengths")
        tag = "" if li is None else str(int(li))
        out += [",".join([tag, str(k)] + ["" if v is None else repr(v[k]) for v in cols]) for k in range(n)]
    return "\n".join(out) + "\n"


def write_result(res: dict, out) -> None:
    """A result JSON at ``out`` without its per-sample arrays, which go to curve_path(out) (written first: a
    JSON on disk always has its CSV beside it); :func:`read_result` puts them back."""
    from mrhyst.data.io import atomic_path, write_json

    body, columns, values = split_samples(res)
    if columns:
        body["curves"] = {"file": "<this file's name without .json>" + SUFFIX, "columns": ["loop_index", "sample",
                                                                                          *columns]}
        with atomic_path(curve_path(out)) as tmp:
            tmp.write_text(samples_text(columns, values))
    write_json(body, out)


def _number(text: str):
    return int(text) if text.lstrip("-").isdigit() else float(text)


def read_result(path) -> dict:
    """A result JSON written by :func:`write_result` with its per-sample arrays back in place (a JSON without a
    ``curves`` entry is returned as it is)."""
    import csv

    from mrhyst.data.io import InputError, read_json

    res = read_json(path)
    if not res.get("curves") or res["curves"]["columns"][:3] == ["loop_index", "sample", CURVE_KEY]:
        return read_fit(path) if res.get("curves") else res
    cp = curve_path(path)
    if not cp.is_file():
        raise InputError(f"{cp}: file not found (the per-sample arrays of {path})")
    with open(cp, newline="") as fh:
        rows = list(csv.reader(fh))
    head, cells = rows[0], {}
    for r in rows[1:]:
        li = None if r[0] == "" else int(r[0])
        for col, text in zip(head[2:], r[2:]):
            if text != "":
                cells.setdefault((li, col), []).append(_number(text))
    for p, rec in _records(res):
        for key in SAMPLE_KEYS:
            v = cells.get((rec["loop_index"], f"{p}.{key}" if p else key))
            if v is not None and key not in rec:
                rec[key] = v
    return res
