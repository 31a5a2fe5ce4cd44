"""Start-up of a fit (issue 26): the CSV reader without pandas reads what pandas read, a fit's curve CSV has the
bytes pandas wrote, and a warm `mrhyst fit` of a loop file loads neither pandas nor jsonschema nor matplotlib
(the times are measured in bench/bench_startup.py, never here)."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst import config
from mrhyst.data import csvtext, curves
from mrhyst.data.errors import InputError

ROOT = Path(__file__).resolve().parents[1]

_number = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False, width=64).map(repr),
    st.floats(-1e6, 1e6, allow_nan=False).map(lambda v: f"{v:.6e}"),
    st.integers(-10**20, 10**20).map(str),
    st.sampled_from(["1.", ".5", "-0", "+3", "1E-5", "nan", "inf", "-Infinity", "1_0", "0x1", "", "abc", "1;5",
                     "\u0661", "1d5"]),
)


def _pandas_numeric(text: str, col: str) -> np.ndarray:
    """What the reader did before (pandas.read_csv as text, then pandas.to_numeric per column)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", pd.errors.ParserWarning)
        df = pd.read_csv(io.StringIO(text), dtype=str, keep_default_na=False, skipinitialspace=True,
                         index_col=False, sep=",")
    return pd.to_numeric(df[col].astype(str).str.strip(), errors="coerce").to_numpy(dtype=float)


@settings(max_examples=150, deadline=None, derandomize=True)
@given(st.lists(st.tuples(_number, _number, st.sampled_from(["", " ", "  "])), min_size=1, max_size=12))
def test_reader_without_pandas_reads_the_numbers_pandas_read(rows):
    """Each value, or the first bad one and its line, as pandas gave them (the expectation is pandas' own reading,
    not this reader's code)."""
    text = "H_A_per_m,B_T\n" + "".join(f"{pad}{h},{pad}{b}{pad}\n" for h, b, pad in rows)
    lines = text.splitlines()
    table = csvtext._frame(lines, ",", ["H_A_per_m", "B_T"], Path("x.csv"))
    assert isinstance(table, csvtext.Table) and len(table) == len(rows)
    for col in ("H_A_per_m", "B_T"):
        want = _pandas_numeric(text, col)
        bad = ~np.isfinite(want)
        if bad.any():
            with pytest.raises(InputError, match=f"row {int(np.argmax(bad)) + 2}, column {col}:"):
                csvtext.numeric(table, col, "x.csv")
        else:
            np.testing.assert_array_equal(csvtext.numeric(table, col, "x.csv"), want)


def test_rows_pandas_must_read_keep_their_messages(tmp_path):
    """A short row, a long row and a quoted field go through pandas, with the messages of before (checked on
    the tree before this change: a short row read as an empty field)."""
    p = tmp_path / "l.csv"
    p.write_text("H_A_per_m,B_T\n1,0.1\n2\n3,0.3\n4,0.4\n5,0.5\n")
    t = csvtext.read_csv(p, ("H_A_per_m", "B_T"))
    with pytest.raises(InputError, match=r"row 3, column B_T: expected a finite number, got ''"):
        csvtext.numeric(t, "B_T", p)
    p.write_text("H_A_per_m,B_T\n1,0.1\n2,0.2,9\n")
    with pytest.raises(InputError, match="row 3: 3 fields, more fields than the header"):  # the file's own line
        csvtext.read_csv(p, ("H_A_per_m", "B_T"))
    p.write_text('H_A_per_m,B_T\n"1",0.1\n2,"0.2"\n')
    np.testing.assert_array_equal(csvtext.numeric(csvtext.read_csv(p, ("H_A_per_m", "B_T")), "B_T", p), [0.1, 0.2])


def test_curve_csv_has_the_bytes_pandas_wrote(tmp_path):
    rows = [(None, [0.1, -2.5e-7, 1.0, 0.0]), (3, np.array([1 / 3, -0.0, 12345678901.5]))]
    want = pd.concat([pd.DataFrame({"loop_index": pd.array([li] * len(b), dtype="Int64"), "sample": np.arange(len(b)),
                                    "B_model_T": np.asarray(b, dtype=float)}) for li, b in rows], ignore_index=True)
    buf = io.StringIO()
    want.to_csv(buf, index=False, float_format="%.10g", lineterminator="\n")
    assert curves.curve_text(rows) == buf.getvalue()


def test_is_default_is_exact():
    d = config.defaults("lsm")
    assert config.is_default("lsm", d)
    key, v = next((k, v) for k, v in d.items() if isinstance(v, int) and not isinstance(v, bool))
    assert not config.is_default("lsm", {**d, key: float(v)})  # 5.0 is not the schema's 5: checked the usual way
    assert not config.is_default("lsm", {**d, key: v + 1})


def test_fit_loads_neither_pandas_nor_jsonschema(tmp_path):
    """A fit of a loop file with the defaults: numpy, numba and scipy only (pandas, jsonschema, matplotlib are
    a third of the start-up they used to cost)."""
    raw = ROOT / "data" / "raw" / "li_gong_rig.csv"
    loop = tmp_path / "loop.csv"
    subprocess.run([sys.executable, "-m", "mrhyst", "convert", str(raw), "--sensor", "hall1", "--out", str(loop)],
                   check=True, capture_output=True)
    code = ("import sys, runpy; sys.argv = ['mrhyst', 'fit', sys.argv[1], '--method', 'lsm', '--out', sys.argv[2], "
            "'--quiet']; runpy.run_module('mrhyst', run_name='__main__', alter_sys=True)\n")
    code = ("import sys, atexit, runpy\n"
            "atexit.register(lambda: print(sorted({m.split('.')[0] for m in sys.modules} & {'pandas', 'jsonschema', "
            "'matplotlib'}), file=sys.stderr))\n" + code.split("\n")[0].replace("import sys, runpy; ", ""))
    r = subprocess.run([sys.executable, "-c", code, str(loop), str(tmp_path / "f.json")], capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr
    assert r.stderr.strip().splitlines()[-1] == "[]", r.stderr
    assert (tmp_path / "f.curve.csv").read_text().startswith("loop_index,sample,B_model_T\n,0,")


# --------------------------------------------------------------------------------------------------
# per-sample arrays beside a result JSON (issue 26 item 5: the external fits)
# --------------------------------------------------------------------------------------------------
_values = st.lists(st.one_of(st.floats(allow_nan=False, allow_infinity=False), st.integers(-5, 5)), min_size=1,
                   max_size=6)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.one_of(st.none(), st.integers(0, 9)), _values, st.booleans()), min_size=1, max_size=4,
                unique_by=lambda t: t[0]), st.booleans())
def test_per_sample_arrays_go_beside_the_json_and_come_back_exactly(tmp_path_factory, loops, joint):
    """Any per-loop arrays (ints stay ints, floats keep every bit, a failed fit's null curve stays in the JSON)
    come back where they were; the JSON on disk holds none of them."""
    recs = [{"loop_index": li, "rms_T": 1e-3, "B_T": list(v), "valid": [1] * len(v),
             "B_model_T": [2 * x for x in v] if ok else None} for li, v, ok in loops]
    res = {"source": "s", "loops": recs, "history": [0.5, 0.25]}
    if joint:
        res["joint"] = {"params": {"Ms": 1.0}, "per_loop": [{"loop_index": r["loop_index"], "B_model_T": r["B_T"]}
                                                             for r in recs]}
    out = tmp_path_factory.mktemp("r") / "x.json"
    curves.write_result(res, out)
    on_disk = json.loads(out.read_text())
    assert on_disk["history"] == [0.5, 0.25]  # not per sample: stays
    assert all(set(r) - {"B_model_T"} == {"loop_index", "rms_T"} for r in on_disk["loops"])
    assert all(r.get("B_model_T", "moved") in (None, "moved") for r in on_disk["loops"])
    back = curves.read_result(out)
    assert back.pop("curves")["columns"][:2] == ["loop_index", "sample"]
    assert json.dumps(back, sort_keys=True) == json.dumps(res, sort_keys=True)


def test_curve_file_is_one_row_per_loop_and_sample(tmp_path):
    res = {"loops": [{"loop_index": 3, "B_T": [0.1, 0.2], "H_A_per_m": [1.0, 2.0], "valid": [1, 0],
                      "B_model_T": [0.11, 0.19]}]}
    curves.write_result(res, tmp_path / "r.json")
    assert (tmp_path / "r.curve.csv").read_text() == (
        "loop_index,sample,loops.B_T,loops.H_A_per_m,loops.valid,loops.B_model_T\n"
        "3,0,0.1,1.0,1,0.11\n3,1,0.2,2.0,0,0.19\n")


# --------------------------------------------------------------------------------------------------
# the process entry's start-up and exit (mrhyst.startup)
# --------------------------------------------------------------------------------------------------
def test_process_entry_gives_the_bytes_and_lines_of_an_in_process_run(tmp_path):
    """`python -m mrhyst fit` (one BLAS thread, the collector off while loading, no interpreter teardown) writes
    the bytes and prints the line an in-process ``cli.main(argv)`` does (BLAS threads as the environment has
    them, none of the process start-up); the atexit handlers still run; a refusal is still exit 2 and one line."""
    from mrhyst import cli

    raw = ROOT / "data" / "raw" / "li_gong_rig.csv"
    loop = tmp_path / "loop.csv"
    assert cli.main(["convert", str(raw), "--sensor", "hall1", "--out", str(loop)]) == 0
    code = ("import atexit, sys, runpy; atexit.register(lambda: print('atexit ran', file=sys.stderr)); "
            "sys.argv = ['mrhyst'] + sys.argv[1:]; runpy.run_module('mrhyst', run_name='__main__', alter_sys=True)")
    r = subprocess.run([sys.executable, "-c", code, "fit", str(loop), "--method", "lsm", "--out",
                        str(tmp_path / "p.json")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stderr.strip() == "atexit ran"
    first, *warn = r.stdout.splitlines()  # the fit's line, then one per warning (alpha at its box edge here)
    assert first.startswith("fit: ja, lsm, RMS ") and first.endswith("p.json") and r.stdout.endswith("\n")
    assert all(w.startswith("  warning: ") for w in warn)
    assert cli.main(["fit", str(loop), "--method", "lsm", "--out", str(tmp_path / "i.json"), "--quiet"]) == 0
    for ext in (".json", ".curve.csv"):
        assert (tmp_path / f"p{ext}").read_bytes() == (tmp_path / f"i{ext}").read_bytes()
    bad = subprocess.run([sys.executable, "-m", "mrhyst", "fit", str(tmp_path / "none.csv"), "--out",
                          str(tmp_path / "n.json")], capture_output=True, text=True)
    assert bad.returncode == 2 and len(bad.stderr.splitlines()) == 1 and not (tmp_path / "n.json").exists()


def test_collector_is_back_on_with_the_loaded_objects_frozen(monkeypatch):
    """After start-up the command's own garbage is collected again (a cycle made after imported() is freed)."""
    import gc

    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)  # begin() sets it: restored after the test
    import weakref

    from mrhyst import startup

    assert gc.isenabled()
    try:
        startup.begin(heavy=True)
        assert not gc.isenabled() and os.environ["OPENBLAS_NUM_THREADS"] == "1"
        startup.imported()
        assert gc.isenabled() and gc.get_freeze_count() > 0

        class Node:
            pass

        a = Node()
        a.self = a
        gone = weakref.ref(a)
        del a
        gc.collect()
        assert gone() is None
        startup.imported()  # on: nothing to do
        assert gc.isenabled()
    finally:
        gc.unfreeze()
        gc.enable()


def test_reader_leaving_early_keeps_the_written_output_and_exit_0(tmp_path):
    """`mrhyst fit ... | head`: stdout's reader is gone before the summary line; the fit's files were written before
    it, so the command says so in one line and exits 0 (it said 'Broken pipe; no output written', exit 2)."""
    from mrhyst import cli

    loop = tmp_path / "loop.csv"
    assert cli.main(["convert", str(ROOT / "data" / "raw" / "li_gong_rig.csv"), "--sensor", "hall1", "--out",
                     str(loop)]) == 0
    out = tmp_path / "p.json"
    p = subprocess.Popen([sys.executable, "-m", "mrhyst", "fit", str(loop), "--method", "lsm", "--out", str(out)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    p.stdout.close()  # the reader leaves before the process prints anything
    err = p.stderr.read()
    assert p.wait() == 0, err
    assert err.splitlines() == ["mrhyst fit: stdout closed by its reader; the output was written"]
    assert json.loads(out.read_text())["method"] == "lsm" and out.with_suffix(".curve.csv").exists()


# --------------------------------------------------------------------------------------------------
# the config schema kept parsed beside it (mrhyst.startup.cached_yaml)
# --------------------------------------------------------------------------------------------------
def test_schema_cache_is_used_only_for_the_same_bytes_and_written_as_bytecode_is(tmp_path, monkeypatch):
    import yaml
    from mrhyst import startup

    src = tmp_path / "s.yaml"
    src.write_text("a: {default: 1}\nb: [x, 2.5, null, true]\n")
    calls = []

    def load(text):
        calls.append(text)
        return yaml.safe_load(text)

    monkeypatch.setattr(sys, "dont_write_bytecode", True)  # -B / PYTHONDONTWRITEBYTECODE: parsed, nothing written
    assert startup.cached_yaml(src, load) == {"a": {"default": 1}, "b": ["x", 2.5, None, True]}
    assert not (tmp_path / "__pycache__").exists() and len(calls) == 1
    monkeypatch.setattr(sys, "dont_write_bytecode", False)
    first = startup.cached_yaml(src, load)
    assert len(calls) == 2 and list((tmp_path / "__pycache__").iterdir()) != []
    assert startup.cached_yaml(src, load) == first and len(calls) == 2  # from the cache: not parsed again
    st0 = src.stat()
    src.write_text("a: {default: 7}\nb: [x, 2.5, null, true]\n")  # same size, same timestamps: other bytes
    os.utime(src, ns=(st0.st_atime_ns, st0.st_mtime_ns))
    assert startup.cached_yaml(src, load)["a"] == {"default": 7} and len(calls) == 3
    cache = next((tmp_path / "__pycache__").glob("s.yaml.*.marshal"))
    cache.write_bytes(b"\x00garbage")  # a truncated or foreign cache is parsed over, never trusted
    assert startup.cached_yaml(src, load)["a"] == {"default": 7} and len(calls) == 4
    assert [p.name for p in (tmp_path / "__pycache__").iterdir()] == [cache.name]  # no temporary left behind


def test_the_schema_read_through_the_cache_is_the_schema(tmp_path):
    """The project's schema by the cache (a fresh process that writes it, one that reads it) equals yaml's own
    read of the file."""
    import yaml

    code = ("import json, sys; from mrhyst import config; json.dump(config._schema(), sys.stdout)")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    got = [json.loads(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                     check=True).stdout) for _ in range(2)]
    want = json.loads(json.dumps(yaml.safe_load(config.SCHEMA_PATH.read_text())))
    assert got[0] == want and got[1] == want
