"""Hall chain (B = (V - Vq)/S), the contract files, and every bad input of issue 2 (one line, exit != 0, no output)."""

import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst import cli
from mrhyst.data import io
from mrhyst.model import hall

SIDE = {"supply_V": 3.3, "coil_turns_per_m": 3000.0, "dwell_s": 2.0,
        "sensors": {"hall1": {"sensitivity_V_per_T": 5.0, "quiescent_V": 1.65,
                              "output_min_V": 0.2, "output_max_V": 3.1}}}
HEADER = "step,time_s,current_A,hall1_V\n"


def rows(n=8):
    I = np.concatenate([np.linspace(0, 2, n // 2 + 1), np.linspace(2, 0, n // 2 + 1)[1:]])
    B = 0.04 * I
    V = 1.65 + 5.0 * B
    return "".join(f"{j},{2.0 * (j + 1)},{i:.6f},{v:.6f}\n" for j, (i, v) in enumerate(zip(I, V)))


def write_case(tmp_path, body, side=SIDE, name="sweep"):
    csv = tmp_path / f"{name}.csv"
    if isinstance(body, bytes):
        csv.write_bytes(body)
    else:
        csv.write_text(body)
    if side is not None:
        (tmp_path / f"{name}.json").write_text(side if isinstance(side, str) else json.dumps(side))
    return csv


@settings(max_examples=50, deadline=None)
@given(st.floats(-0.3, 0.3), st.floats(0.5, 50.0), st.floats(0.5, 3.0))
def test_hall_round_trip(B, S, Vq):
    V = hall.tesla_to_volts(B, S, Vq)
    assert hall.volts_to_tesla(V, S, Vq) == pytest.approx(B, abs=1e-12)


def test_a1304_defaults_and_ratiometric_quiescent():
    assert hall.A1304_SENSITIVITY_V_PER_T == 5.0  # 0.5 mV/G
    assert hall.quiescent_voltage(3.3) == pytest.approx(1.65)
    assert hall.quiescent_voltage(5.0) == pytest.approx(2.5)
    assert hall.quiescent_voltage(3.3, 1.6) == 1.6
    assert hall.volts_to_tesla(1.65 + 0.45, 5.0, 1.65) == pytest.approx(0.09)


def test_convert_good_sweep_marks_branches_and_saturation(tmp_path):
    body = rows(8)
    lines = body.splitlines()
    lines[4] = "4,10.0,2.000000,3.100000"  # at the sensor's upper output limit
    csv = write_case(tmp_path, HEADER + "\n".join(lines) + "\n")
    out = tmp_path / "loop.csv"
    assert cli.main(["convert", str(csv), "--sensor", "hall1", "--out", str(out)]) == 0
    loop = io.read_loop(out)
    assert loop.kind == "loop"
    assert loop.branch.tolist() == ["up"] * 5 + ["down"] * 4
    assert loop.saturated.tolist() == [False] * 4 + [True] + [False] * 4
    assert loop.B_T[1] == pytest.approx(0.04 * 0.5, abs=1e-6)
    assert np.allclose(loop.H_A_per_m, 3000.0 * loop.current_A)


def test_quiescent_defaults_to_half_supply(tmp_path):
    side = json.loads(json.dumps(SIDE))
    del side["sensors"]["hall1"]["quiescent_V"]
    side["supply_V"] = 5.0
    csv = write_case(tmp_path, HEADER + "0,1,0,2.5\n1,2,1,2.6\n2,3,2,2.7\n3,4,1,2.65\n4,5,0,2.55\n", side)
    raw = io.read_raw(csv)
    loop = io.raw_to_loop(raw, "hall1")
    assert loop.B_T.iloc[0] == pytest.approx(0.0)
    assert loop.B_T.iloc[2] == pytest.approx(0.04)


def test_branches_follow_any_piecewise_monotone_path():
    I = [0, 1, 2, 1, 0, -1, -2, -1, 0, 0, 1]
    assert io.branches(I).tolist() == ["up", "up", "up", "down", "down", "down", "down", "up", "up", "up", "up"]


BAD = {
    "empty file": ("", SIDE, "empty file"),
    "header only": (HEADER, SIDE, "header only"),
    "missing column": ("step,time_s,hall1_V\n" + "0,1,1.6\n" * 6, SIDE, "missing column(s) current_A"),
    "text in a number": (HEADER + rows(8).replace("0.500000", "abc", 1), SIDE, "row 3, column current_A"),
    "NaN in a number": (HEADER + rows(8).replace("1.750000", "nan", 1), SIDE, "expected a finite number"),
    "millivolts": (HEADER + rows(8).replace("1.650000", "1650.0", 1), SIDE, "looks like millivolts"),
    "sidecar missing": (HEADER + rows(8), None, "sidecar sweep.json not found"),
    "sidecar not JSON": (HEADER + rows(8), "{supply_V: 3.3", "not valid JSON"),
    "zero sensitivity": (HEADER + rows(8), {**SIDE, "sensors": {"hall1": {"sensitivity_V_per_T": 0}}},
                         "sensitivity_V_per_T must be non-zero"),
    "fewer than 5 samples": (HEADER + "0,1,0,1.65\n1,2,1,1.7\n2,3,0,1.66\n", SIDE, "at least 5 samples"),
    "duplicate steps": (HEADER + rows(8).replace("3,8.0", "2,8.0", 1), SIDE, "duplicate step 2 (one row per reading"),
    "units after the names": ("step,time_s [s],current_A [A],hall1_V [V]\n" + rows(8), SIDE,
                              "rename 'time_s [s]' to 'time_s', 'current_A [A]' to 'current_A', 'hall1_V [V]' to"),
    "another letter case": (HEADER.replace("current_A", "Current_A") + rows(8), SIDE,
                            "names are case-sensitive: rename 'Current_A' to 'current_A'"),
    "the sidecar given as the sweep": (json.dumps(SIDE), SIDE, "a JSON file, not a CSV (a raw sweep's sidecar?"),
    "unsorted steps": (HEADER + rows(8).replace("3,8.0", "1,8.0", 1), SIDE, "steps must increase"),
    "binary garbage": (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)), SIDE, "binary data"),
    "not UTF-8": (b"step,time_s,current_A,hall1_V\n0,1,0,\xff\xfe\n", SIDE, "not UTF-8"),
    "sensor not in sidecar": (HEADER + rows(8), {**SIDE, "sensors": {"hallX": {"sensitivity_V_per_T": 5.0}}},
                              "sensor 'hall1' not in 'sensors'"),
    "supply not a number": (HEADER + rows(8), {**SIDE, "supply_V": "3.3V"}, "supply_V must be a number"),
    "time goes backwards": (HEADER + rows(8).replace("3,8.0", "3,1.0", 1), SIDE, "time goes backwards"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_raw_input_one_line_nonzero_no_output(case, tmp_path, capsys):
    body, side, expect = BAD[case]
    csv = write_case(tmp_path, body, side)
    out = tmp_path / "out" / "loop.csv"
    rc = cli.main(["convert", str(csv), "--sensor", "hall1", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc != 0
    assert err.count("\n") == 1, err  # one line
    assert expect in err and "sweep" in err  # names the file and the problem
    assert "Traceback" not in err
    assert not out.exists()
    assert not out.parent.exists() or list(out.parent.iterdir()) == []  # no partial or temporary file


SIDECAR_BAD = {
    "no supply": ({k: v for k, v in SIDE.items() if k != "supply_V"}, "sweep.json: missing key 'supply_V'"),
    "no sensors": ({**SIDE, "sensors": {}}, "sweep.json: missing or empty 'sensors' object"),
    "sensor not an object": ({**SIDE, "sensors": {"hall1": 5.0}}, "sweep.json: sensors.hall1: expected an object"),
    "sensor without sensitivity": ({**SIDE, "sensors": {"hall1": {"quiescent_V": 1.65}}},
                                   "sweep.json: sensors.hall1: missing key 'sensitivity_V_per_T'"),
    "dwell zero": ({**SIDE, "dwell_s": 0}, "sweep.json: dwell_s must be > 0, got 0"),
    "NaN turns": ({**SIDE, "coil_turns_per_m": float("nan")}, "sweep.json: coil_turns_per_m must be a number, got nan"),
    "limit as text": ({**SIDE, "sensors": {"hall1": {**SIDE["sensors"]["hall1"], "output_max_V": "3.1 V"}}},
                      "sweep.json: sensors.hall1: output_max_V must be a number, got '3.1 V'"),
    "limits reversed": ({**SIDE, "sensors": {"hall1": {**SIDE["sensors"]["hall1"], "output_min_V": 3.2}}},
                        "sweep.json: sensors.hall1: output_min_V (3.2) must be below output_max_V (3.1)"),
}


@pytest.mark.parametrize("case", sorted(SIDECAR_BAD))
def test_bad_sidecar_is_one_line_naming_the_key(case, tmp_path):
    side, expect = SIDECAR_BAD[case]
    csv = write_case(tmp_path, HEADER + rows(8), side)
    with pytest.raises(io.InputError) as e:
        io.read_raw(csv)
    assert str(e.value).endswith(expect) and "\n" not in str(e.value)


def test_sidecar_schema_states_the_contract_and_refuses_unknown_keys(root, tmp_path):
    """The schema holds every contract field (ARCHITECTURE 4) plus the optional provenance and notes; the project's
    sweeps pass it; an unknown key is an error naming the closest known one (issue 25: a misspelt quiescent_v was
    ignored and Vcc/2 used); free text goes in notes."""
    import jsonschema

    schema = json.loads(io.SIDECAR_SCHEMA_PATH.read_text())
    assert set(schema["properties"]) == {"supply_V", "coil_turns_per_m", "dwell_s", "sensors", "provenance", "notes",
                                         "start_state", "preconditioning",  # issue 23: optional start state
                                         "supply_min_V"}  # optional: a bipolar supply
    assert set(schema["required"]) == {"supply_V", "coil_turns_per_m", "sensors"}
    sensor = schema["properties"]["sensors"]["additionalProperties"]["properties"]
    assert set(sensor) == {"sensitivity_V_per_T", "quiescent_V", "output_min_V", "output_max_V", "notes"}
    for side in sorted((root / "data" / "raw").glob("*.json")):
        jsonschema.validate(json.loads(side.read_text()), schema)
    csv = write_case(tmp_path, HEADER + rows(8), {**SIDE, "notes": "lab 3",
                                                  "sensors": {"hall1": {**SIDE["sensors"]["hall1"], "notes": "A1"}}})
    assert io.read_raw(csv).sensors["hall1"].sensitivity_V_per_T == 5.0
    for side, expect in [({**SIDE, "operator": "lab 3"}, "unknown key 'operator'"),
                         ({**SIDE, "supply_v": 3.3}, "unknown key 'supply_v'"),
                         ({**SIDE, "sensors": {"hall1": {"sensitivity_V_per_T": 5.0, "quiescent_v": 1.6}}},
                          "sensors.hall1: unknown key 'quiescent_v' (known: notes, output_max_V, output_min_V, "
                          "quiescent_V, sensitivity_V_per_T); did you mean 'quiescent_V'?")]:
        csv = write_case(tmp_path, HEADER + rows(8), side)
        with pytest.raises(io.InputError, match="unknown key") as e:
            io.read_raw(csv)
        assert expect in str(e.value) and "\n" not in str(e.value)


def test_bad_input_through_the_installed_console_script(tmp_path):
    csv = write_case(tmp_path, HEADER)
    out = tmp_path / "loop.csv"
    exe = [sys.executable, "-m", "mrhyst"]
    p = subprocess.run(exe + ["convert", str(csv), "--sensor", "hall1", "--out", str(out)],
                       capture_output=True, text=True)
    assert p.returncode == 2
    assert p.stderr.strip().count("\n") == 0 and "header only" in p.stderr
    assert not out.exists()


def test_simulate_cli_bad_params_and_good_run(tmp_path, capsys):
    out = tmp_path / "sim.csv"
    rc = cli.main(["simulate", "--Ms", "1.6e6", "--a", "1100", "--alpha", "0.0017", "--c", "0.26",
                   "--n-over-le", "3000", "--out", str(out)])
    assert rc == 2 and "missing k" in capsys.readouterr().err and not out.exists()
    rc = cli.main(["simulate", "--Ms", "1.6e6", "--a", "1100", "--alpha", "0.0017", "--c", "0.26", "--k", "400",
                   "--n-over-le", "-3", "--out", str(out)])
    assert rc == 2 and "n-over-le" in capsys.readouterr().err and not out.exists()
    params = tmp_path / "p.json"
    params.write_text(json.dumps({"params": {"Ms": 1.6e6, "a": 1100, "alpha": 0.0017, "c": 0.26, "k": 400}}))
    assert cli.main(["simulate", "--params", str(params), "--n-over-le", "3000", "--out", str(out)]) == 0
    loop = io.read_loop(out)
    assert loop.B_T.size == 53 and loop.B_T[0] == 0.0 and loop.B_T.max() > 1.0
    params.write_text("[1, 2]")
    out2 = tmp_path / "sim2.csv"
    assert cli.main(["simulate", "--params", str(params), "--n-over-le", "3000", "--out", str(out2)]) == 2
    assert not out2.exists()


@pytest.mark.parametrize("body,expect", [
    ("H_A_per_m,B_T\n1,2\n", "at least 5 samples"),
    ("H_A_per_m,Bx\n" + "1,0.1\n" * 6, "missing column(s) B_T"),
    ("H_A_per_m,B_T\n" + "1,100\n" * 6, "not a plausible flux density"),
    ("step,current_A,H_A_per_m,B_T,branch\n" + "".join(f"{i},0,0,0,sideways\n" for i in range(6)),
     "expected 'up' or 'down'"),
])
def test_bad_loop_files(tmp_path, body, expect):
    p = tmp_path / "loop.csv"
    p.write_text(body)
    with pytest.raises(io.InputError, match=expect.replace("(", r"\(").replace(")", r"\)")):
        io.read_loop(p)


def test_third_party_aliases_are_read(tmp_path):
    p = tmp_path / "bh.csv"
    p.write_text("H,B\n" + "".join(f"{h},{h / 1e3}\n" for h in range(6)))
    loop = io.read_loop(p)
    assert loop.kind == "bh" and loop.H_A_per_m[-1] == 5 and loop.B_T[-1] == pytest.approx(0.005)


def test_write_json_refuses_nan_and_leaves_no_file(tmp_path):
    p = tmp_path / "x.json"
    with pytest.raises(ValueError, match="non-finite"):
        io.write_json({"rms_T": float("nan")}, p)
    assert not p.exists() and list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------------------------------
# lenient third-party B(H) input (issue 17, point 5)
# --------------------------------------------------------------------------------------------------
def _bh_rows(n=40):
    H = np.concatenate([np.linspace(100, -100, n), np.linspace(-100, 100, n)])  # -100 repeated at the reversal
    B = np.tanh(H / 40.0) + np.where(np.arange(H.size) < n, 0.1, -0.1)
    return H, B


@pytest.mark.parametrize("sep,header", [(",", True), (";", True), ("\t", True), (",", False), (";", False),
                                        ("\t", False)])
def test_bh_loop_any_separator_header_optional(tmp_path, sep, header):
    H, B = _bh_rows()
    text = (f"H{sep}B\n" if header else "") + "".join(f"{h:.6g}{sep}{b:.6g}\n" for h, b in zip(H, B))
    p = tmp_path / "loop.txt"
    p.write_text(text)
    lp = io.read_loop(p)
    assert np.allclose(lp.H_A_per_m, np.round(H, 3), atol=1e-3) and lp.B_T.size == H.size


def test_repeated_sample_at_a_reversal_is_fitted(tmp_path):
    """The lowest M130-27s loop with its sample at -Hmax written twice (on which jafit fails): fitted as well
    as without it."""
    from pathlib import Path

    src = Path(__file__).resolve().parent.parent / "data" / "external" / "m130-27s-jamodel" / "loops.csv"
    lp = io.read_loop(src, 0)
    j = int(np.argmin(lp.H_A_per_m))
    H = np.insert(lp.H_A_per_m, j, lp.H_A_per_m[j])
    B = np.insert(lp.B_T, j, lp.B_T[j])
    p = tmp_path / "loop.csv"
    p.write_text("H,B\n" + "".join(f"{h!r},{b!r}\n" for h, b in zip(H.tolist(), B.tolist())))
    out = tmp_path / "fit.json"
    assert cli.main(["fit", str(p), "--method", "lsm", "--start", "cyclic", "--out", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["model_ok"] and d["per_loop"][0]["rms_rel"] < 0.01 and not d["warnings"]


@pytest.mark.parametrize("text,where", [
    ("1;2;3\n4;5;6\n7;8;9\n1;2;3\n4;5;6\n", "row 1"),               # no header and 3 columns
    ("H;B\n1.5;0,5\n2.5;0,6\n3.5;0,7\n4.5;0,8\n5.5;0,9\n", "row 2, column B_T"),  # both decimal marks
    ("1,0.5\n2,0.6\n3,x\n4,0.8\n5,0.9\n", "row 3, column B_T"),       # headerless: row 3 is the 3rd line
])
def test_unreadable_bh_is_one_line_naming_row_and_column(tmp_path, capsys, text, where):
    p = tmp_path / "loop.csv"
    p.write_text(text)
    out = tmp_path / "fit.json"
    assert cli.main(["fit", str(p), "--method", "lsm", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(p) in err[0] and where in err[0], err
    assert not out.exists()


@settings(max_examples=60, deadline=None)
@given(st.integers(10, 16), st.floats(2.6, 3.25), st.floats(0.3, 0.95), st.sampled_from([np.round, np.floor]),
       st.integers(0, 10_000))
def test_a_sample_stuck_at_a_declared_rail_is_flagged_however_the_adc_reads_the_rail(bits, rail, frac, adc, seed):
    """A lab declares its sensor's rail and reads the output through an ADC (rounding or truncating): a sample
    stuck at the rail reads as the code nearest to it, which may lie below the declared value. Every sample the
    rail clipped is flagged, and no sample two codes or more below the rail's code."""
    rng = np.random.default_rng(seed)
    lsb = 3.3 / 2 ** bits
    # a loop whose top goes past the rail by a fraction of its swing above the quiescent output
    true = 1.65 + (rail - 1.65) * (1 + frac) * np.sin(np.linspace(0, np.pi, 60)) + 1e-3 * rng.standard_normal(60)
    V = adc(np.minimum(true, rail) / lsb) * lsb
    flags = hall.saturated_mask(V, None, rail)
    assert flags[true >= rail].all()
    rail_code = adc(rail / lsb) * lsb
    assert not flags[V <= rail_code - 1.5 * lsb].any()


def test_a_row_of_separators_only_is_a_blank_line(tmp_path):
    """A spreadsheet's export ends in rows of bare separators (",,,"): blank lines, the same loop as without."""
    clean = io.raw_to_loop(io.read_raw(write_case(tmp_path, HEADER + rows(8), name="a")), "hall1")
    body = HEADER + rows(8).replace("\n3,", "\n,,,\n3,", 1) + ",,,\n;,\t\n"
    padded = io.raw_to_loop(io.read_raw(write_case(tmp_path, body, name="b")), "hall1")
    assert padded.B_T.tolist() == clean.B_T.tolist() and padded.step.tolist() == clean.step.tolist()
