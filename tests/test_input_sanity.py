"""Bad input, second round (issue 25): no data loss, no special file replaced, no silent nonsense.

Every case is run through the CLI (``cli.main(argv)`` in-process): a refusal is exit 2 with ONE line on stderr
naming the file (and row/column where there is one) and what was expected, no output file, the inputs
untouched; an accepted habit (BOM, ``#`` comments, an extra logged column, decimal commas) gives the same
numbers as the clean file. The clean sweep is a J-A loop (Table 1 group 1) through an ideal A1304 chain.
"""

import json
import os
from pathlib import Path

import numpy as np
import pytest
from mrhyst import cli
from mrhyst.data import io
from mrhyst.model import ja

P1 = np.array([1.2456e6, 2.6882e4, 1.4697e-4, 0.5385, 5.6943e3])  # Table 1, group 1, PSO
SIDE = {"supply_V": 3.3, "coil_turns_per_m": 3000.0, "dwell_s": 0.1,
        "sensors": {"hall1": {"sensitivity_V_per_T": 5.0, "quiescent_V": 1.65,
                              "output_min_V": 0.2, "output_max_V": 3.1}}}
I = np.round(np.concatenate([np.linspace(0, 2, 28), np.linspace(2, 0, 28)[1:]]), 6)
B_TRUE, _ok = ja.simulate(P1, I, 3000.0, form="physical", substeps=4)
V = np.round(1.65 + 5.0 * (B_TRUE + 1.5e-4 * np.random.default_rng(0).standard_normal(I.size)), 6)
T = np.round(0.1 * np.arange(1, I.size + 1), 6)
H = 3000.0 * I


def sweep_text(sep=",", extra=None, volts=V, current=I):
    """The raw sweep CSV; ``extra``: (column name, value of row j) of one more logged column."""
    head = ["step", "time_s", "current_A", "hall1_V"] + ([extra[0]] if extra else [])
    rows = [sep.join(head)]
    for j in range(current.size):
        f = [str(j), repr(float(T[j])), repr(float(current[j])), repr(float(volts[j]))]
        rows.append(sep.join(f + ([extra[1](j)] if extra else [])))
    return "\n".join(rows) + "\n"


def bh_text(h=H, b=B_TRUE, header="H_A_per_m,B_T", sep=","):
    return (header + "\n" if header else "") + "".join(f"{float(x)!r}{sep}{float(y)!r}\n" for x, y in zip(h, b))


def write_sweep(folder: Path, text=None, side=SIDE, side_text=None, name="RAW"):
    csv = folder / f"{name}.csv"
    csv.write_text(text if text is not None else sweep_text())
    (folder / f"{name}.json").write_text(side_text if side_text is not None else json.dumps(side))
    return csv


def snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file() and not p.is_symlink()}


def refused(argv, folder: Path, capsys, *expect, out=None):
    """Run; assert exit 2, one stderr line holding every ``expect``, no new file, every input byte-identical."""
    before = snapshot(folder)
    rc = cli.main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.count("\n") == 1 and err.endswith("\n") and "Traceback" not in err, err
    for e in expect:
        assert e in err, err
    assert snapshot(folder) == before  # no output, no temporary file, inputs untouched
    if out is not None:
        assert not Path(out).exists() or Path(out).is_symlink() or not Path(out).is_file()
    return err


def accepted(argv, capsys):
    rc = cli.main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert rc == 0, err
    return err


def side_with(**sensor):
    s = json.loads(json.dumps(SIDE))
    s["sensors"]["hall1"].update(sensor)
    return s


# --------------------------------------------------------------------------------------------------
# outputs: never an input, never a special file
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("cmd", ["convert", "diagnose"])
def test_out_is_the_sweeps_own_sidecar(cmd, tmp_path, capsys):
    """Measured: `--out RAW.json` overwrote the sensor calibration with exit 0."""
    csv = write_sweep(tmp_path)
    refused([cmd, csv, "--sensor", "hall1", "--out", tmp_path / "RAW.json"], tmp_path, capsys,
            "RAW.json: --out is the input file RAW.json")


def test_out_is_the_config(tmp_path, capsys, root):
    (tmp_path / "L.csv").write_text(bh_text())
    cfg = tmp_path / "config.yaml"
    cfg.write_bytes((root / "config.yaml").read_bytes())
    refused(["fit", tmp_path / "L.csv", "--method", "lsm", "--config", cfg, "--out", cfg], tmp_path, capsys,
            "--out is the input file config.yaml")


def test_out_hard_link_to_the_input_is_the_input(tmp_path, capsys):
    (tmp_path / "L.csv").write_text(bh_text())
    os.link(tmp_path / "L.csv", tmp_path / "also.csv")
    refused(["fit", tmp_path / "L.csv", "--method", "lsm", "--out", tmp_path / "also.csv"], tmp_path, capsys,
            "--out is the input file")


def test_out_fifo_is_refused(tmp_path, capsys):
    (tmp_path / "L.csv").write_text(bh_text())
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    refused(["fit", tmp_path / "L.csv", "--method", "lsm", "--out", fifo], tmp_path, capsys,
            "fifo: not a regular file")
    assert fifo.exists() and not fifo.is_file()


def test_out_link_to_dev_null_is_refused(tmp_path, capsys):
    """A link to /dev/null (the rename would replace the link only, so this test is safe to fail)."""
    (tmp_path / "L.csv").write_text(bh_text())
    link = tmp_path / "null"
    link.symlink_to("/dev/null")
    refused(["fit", tmp_path / "L.csv", "--method", "lsm", "--out", link], tmp_path, capsys, "not a regular file")
    assert link.is_symlink() and os.readlink(link) == "/dev/null"


def test_out_dev_null_is_refused_before_any_write(tmp_path, capsys, monkeypatch):
    """/dev/null itself: the refusal comes before any work; any rename or temporary file would fail the test
    (they are replaced by traps, so /dev/null is never touched even if the check were gone)."""
    (tmp_path / "L.csv").write_text(bh_text())

    def trap(*a, **k):
        raise AssertionError(f"a write was attempted: {a}")

    monkeypatch.setattr(io.os, "replace", trap)
    monkeypatch.setattr(io.tempfile, "mkstemp", trap)
    monkeypatch.setattr(cli.tempfile, "mkstemp", trap)
    refused(["fit", tmp_path / "L.csv", "--method", "lsm", "--out", "/dev/null"], tmp_path, capsys,
            "/dev/null: not a regular file")
    assert not Path("/dev/null").is_file()


def test_atomic_writer_never_renames_onto_a_special_file(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(io.InputError, match="not a regular file"):
        io.write_json({"a": 1}, fifo)
    assert not fifo.is_file() and [p.name for p in tmp_path.iterdir()] == ["fifo"]
