"""A B(H) record that does not return to its first state (a virgin curve first, as the gadolinium and Hiperco 50
records, or a converted 0 -> max -> 0 sweep) is simulated once from its first sample's state: conditioning it would
invent a jump from its end back to its start. A closed loop (back at its first sample: in cyclic steady state) is
conditioned as before. Measured on the rig's own sweep: J-A follows the converted loop as well as the raw sweep."""

import sys

import numpy as np
import pytest
from mrhyst import diagnose as dg
from mrhyst.data import io
from mrhyst.diagnose.sweep import bh_closure, sweep_from_bh

sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from bh_loops import write_ja_loop  # noqa: E402

ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent


def test_closure_tells_a_loop_from_a_record_that_starts_with_a_virgin_curve():
    q = np.linspace(0.0, 1.0, 11)
    loop_H = np.concatenate([1 - 2 * q, 2 * q[1:] - 1])  # +1 -> -1 -> +1, a loop from its tip
    down = np.concatenate([np.ones(11), -np.ones(10)])  # +1 on the falling branch, -1 on the rising one
    B = np.tanh(3 * loop_H) + 0.2 * down * (1 - loop_H**2)  # the branches apart, met at the tips
    assert bh_closure(loop_H, B, 0.05)["closed"]
    virgin = np.concatenate([q, 1 - q[1:]])
    assert not bh_closure(virgin, np.concatenate([q, 0.3 + 0.7 * (1 - q[1:])]), 0.05)["closed"]  # ends at remanence
    assert not bh_closure(q[:-1].tolist() + [1.0], q.tolist(), 0.05)["closed"]  # ends at +max, starts at 0


@pytest.mark.parametrize("first,closed", [(0, False), (15, True)])
def test_an_open_record_runs_once_from_its_first_state(tmp_path, first, closed):
    """From 0 A/m (a virgin curve first, then +400 -> -400 -> +400): open, run once; from the first tip: a closed
    loop, conditioned (config diagnose.bh.conditioning_passes, 1)."""
    f = tmp_path / "virgin.csv"
    H = write_ja_loop(f, seed=1)[first:]  # 0 -> +400 -> -400 -> +400 A/m from the demagnetised state
    B = np.loadtxt(f, delimiter=",", skiprows=1)[first:, 1]
    f.write_text("H_A_per_m,B_T\n" + "".join(f"{float(h)!r},{float(b)!r}\n" for h, b in zip(H, B)))
    sw = sweep_from_bh(f, None, dg.resolve_config())
    assert sw.closure["closed"] is closed and sw.closure["conditioning_passes"] == (1 if closed else 0)
    assert sw.start == (H.size if closed else 0) and sw.current.size == H.size * (2 if closed else 1)
    assert sw.M0 == pytest.approx(B[0] / (4e-7 * np.pi) - H[0])  # the first sample's state either way


@pytest.mark.slow
def test_a_converted_sweep_diagnosed_as_a_loop_follows_the_raw_sweeps_fit(tmp_path):
    """data/raw's sweep through `convert`, then `diagnose LOOP.csv` (no Hall chain, no times): the record starts
    demagnetised at 0 A and ends at its remanence, so it is not conditioned, and plain J-A leaves about what it
    leaves on the raw sweep (conditioned, it left 10x that: J-A had to start the virgin curve from a remanence)."""
    loop = tmp_path / "loop.csv"
    raw = io.read_raw(ROOT / "data" / "raw" / "li_gong_rig.csv")
    io.write_csv(io.raw_to_loop(raw, "hall1"), loop)
    d_loop = dg.diagnose_bh_file(loop)
    d_raw = dg.diagnose_file(ROOT / "data" / "raw" / "li_gong_rig.csv", "hall1")
    assert d_loop["input"]["closure"]["closed"] is False and d_loop["input"]["conditioning_passes"] == 0
    assert d_loop["rms_before_T"] < 1.5 * d_raw["rms_before_T"]
