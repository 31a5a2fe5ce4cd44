"""Bad input everywhere a user can give it (issue 6), beyond the spine's list in test_hall_io.py.

Every bad input: exit != 0, one line on stderr naming where and what, no traceback, and nothing in the
output folder afterwards. Not errors: bipolar sweeps and several cycles (convert and fit follow any
piecewise-monotone path) and large files (10^5 rows, timed).
"""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from mrhyst import cli
from mrhyst.data import io
from mrhyst.model import ja

ROOT = Path(__file__).resolve().parent.parent
P1 = np.array([1.2456e6, 2.6882e4, 1.4697e-4, 0.5385, 5.6943e3])  # Table 1, group 1, PSO
SIDE = {"supply_V": 3.3, "coil_turns_per_m": 3000.0, "dwell_s": 0.1,
        "sensors": {"hall1": {"sensitivity_V_per_T": 5.0, "quiescent_V": 1.65,
                              "output_min_V": 0.2, "output_max_V": 3.1}}}


def run(argv, capsys):
    rc = cli.main([str(a) for a in argv])
    err = capsys.readouterr().err
    return rc, err


def assert_one_line_error(rc, err, *expect):
    assert rc != 0
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert "Traceback" not in err
    for e in expect:
        assert e in err, err


def assert_empty(folder: Path):
    assert not folder.exists() or list(folder.iterdir()) == [], list(folder.iterdir())


def bh_text(n=30, scale=1.0, header="H_A_per_m,B_T"):
    H = 100.0 * np.sin(np.linspace(0, 2 * np.pi, n))
    B = scale * 0.01 * H / 100.0 * 5
    return header + "\n" + "".join(f"{h:.6f},{b:.6f}\n" for h, b in zip(H, B))


def loop_file_text(n=12, saturated=None):
    I = np.concatenate([np.linspace(0, 2, n // 2 + 1), np.linspace(2, 0, n // 2 + 1)[1:]])
    B, _ = ja.simulate(P1, I, 3000.0, form="paper", substeps=8)
    sat = "" if saturated is None else ",saturated"
    rows = []
    for j, (i, b) in enumerate(zip(I, B)):
        br = "up" if j <= n // 2 else "down"
        s = "" if saturated is None else f",{saturated(j)}"
        rows.append(f"{j},{i:.6f},{3000 * i:.6f},{b:.8f},{br}{s}\n")
    return f"step,current_A,H_A_per_m,B_T,branch{sat}\n" + "".join(rows)


# name -> (file body (str or bytes), what the message must contain)
BAD_FIT = {
    "empty file": ("", "empty file"),
    "whitespace only": ("\n  \n", "empty file"),
    "garbage text": ("hello world\nthis is not a loop\n", "missing column(s) H_A_per_m, B_T"),
    "a raw sweep (no --sensor)": ("step,time_s,current_A,hall1_V\n" + "".join(f"{j},{j + 1},{j / 10},1.7\n" for j in
                                                                                range(8)),
                                  "a raw Hall sweep: `mrhyst diagnose` reads it with --sensor NAME"),
    "binary garbage": (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)), "binary data"),
    "not UTF-8": (b"H_A_per_m,B_T\n1,\xff\xfe\n", "not UTF-8"),
    "header only": ("H_A_per_m,B_T\n", "header only"),
    "NaN in B": (bh_text().replace("\n0.000000,0.000000", "\n0.000000,nan", 1).replace(",0.025", ",nan", 1),
                 "expected a finite number"),
    "text in H": (bh_text().replace("\n", "\nabc,0.1\n", 1), "row 2, column H_A_per_m"),
    "B in mT (values)": (bh_text(scale=1000.0), "not a plausible flux density"),
    "B in gauss (values)": (bh_text(scale=10000.0), "expected tesla, not mT or gauss"),
    "B_mT column": (bh_text(header="H_A_per_m,B_mT"), "column 'B_mT': B must be in tesla"),
    "B (G) column": (bh_text(header="H (A/m),B (G)"), "column 'B (G)': B must be in tesla"),
    "H in Oe": (bh_text(header="H (Oe),B (T)"), "column 'H (Oe)': H must be in A/m"),
    "H in kA/m": (bh_text(header="H_kA_per_m,B_T"), "column 'H_kA_per_m': H must be in A/m"),
    "pipe separated": ("H|B\n" + "1|0.1\n" * 8, "separator looks like"),
    "extra field in rows": ("H_A_per_m,B_T\n" + "1,0.1,7\n" * 8, "more fields than the header"),
    # the file's own line (after a logger's comment preamble), not pandas' count of the lines it kept
    "extra field after a preamble": ("# logger v2\n# operator X\nH_A_per_m,B_T\n" + "1,0.1\n" * 3 + "2,0.2,9\n"
                                     + "3,0.3\n" * 4, "row 7: 3 fields, more fields than the header"),
    "decimal commas in a comma file": ("H_A_per_m,B_T\n" + "1,5,0,1\n" * 8, "decimal commas in a comma-separated"),
    "a loop file without its branch": (loop_file_text(12).replace(",branch", "").replace(",up", "").replace(
        ",down", ""), "has step, current_A but no branch column"),
    "duplicate column": ("H_A_per_m,B_T,B_T\n" + "1,0.1,0.2\n" * 8, "duplicate column(s) B_T"),
    "fewer than 5 rows": ("H_A_per_m,B_T\n1,0.1\n2,0.2\n", "at least 5 samples"),
    "fewer than 6 valid samples": (loop_file_text(12, saturated=lambda j: int(j > 4)), "5 valid (unsaturated)"),
    "all samples saturated": (loop_file_text(12, saturated=lambda j: 1), "all 13 samples are flagged saturated"),
    "saturated not 0/1": (loop_file_text(12, saturated=lambda j: 2), "column saturated: expected 0 or 1"),
    "H constant": ("H_A_per_m,B_T\n" + "".join(f"5,{0.01 * i}\n" for i in range(8)), "H does not change"),
    "B constant": ("H_A_per_m,B_T\n" + "".join(f"{i},0.02\n" for i in range(8)), "B is constant"),
    "unsorted steps in a loop file": (loop_file_text(12).replace("\n3,", "\n1,", 1), "steps must strictly increase"),
    "several loops without --loop-index": (
        "loop_index,H_A_per_m,B_T\n" + "".join(f"{k},{h},{h / 1e3}\n" for k in (0, 1) for h in range(-4, 5)),
        "holds 2 loops (loop_index 0, 1); choose one"),
    "loop_index not contiguous": (
        "loop_index,H_A_per_m,B_T\n" + "".join(f"{k},{h},{h / 1e3}\n" for k in (0, 1, 0) for h in range(-4, 5)),
        "loop 0 appears again"),
    "sample_index unsorted": (
        "loop_index,sample_index,H_A_per_m,B_T\n" + "".join(f"0,{s},{s},{s / 1e3}\n" for s in (0, 1, 2, 4, 3, 5, 6)),
        "samples must be in the order measured"),
}


@pytest.mark.parametrize("case", sorted(BAD_FIT))
def test_fit_bad_loop_files(case, tmp_path, capsys):
    body, expect = BAD_FIT[case]
    p = tmp_path / "in" / "loop.csv"
    p.parent.mkdir()
    p.write_bytes(body) if isinstance(body, bytes) else p.write_text(body)
    out = tmp_path / "out" / "fit.json"
    rc, err = run(["fit", p, "--method", "lsm", "--out", out], capsys)
    assert_one_line_error(rc, err, expect, "loop.csv")
    assert_empty(out.parent)


def test_fit_missing_file(tmp_path, capsys):
    out = tmp_path / "out" / "fit.json"
    rc, err = run(["fit", tmp_path / "nope.csv", "--method", "pso", "--out", out], capsys)
    assert_one_line_error(rc, err, "nope.csv: file not found")
    assert_empty(out.parent)


@pytest.mark.parametrize("argv,expect", [
    (["--method", "newton"], "argument --method: invalid choice: 'newton'"),
    (["--method", "lsm", "--form", "jiles"], "argument --form: invalid choice"),
    (["--method", "lsm", "--seed", "-1"], "argument --seed"),
    (["--method", "lsm", "--seed", "1.5"], "argument --seed"),
    (["--method", "lsm", "--start", "virgin"], "argument --start: invalid choice"),
    (["--method", "lsm", "--loop-index", "x"], "argument --loop-index"),
    (["--method", "lsm", "--loop-index", "0"], "no loop_index column"),
    (["--method", "lsm", "--joint-weight", "own"], "--joint-weight is for a joint fit"),
    (["--method", "lsm", "--joint-weight", "mine"], "argument --joint-weight: invalid choice"),
])
def test_fit_bad_options(argv, expect, tmp_path, capsys):
    p = tmp_path / "loop.csv"
    p.write_text(bh_text())
    out = tmp_path / "out" / "fit.json"
    with pytest.raises(SystemExit) if "argument" in expect else _nullcontext():
        rc, err = run(["fit", p, *argv, "--out", out], capsys)
    if "argument" in expect:
        err = capsys.readouterr().err
        rc = 2
    assert_one_line_error(rc, err, expect)
    assert_empty(out.parent)


class _nullcontext:
    def __enter__(self):
        return self

    def __exit__(self, *a):
        return False


def test_simulate_bad_substeps_is_one_line(tmp_path, capsys):
    out = tmp_path / "out" / "sim.csv"
    with pytest.raises(SystemExit) as e:
        cli.main(["simulate", "--Ms", "1e6", "--a", "1e4", "--alpha", "1e-3", "--c", "0.2", "--k", "1e3",
                  "--n-over-le", "3000", "--substeps", "0", "--out", str(out)])
    err = capsys.readouterr().err
    assert e.value.code == 2
    assert_one_line_error(2, err, "argument --substeps: expected a whole number >= 1")
    with pytest.raises(SystemExit):
        cli.main(["simulate", "--Ms", "nan", "--n-over-le", "3000", "--out", str(out)])
    assert_one_line_error(2, capsys.readouterr().err, "argument --Ms: expected a finite number")
    assert_empty(out.parent)


# --------------------------------------------------------------------------------------------------
# --out
# --------------------------------------------------------------------------------------------------
def test_out_is_a_folder(tmp_path, capsys):
    p = tmp_path / "loop.csv"
    p.write_text(bh_text())
    d = tmp_path / "outdir"
    d.mkdir()
    rc, err = run(["fit", p, "--method", "lsm", "--out", d], capsys)
    assert_one_line_error(rc, err, "is a folder; --out needs a file path")
    rc, err = run(["fit", p, "--method", "lsm", "--out", str(tmp_path / "new") + "/"], capsys)
    assert_one_line_error(rc, err, "is a folder")
    assert_empty(d)
    assert not (tmp_path / "new").exists()


def test_out_under_a_file(tmp_path, capsys):
    p = tmp_path / "loop.csv"
    p.write_text(bh_text())
    rc, err = run(["fit", p, "--method", "lsm", "--out", tmp_path / "loop.csv" / "fit.json"], capsys)
    assert_one_line_error(rc, err, "is a file, not a folder")


def test_out_is_the_input(tmp_path, capsys):
    p = tmp_path / "loop.csv"
    p.write_text(bh_text())
    before = p.read_bytes()
    rc, err = run(["fit", p, "--method", "lsm", "--out", p], capsys)
    assert_one_line_error(rc, err, "--out is the input file")
    assert p.read_bytes() == before


def test_out_folder_not_writable(tmp_path, capsys):
    """/sys refuses new files even to root (chmod would not stop root, which runs CI here)."""
    import tempfile

    try:
        fd, probe = tempfile.mkstemp(dir="/sys")
    except OSError:
        pass
    else:  # pragma: no cover
        import os

        os.close(fd)
        os.unlink(probe)
        pytest.skip("/sys is writable here")
    p = tmp_path / "loop.csv"
    p.write_text(bh_text())
    rc, err = run(["fit", p, "--method", "lsm", "--out", "/sys/mrhyst-test/fit.json"], capsys)
    assert_one_line_error(rc, err, "output folder /sys is not writable")
    raw = tmp_path / "sweep.csv"
    raw.write_text("step,time_s,current_A,hall1_V\n" + "".join(f"{j},{j + 1},{j},1.66\n" for j in range(6)))
    (tmp_path / "sweep.json").write_text(json.dumps(SIDE))
    rc, err = run(["convert", raw, "--sensor", "hall1", "--out", "/sys/mrhyst-test/loop.csv"], capsys)
    assert_one_line_error(rc, err, "not writable")


def test_write_failure_late_is_one_line(tmp_path, capsys, monkeypatch):
    """A write that fails after the checks (disk full) still gives one line and leaves no file."""
    p = tmp_path / "loop.csv"
    p.write_text(bh_text())
    out = tmp_path / "out" / "fit.json"

    def full(*a, **k):
        raise OSError(28, "No space left on device", str(out))

    monkeypatch.setattr(io.os, "replace", full)
    rc, err = run(["fit", p, "--method", "lsm", "--out", out], capsys)
    assert_one_line_error(rc, err, "No space left on device", "no output written")
    assert_empty(out.parent)


# --------------------------------------------------------------------------------------------------
# config via `mrhyst fit --config`
# --------------------------------------------------------------------------------------------------
def _cfg(tmp_path, mutate):
    cfg = yaml.safe_load((ROOT / "config.yaml").read_text())
    mutate(cfg)
    p = tmp_path / "cfg.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


def _set(path, value):
    def m(cfg):
        d = cfg
        for k in path[:-1]:
            d = d.setdefault(k, {})
        d[path[-1]] = value
    return m


BAD_CONFIG = {
    "unknown top-level key": (_set(["fitting"], {"x": 1}), "unknown key(s) fitting"),
    "mistyped key": (_set(["ja", "substep"], 2), "ja: unknown key(s) substep"),
    "wrong type": (_set(["ja", "substeps"], "two"), "ja.substeps: 'two' is not of type 'integer'"),
    "string float (no dot)": (_set(["paper", "i_max_A"], "1e-3"), "paper.i_max_A"),
    "box lower > upper": (_set(["pso", "default_box", "lo", "Ms"], 1.0e+7), "pso.default_box"),
    "box unknown parameter": (_set(["pso", "default_box", "hi", "Mss"], 1.0), "pso.default_box.hi: unknown key(s) Mss"),
    "bracket lower > upper": (_set(["nle", "bracket"], [5.0, 1.0]), "nle.bracket: lower"),
    "external unknown key": (_set(["external", "box_factr"], 3.0), "external: unknown key(s) box_factr"),
    "external wrong type": (_set(["external", "lsm_starts"], "eight"),
                            "external.lsm_starts: 'eight' is not of type 'integer'"),
    "external bad start": (_set(["external", "sources", "x"], {"path": "a.csv", "start": "virgin"}),
                           "external.sources.x.start"),
}


@pytest.mark.parametrize("case", sorted(BAD_CONFIG))
def test_fit_bad_config(case, tmp_path, capsys):
    mutate, expect = BAD_CONFIG[case]
    cfg = _cfg(tmp_path, mutate)
    p = tmp_path / "loop.csv"
    p.write_text(bh_text())
    out = tmp_path / "out" / "fit.json"
    rc, err = run(["fit", p, "--method", "lsm", "--config", cfg, "--out", out], capsys)
    assert_one_line_error(rc, err, expect, "cfg.yaml")
    assert_empty(out.parent)


def test_fit_config_not_yaml_or_missing(tmp_path, capsys):
    p = tmp_path / "loop.csv"
    p.write_text(bh_text())
    bad = tmp_path / "bad.yaml"
    bad.write_text("ja: [unclosed\n")
    out = tmp_path / "out" / "fit.json"
    rc, err = run(["fit", p, "--method", "lsm", "--config", bad, "--out", out], capsys)
    assert_one_line_error(rc, err, "bad.yaml: not valid YAML (line")
    rc, err = run(["fit", p, "--method", "lsm", "--config", tmp_path / "none.yaml", "--out", out], capsys)
    assert_one_line_error(rc, err, "none.yaml: file not found")
    assert_empty(out.parent)


def test_fit_with_the_project_config_works(tmp_path, capsys):
    p = tmp_path / "loop.csv"
    I = ja.paper_current_path()
    B, _ = ja.simulate(P1, I, 3000.0, form="physical", substeps=8)
    p.write_text("H_A_per_m,B_T\n" + "".join(f"{float(3000 * i)!r},{float(b)!r}\n" for i, b in zip(I, B)))
    out = tmp_path / "fit.json"
    rc, err = run(["fit", p, "--method", "lsm", "--config", ROOT / "config.yaml", "--start", "demagnetised",
                   "--out", out], capsys)
    assert rc == 0, err
    assert json.loads(out.read_text())["rms_T"] < 1e-3


def test_a_pso_flag_given_to_a_least_squares_fit_is_said_and_its_warnings_reach_stdout(tmp_path, capsys):
    """--seed with --method lsm was dropped without a word (the JSON recorded seed: null); now a note on stderr. A
    fit's warnings (here c at its box edge: the truth has c = 0, the lower end of its box) were in the JSON only;
    the summary prints each on its own line."""
    p = tmp_path / "loop.csv"
    I = ja.paper_current_path()
    B, _ = ja.simulate(P1 * [1, 1, 1, 0, 1], I, 3000.0, form="physical", substeps=8)  # c = 0: the box edge
    p.write_text("H_A_per_m,B_T\n" + "".join(f"{float(3000 * i)!r},{float(b)!r}\n" for i, b in zip(I, B)))
    out = tmp_path / "fit.json"
    rc = cli.main([str(a) for a in ["fit", p, "--method", "lsm", "--seed", 3, "--out", out]])
    cap = capsys.readouterr()
    assert rc == 0 and "--seed is for --method pso" in cap.err and cap.err.count("\n") == 1
    d = json.loads(out.read_text())
    assert d["seed"] is None and d["warnings"]
    for w in d["warnings"]:
        assert f"  warning: {w}" in cap.out.splitlines()
    rc = cli.main([str(a) for a in ["fit", p, "--method", "lsm", "--out", out]])
    assert rc == 0 and capsys.readouterr().err == ""


# --------------------------------------------------------------------------------------------------
# not errors: other sweeps than the paper's 0 -> max -> 0
# --------------------------------------------------------------------------------------------------
def bipolar_current(i_max=2.0, cycles=2, n_quarter=20):
    """0 -> +i_max -> -i_max -> +i_max ... (cycles full cycles), then back to 0: piecewise linear."""
    q = np.linspace(0, i_max, n_quarter + 1)
    parts = [q]
    for _ in range(cycles):
        parts += [np.linspace(i_max, -i_max, 2 * n_quarter + 1)[1:], np.linspace(-i_max, i_max, 2 * n_quarter + 1)[1:]]
    parts.append(q[::-1][1:])
    return np.concatenate(parts)


def write_sweep(folder: Path, I, sigma=1.5e-4, seed=0, name="sweep"):
    B, ok = ja.simulate(P1, I, 3000.0, form="physical", substeps=4)
    assert ok
    rng = np.random.default_rng(seed)
    V = 1.65 + 5.0 * (B + sigma * rng.standard_normal(B.size))
    csv = folder / f"{name}.csv"
    io.write_raw(csv, np.arange(I.size), 0.1 * np.arange(1, I.size + 1), I, {"hall1": V}, SIDE)
    return csv, B


def test_bipolar_two_cycle_sweep_converts_and_fits(tmp_path, capsys):
    I = bipolar_current(cycles=2)
    csv, B = write_sweep(tmp_path, I)
    loop = tmp_path / "loop.csv"
    rc, err = run(["convert", csv, "--sensor", "hall1", "--out", loop], capsys)
    assert rc == 0, err
    lp = io.read_loop(loop)
    assert lp.B_T.size == I.size and lp.current_A.min() == -2.0
    # branch follows every reversal: 0->2 up, 2->-2 down, -2->2 up, ... , 2->0 down
    changes = np.count_nonzero(lp.branch[1:] != lp.branch[:-1])
    assert changes == 5
    fit = tmp_path / "fit.json"
    rc, err = run(["fit", loop, "--method", "lsm", "--out", fit], capsys)
    assert rc == 0, err
    res = json.loads(fit.read_text())
    assert res["start"] == "demagnetised" and res["n_samples"] == I.size
    assert res["rms_T"] < 3 * 1.5e-4  # at the noise, across both cycles
    for n, v in zip(ja.PARAM_NAMES, P1):
        if n in ("Ms", "c", "k"):
            assert res["params"][n] == pytest.approx(v, rel=0.1)


def test_bipolar_b_h_file_fits_with_cyclic_start(tmp_path, capsys):
    """A closed bipolar loop given as a B(H) file (no current column) fits in the cyclic steady state."""
    I = np.concatenate([np.linspace(2, -2, 41), np.linspace(-2, 2, 41)[1:]])
    H = 3000.0 * I
    B, ok = ja.simulate_h(P1, np.tile(H, 4), form="physical", substeps=8)
    p = tmp_path / "bh.csv"
    p.write_text("H,B\n" + "".join(f"{float(h)!r},{float(b)!r}\n" for h, b in zip(H, B[-H.size:])))
    out = tmp_path / "fit.json"
    rc, err = run(["fit", p, "--method", "lsm", "--start", "cyclic", "--out", out], capsys)
    assert rc == 0, err
    assert json.loads(out.read_text())["rms_T"] < 2e-3


# --------------------------------------------------------------------------------------------------
# large files
# --------------------------------------------------------------------------------------------------
def test_large_sweep_1e5_rows_converts_and_fits(tmp_path, capsys):
    """10^5 rows go through convert, and 10^4 of them through an LSM fit (no timing here: speed is for bench/)."""
    n = 100_000
    t = np.linspace(0.0, 5.0, n)
    I = np.round(2.0 * np.sin(2 * np.pi * t) * np.minimum(1.0, 4.0 * t), 6)  # 5 bipolar cycles, 10^5 rows
    csv, _ = write_sweep(tmp_path, I, name="big")
    loop = tmp_path / "loop.csv"
    rc, err = run(["convert", csv, "--sensor", "hall1", "--out", loop], capsys)
    assert rc == 0, err
    assert io.read_loop(loop).B_T.size == n
    # fit: LSM on every 10th sample (10^4 rows)
    dec = tmp_path / "loop10.csv"
    lines = loop.read_text().splitlines()
    dec.write_text("\n".join([lines[0]] + lines[1::10]) + "\n")
    fit = tmp_path / "fit.json"
    rc, err = run(["fit", dec, "--method", "lsm", "--out", fit], capsys)
    assert rc == 0, err
    assert json.loads(fit.read_text())["rms_T"] < 3e-4


def test_keyboard_interrupt_leaves_nothing(tmp_path, capsys, monkeypatch):
    p = tmp_path / "loop.csv"
    p.write_text(bh_text())
    out = tmp_path / "out" / "fit.json"
    from mrhyst.fit import identify

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(identify, "fit_file", interrupted)
    rc, err = run(["fit", p, "--method", "lsm", "--out", out], capsys)
    assert rc == 130 and err.count("\n") == 1 and "no output written" in err
    assert_empty(out.parent)
    shutil.rmtree(tmp_path / "out", ignore_errors=True)


def test_fit_joint_weight_own_is_least_squares_only(tmp_path, capsys):
    ferrite = Path(__file__).resolve().parent.parent / "data/external/mnzn-ferrite-jamodel/loops.csv"
    out = tmp_path / "out" / "fit.json"
    rc, err = run(["fit", ferrite, "--loop-index", "all", "--method", "pso", "--joint-weight", "own",
                   "--out", out], capsys)
    assert_one_line_error(rc, err, "joint weight 'own' is a least-squares fit (--method lsm)")
    assert_empty(out.parent)


def test_a_path_with_no_file_name_is_one_line(tmp_path, capsys):
    """'.' or '/' as the raw sweep: one line (it has no sidecar name to derive), not a traceback."""
    for p in (".", "/"):
        for argv in (["convert", p, "--sensor", "hall1", "--out", tmp_path / "x.csv"],
                     ["diagnose", p, "--sensor", "hall1", "--out", tmp_path / "x.json"]):
            rc, err = run(argv, capsys)
            assert_one_line_error(rc, err, "not a file (expected a raw sweep's CSV)")
    assert_empty(tmp_path)


def test_a_sidecar_number_no_float_holds_is_one_line(tmp_path, capsys):
    csv, _ = write_sweep(tmp_path, np.linspace(0, 2, 12))
    side = io.sidecar_path(csv)
    side.write_text(side.read_text().replace('"coil_turns_per_m": 3000.0', '"coil_turns_per_m": 1' + "0" * 400))
    rc, err = run(["convert", csv, "--sensor", "hall1", "--out", tmp_path / "out" / "x.csv"], capsys)
    assert_one_line_error(rc, err, "sweep.json: the number 100000000000... (401 digits)")
    assert_empty(tmp_path / "out")


def _rig_fit(tmp_path, capsys):
    """A raw sweep and the fit of its loop (the reference a lab holds)."""
    csv, _ = write_sweep(tmp_path, np.concatenate([np.linspace(0, 2, 14), np.linspace(2, 0, 14)[1:]]))
    loop, fit = tmp_path / "loop.csv", tmp_path / "fit.json"
    assert run(["convert", csv, "--sensor", "hall1", "--out", loop], capsys)[0] == 0
    assert run(["fit", loop, "--method", "lsm", "--out", fit, "--quiet"], capsys)[0] == 0
    return csv, fit


@pytest.mark.parametrize("field,value,expect", [
    ("rms_T", "0.5 mT", "rms_T: expected the fit's RMS misfit in tesla"),
    ("rms_T", 1e300, "a number above 0 and below 10, got 1e+300"),
    ("rms_T", -1.0, "got -1.0"),
    ("Ms", "345800.67", "params: parameter Ms must be a number, got '345800.67'"),
    ("form", None, "missing key 'form' (paper or physical"),  # was read as physical: none -> unexplained
    ("rms_T", None, "missing key 'rms_T' (the fit's own RMS misfit"),  # was a floor at the noise: the same
])
def test_a_reference_with_a_bad_number_is_one_line(field, value, expect, tmp_path, capsys):
    """A fit file edited by hand: a number written as text, or an RMS no B loop has, is refused as `mrhyst
    simulate --params` refuses it (before: a traceback, or a string read as a number); so is one without its form or
    its RMS (before: a default, which turned the verdict on the sweep the fit came from)."""
    csv, fit = _rig_fit(tmp_path, capsys)
    d = json.loads(fit.read_text())
    if value is None:  # the key deleted
        del d[field]
    else:
        (d["params"] if field in ja.PARAM_NAMES else d)[field] = value
    fit.write_text(json.dumps(d))
    out = tmp_path / "out" / "d.json"
    rc, err = run(["diagnose", csv, "--sensor", "hall1", "--reference", fit, "--out", out], capsys)
    assert_one_line_error(rc, err, expect)
    assert_empty(out.parent)


def test_outputs_never_overwrite_an_input_or_each_other(tmp_path, capsys):
    """--figure onto the sidecar, the reference or --out, and fit's model curves (OUT.curve.csv) onto its input:
    refused before any work, every file as it was."""
    csv, fit = _rig_fit(tmp_path, capsys)
    side = io.sidecar_path(csv)
    before = {p: p.read_bytes() for p in (csv, side, fit)}
    out = tmp_path / "out" / "d.json"
    png = tmp_path / "sweep.png"  # a PNG the command reads? the CSV named .png: --figure onto it is the input
    png.write_bytes(csv.read_bytes())
    png.with_suffix(".json").write_bytes(side.read_bytes())
    for fig, expect in ((side, "--figure writes a PNG"), (fit, "--figure writes a PNG"),
                        (out.with_suffix(".png"), "--figure is also --out")):
        o = out.with_suffix(".png") if fig.suffix == ".png" else out
        rc, err = run(["diagnose", csv, "--sensor", "hall1", "--reference", fit, "--out", o, "--figure", fig], capsys)
        assert_one_line_error(rc, err, expect)
    rc, err = run(["diagnose", png, "--sensor", "hall1", "--out", out, "--figure", png], capsys)
    assert_one_line_error(rc, err, "--figure is the input file sweep.png")
    loop = tmp_path / "run7.curve.csv"
    loop.write_text((tmp_path / "loop.csv").read_text())
    rc, err = run(["fit", loop, "--method", "lsm", "--out", tmp_path / "run7.json"], capsys)
    assert_one_line_error(rc, err, "the model curves beside --out is the input file run7.curve.csv")
    assert {p: p.read_bytes() for p in before} == before and loop.read_text() == (tmp_path / "loop.csv").read_text()
    assert_empty(tmp_path / "out")


def test_a_declared_preconditioning_is_bounded(tmp_path, capsys):
    """A peak in mA written in the A field is refused in one line (it would run 10^5 steps a cycle); 1000 declared
    cycles run 5 (a J-A core's cyclic state is reached within them), and the verdict says so."""
    csv, _ = write_sweep(tmp_path, np.concatenate([np.linspace(0, 2, 14), np.linspace(2, 0, 14)[1:]]))
    side = io.sidecar_path(csv)
    base = json.loads(side.read_text())
    out = tmp_path / "out" / "d.json"
    side.write_text(json.dumps(dict(base, start_state="cycled",
                                    preconditioning={"cycles": 2, "i_peak_A": 2000, "bipolar": True})))
    rc, err = run(["diagnose", csv, "--sensor", "hall1", "--out", out], capsys)
    assert_one_line_error(rc, err, "i_peak_A 2000 A is more than 10x the sweep's largest current (2 A)")
    assert_empty(out.parent)
    side.write_text(json.dumps(dict(base, preconditioning={"cycles": 1000, "i_peak_A": 2.0, "bipolar": True})))
    assert run(["diagnose", csv, "--sensor", "hall1", "--out", out, "--quiet"], capsys)[0] == 0
    st = json.loads(out.read_text())["start_state"]
    assert st["preconditioning"]["cycles"] == 1000 and "5 of the 1000 cycles are run" in st["note"]


def test_small_mistakes_are_one_line(tmp_path, capsys):
    """A figure named .svg (the bytes are PNG), a sidecar key given twice (json keeps the last silently), a folder
    as the input file, and simulate --i-max 0: each one line, nothing written."""
    csv, _ = write_sweep(tmp_path, np.linspace(0, 2, 12))
    out = tmp_path / "out"
    rc, err = run(["diagnose", csv, "--sensor", "hall1", "--out", out / "d.json", "--figure", out / "d.svg"], capsys)
    assert_one_line_error(rc, err, "--figure writes a PNG; give a path ending in .png")
    side = io.sidecar_path(csv)
    good = side.read_text()
    side.write_text(good.replace('"supply_V": 3.3', '"supply_V": 3300'))  # mV: every output bound 1000x too wide
    rc, err = run(["convert", csv, "--sensor", "hall1", "--out", out / "l.csv"], capsys)
    assert_one_line_error(rc, err, "supply_V: 3300 is greater than the maximum of 60")
    side.write_text(good.replace('"dwell_s": 0.1', '"dwell_s": 0.1, "dwell_s": 0.2'))
    rc, err = run(["convert", csv, "--sensor", "hall1", "--out", out / "l.csv"], capsys)
    assert_one_line_error(rc, err, "sweep.json: key 'dwell_s' is given twice")
    rc, err = run(["fit", tmp_path, "--method", "lsm", "--out", out / "f.json"], capsys)
    assert_one_line_error(rc, err, "is a folder; expected a CSV file")
    rc, err = run(["simulate", "--i-max", "0", "--Ms", "1e6", "--a", "3e4", "--alpha", "1e-4", "--c", "0.4", "--k",
                   "6e3", "--n-over-le", "3000", "--out", out / "s.csv"], capsys)
    assert_one_line_error(rc, err, "--i-max must be > 0 A")
    assert_empty(out)


def _cycled(tmp_path, **pre):
    csv, _ = write_sweep(tmp_path, np.concatenate([np.linspace(0, 2, 14), np.linspace(2, 0, 14)[1:]]))
    side = io.sidecar_path(csv)
    base = json.loads(side.read_text())
    side.write_text(json.dumps(dict(base, start_state="cycled",
                                    preconditioning=dict({"cycles": 2, "i_peak_A": 2.0, "bipolar": True}, **pre)))
                    .replace('"NaN"', "NaN"))
    return csv


@pytest.mark.parametrize("pre,expect", [
    ({"i_peak_A": "NaN"}, "i_peak_A nan A is more than 10x"),  # JSON's NaN literal (json reads it)
    ({"cycles": 2.5}, "preconditioning: cycles must be a whole number, got 2.5"),
    ({"bipolar": "true"}, "preconditioning: bipolar must be true or false, got 'true'"),
    ({"cycles": 10**7}, "cycles: 10000000 is greater than the maximum of 1000000"),
])
def test_a_bad_preconditioning_is_one_line(pre, expect, tmp_path, capsys):
    csv = _cycled(tmp_path, **pre)
    rc, err = run(["diagnose", csv, "--sensor", "hall1", "--out", tmp_path / "out" / "d.json"], capsys)
    assert_one_line_error(rc, err, expect)
    assert_empty(tmp_path / "out")


def test_a_far_preconditioning_runs_in_bounded_steps_and_says_what_sets_the_start(tmp_path, capsys):
    """20 A on a 0.005 A step was 4000 steps a leg (7 minutes, 5.6 GB): each leg is at most LEG_STEPS; a cycled raw
    sweep's skipped remanent_start names the declared history (it read "third-party B(H) loop")."""
    from mrhyst.diagnose import startstate

    path = startstate.conditioning_path({"cycles": 5, "i_peak_A": 20.0, "bipolar": True}, 0.005, 0.0)
    assert path.size <= 5 * 3 * startstate.LEG_STEPS + 1 and path.max() == 20.0 and path.min() == -20.0
    csv = _cycled(tmp_path)
    out = tmp_path / "d.json"
    assert run(["diagnose", csv, "--sensor", "hall1", "--out", out, "--quiet"], capsys)[0] == 0
    why = json.loads(out.read_text())["skipped"]["remanent_start"]
    assert "a preconditioning the sidecar declares" in why and why.startswith("the sweep's history sets")


def test_more_one_liners_from_a_second_pass(tmp_path, capsys):
    """A coil that underflows H (5e-324: a ZeroDivisionError), a reference's unknown start (read as a cyclic one:
    the verdict changed), a quoted header (its long row was named by pandas' count), a loop file without current_A
    (read as a B(H) loop)."""
    csv, _ = write_sweep(tmp_path, np.concatenate([np.linspace(0, 2, 14), np.linspace(2, 0, 14)[1:]]))
    side = io.sidecar_path(csv)
    good = side.read_text()
    side.write_text(good.replace('"coil_turns_per_m": 3000.0', '"coil_turns_per_m": 5e-324'))
    out = tmp_path / "out"
    rc, err = run(["convert", csv, "--sensor", "hall1", "--out", out / "l.csv"], capsys)
    assert_one_line_error(rc, err, "above any material's")
    side.write_text(good)
    csv2, fit = _rig_fit(tmp_path / "r", capsys)
    d = json.loads(fit.read_text())
    fit.write_text(json.dumps(dict(d, start="bogus")))
    rc, err = run(["diagnose", csv2, "--sensor", "hall1", "--reference", fit, "--out", out / "d.json"], capsys)
    assert_one_line_error(rc, err, "start must be one of auto, cyclic, fit, first_sample, demagnetised")
    lines = csv.read_text().splitlines()
    q = ['# logger', '', '"' + '","'.join(lines[0].split(",")) + '"'] + lines[1:5] + [lines[5] + ",9"] + lines[6:]
    qcsv = tmp_path / "q.csv"
    qcsv.write_text("\n".join(q) + "\n")
    io.sidecar_path(qcsv).write_text(good)
    rc, err = run(["convert", qcsv, "--sensor", "hall1", "--out", out / "q.csv"], capsys)
    assert_one_line_error(rc, err, "row 8: ", "more fields than the header")
    loop = tmp_path / "L.csv"
    assert run(["convert", csv, "--sensor", "hall1", "--out", loop], capsys)[0] == 0
    rows = [r.split(",") for r in loop.read_text().splitlines()]
    k = rows[0].index("current_A")
    (tmp_path / "L2.csv").write_text("\n".join(",".join(c for j, c in enumerate(r) if j != k) for r in rows) + "\n")
    rc, err = run(["fit", tmp_path / "L2.csv", "--method", "lsm", "--out", out / "f.json"], capsys)
    assert_one_line_error(rc, err, "has step, branch but no current_A column")
    assert_empty(out)


def test_a_hand_edited_temperature_law_is_one_line():
    """Laws read back from a fit file: numbers as strings, anchors that do not match the degree, a degree of 10^8,
    a negative Ms0 are refused (they were a traceback, a 44 s run, or read as numbers)."""
    from mrhyst.data.errors import InputError
    from mrhyst.materials.templaws import Laws

    lw = Laws({"a": 2, "k": 1, "c": 0, "alpha": 0}, (-38.0, 10.0))
    good = lw.to_json(np.r_[2.5e6, 293.0, 0.4, np.ones(len(lw.names) - 3)])
    Laws.from_json(json.loads(json.dumps(good)))
    for edit, expect in ((lambda d: d["a"]["values"].__setitem__(0, "1.0"), r"a.values must be 3 number\(s\)"),
                         (lambda d: d["a"].__setitem__("anchors_C", [-38.0, -14.0]), "a.anchors_C must be 3"),
                         (lambda d: d["a"].__setitem__("degree", 10**8), "a.degree must be a whole number 0-10"),
                         (lambda d: d["Ms"].__setitem__("Ms0", -2.5e6), "Ms0, Tc_K and beta must be > 0")):
        d = json.loads(json.dumps(good))
        edit(d)
        with pytest.raises(InputError, match=expect):
            Laws.from_json(d)
