"""Property test (issue 25): mutations of a good sweep and sidecar, and of a good B(H) loop, through the CLI.

Every run ends in exit 0 with finite numbers in its output, or exit 2 with ONE line on stderr; never a
traceback or a warning, never a partial or temporary file, the inputs byte-identical afterwards. Derandomized
(the same examples on every run) and bounded so that it runs in CI: ``convert`` of mutated raw sweeps (the
readers and every sanity check), ``fit --method lsm`` of mutated B(H) loops (the loop checks and a fit), and
``diagnose`` of mutated raw sweeps (the readers, then a whole diagnosis whose every number must be finite).
"""

import contextlib
import io as _io
import json
import math
import tempfile
import warnings
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mrhyst import cli
from test_input_sanity import SIDE, bh_text, sweep_text

CELLS = ["", "abc", "nan", "inf", "-inf", "1e308", "-1e308", "-1", "0", "1e-320", "3.3", "1650", "1,5", " 2 ", "#",
         "1e999", "0x10", "NaN", "None", "-0", "5e2"]
SIDE_VALUES = [0, -1, 1e308, 1e-308, "3.3", None, True, [], {}, 5.0, 1.65, 0.005, 1e6, -3.3, float("nan"),
               float("inf")]
KEYS = ["supply_V", "coil_turns_per_m", "dwell_s", "sensors", "quiescent_V", "sensitivity_V_per_T", "output_min_V",
        "output_max_V"]


@st.composite
def table_mutation(draw, n_rows: int, n_cols: int):
    kind = draw(st.sampled_from(["delete", "duplicate", "swap", "garble", "scale", "drop_col", "rename_col",
                                 "bom_crlf", "blank_comment", "truncate"]))
    r = draw(st.integers(0, n_rows - 1))
    return (kind, r, draw(st.integers(0, n_rows - 1)), draw(st.integers(0, n_cols - 1)), draw(st.sampled_from(CELLS)),
            draw(st.sampled_from([-1.0, 0.0, 1e-3, 1e3, 1e300, 10.0])))


def mutate_table(text: str, muts) -> str:
    head, *rows = text.splitlines()
    rows = [r.split(",") for r in rows]
    cols = head.split(",")
    for kind, r, r2, c, cell, f in muts:
        r, r2 = min(r, len(rows) - 1), min(r2, len(rows) - 1)
        c = min(c, len(cols) - 1)
        if kind == "delete" and len(rows) > 1:
            rows.pop(r)
        elif kind == "duplicate":
            rows.insert(r, list(rows[r]))
        elif kind == "swap":
            rows[r], rows[r2] = rows[r2], rows[r]
        elif kind == "garble":
            rows[r][c] = cell
        elif kind == "scale":
            with contextlib.suppress(ValueError):
                rows[r][c] = repr(float(rows[r][c]) * f)
        elif kind == "drop_col" and len(cols) > 1:
            cols.pop(c)
            rows = [row[:c] + row[c + 1:] for row in rows]
        elif kind == "rename_col":
            cols[c] = cols[c].upper() if cell == "" else cols[c] + "x"
        elif kind == "truncate":
            rows = rows[: max(r, 1)]
    lines = [",".join(cols)] + [",".join(row) for row in rows]
    if any(m[0] == "blank_comment" for m in muts):
        lines = ["# logger"] + lines[:3] + [""] + lines[3:]
    text = "\n".join(lines) + "\n"
    if any(m[0] == "bom_crlf" for m in muts):
        text = "\ufeff" + text.replace("\n", "\r\n")
    return text


@st.composite
def side_mutation(draw):
    kind = draw(st.sampled_from(["none", "set", "delete", "rename", "add", "bom"]))
    return kind, draw(st.sampled_from(KEYS)), draw(st.sampled_from(SIDE_VALUES))


def mutate_side(muts) -> str:
    side = json.loads(json.dumps(SIDE))
    bom = ""
    for kind, key, value in muts:
        d = side if key in side else side["sensors"]["hall1"] if isinstance(side.get("sensors"), dict) and \
            isinstance(side["sensors"].get("hall1"), dict) else side
        if kind == "set":
            d[key] = value
        elif kind == "delete":
            d.pop(key, None)
        elif kind == "rename" and key in d:
            d[key.lower() if key != key.lower() else key + "_"] = d.pop(key)
        elif kind == "add":
            d["x_" + key] = value
        elif kind == "bom":
            bom = "\ufeff"
    return bom + json.dumps(side)


def run_cli(argv, folder: Path):
    """main(argv) in-process: (exit code, stderr, warnings raised); the folder's files before == after checked."""
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    err = _io.StringIO()
    with warnings.catch_warnings(record=True) as caught, contextlib.redirect_stderr(err):
        warnings.simplefilter("always")
        rc = cli.main([str(a) for a in argv])
    after = {p.name: p.read_bytes() for p in folder.iterdir() if p.name != "out"}
    assert after == before, "an input changed or a temporary file was left"
    return rc, err.getvalue(), [str(w.message) for w in caught]


def check_outcome(rc, err, caught, out: Path):
    assert not caught, caught
    assert "Traceback" not in err
    if rc == 2:
        assert err.count("\n") == 1 and err.endswith("\n"), err
        assert not out.exists() and list(out.parent.iterdir()) == [] if out.parent.exists() else True
        return None
    assert rc == 0 and err == "", (rc, err)
    return out


def finite_csv(path: Path) -> None:
    import pandas as pd

    df = pd.read_csv(path)
    num = df.select_dtypes("number").to_numpy(dtype=float)
    assert num.size and np.all(np.isfinite(num)), path


FUZZ = settings(max_examples=120, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@FUZZ
@given(st.lists(table_mutation(55, 4), min_size=0, max_size=3), st.lists(side_mutation(), min_size=0, max_size=2))
def test_convert_of_a_mutated_sweep_and_sidecar(table_muts, side_muts):
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        (d / "RAW.csv").write_text(mutate_table(sweep_text(), table_muts))
        (d / "RAW.json").write_text(mutate_side(side_muts))
        out = d / "out" / "loop.csv"
        rc, err, caught = run_cli(["convert", d / "RAW.csv", "--sensor", "hall1", "--out", out], d)
        if check_outcome(rc, err, caught, out):
            finite_csv(out)


@settings(max_examples=12, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(table_mutation(55, 2), min_size=1, max_size=2))
def test_lsm_fit_of_a_mutated_b_h_loop(table_muts):
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        (d / "L.csv").write_text(mutate_table(bh_text(), table_muts))
        out = d / "out" / "fit.json"
        rc, err, caught = run_cli(["fit", d / "L.csv", "--method", "lsm", "--out", out], d)
        if check_outcome(rc, err, caught, out):
            fit = json.loads(out.read_text())  # write_json refuses a non-finite number; the fit's own figures:
            assert all(math.isfinite(v) for v in fit["params"].values()) and math.isfinite(fit["rms_T"])


def finite_json(node, where="DIAG") -> None:
    """Every number of a diagnosis JSON is finite (null is allowed: it says 'not computed', never a silent NaN)."""
    if isinstance(node, dict):
        for k, v in node.items():
            finite_json(v, f"{where}.{k}")
    elif isinstance(node, list):
        for i, v in enumerate(node):
            finite_json(v, f"{where}[{i}]")
    elif isinstance(node, float):
        assert math.isfinite(node), where


@settings(max_examples=8, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(table_mutation(55, 4), min_size=1, max_size=2), st.lists(side_mutation(), min_size=0, max_size=1))
def test_diagnose_of_a_mutated_sweep_and_sidecar(table_muts, side_muts):
    """`diagnose` reads through the same readers as `convert`, then fits: a mutation that passes the readers must
    give a diagnosis whose every number is finite; one that does not, one line and no output."""
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        (d / "RAW.csv").write_text(mutate_table(sweep_text(), table_muts))
        (d / "RAW.json").write_text(mutate_side(side_muts))
        out = d / "out" / "diag.json"
        with contextlib.redirect_stdout(_io.StringIO()):
            rc, err, caught = run_cli(["diagnose", d / "RAW.csv", "--sensor", "hall1", "--quiet", "--out", out], d)
        if check_outcome(rc, err, caught, out):
            diag = json.loads(out.read_text())
            finite_json(diag)
            assert diag["effect"], diag["verdict"]
