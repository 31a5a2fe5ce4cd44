"""The one path shape (issue 22, point 2): checked against paths generated from known turning points, and
derived once per path in a diagnosis (a counter on the one derivation)."""

from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from bh_loops import write_ja_loop
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst import diagnose as dg
from mrhyst.data import loopfigures
from mrhyst.data import shape as shp
from mrhyst.data.io import branches
from mrhyst.model import ja

ROOT = Path(__file__).resolve().parent.parent
RAW = ROOT / "data" / "raw" / "li_gong_rig.csv"


@st.composite
def programs(draw):
    """A piecewise-monotone current program from known turning points: levels v0, v1, ... alternating up and
    down, each leg of n_i > 0 strictly monotone steps, each reversal held for r_i extra samples (a dwell).
    Returns (path, expected) with the expected shape written down while building, not derived from it."""
    n_legs = draw(st.integers(1, 6))
    up = draw(st.booleans())
    v = draw(st.integers(-5, 5))
    path = [float(v)]
    exp = {"segments": [], "turns": [], "dirs": [1 if up else -1], "cycle_starts": 0}
    start = 0
    for leg in range(n_legs):
        d = 1 if up else -1
        steps = draw(st.integers(1, 6))
        for _ in range(steps):
            v += d * draw(st.integers(1, 3))
            path.append(float(v))
            exp["dirs"].append(d)
        last = leg == n_legs - 1
        hold = 0 if last else draw(st.integers(0, 2))
        path += [float(v)] * hold
        exp["dirs"] += [d] * hold
        stop = len(path) - 1
        exp["segments"].append((start, stop, d))
        if not last:
            exp["turns"].append((stop - hold, stop, d))
            exp["cycle_starts"] += d < 0  # falling, then rising: a new cycle
        start = stop
        up = not up
    return np.array(path), exp


@settings(max_examples=150, deadline=None)
@given(programs())
def test_shape_of_a_generated_program_is_the_one_generated(prog):
    path, exp = prog
    s = shp.path_shape(path)
    assert [(g.start, g.stop, g.direction) for g in s.segments] == exp["segments"]
    assert list(s.directions) == exp["dirs"]
    assert s.turns() == exp["turns"]
    assert s.reversals == len(exp["turns"])
    want_turning = np.zeros(path.size, bool)
    for first, last, _ in exp["turns"]:
        want_turning[first: last + 1] = True
    assert np.array_equal(s.turning, want_turning)
    assert s.n_cycles == 1 + exp["cycle_starts"] and s.counts() == (len(exp["turns"]), 1 + exp["cycle_starts"])
    assert s.turning_points == [0, *(t[1] for t in exp["turns"]), path.size - 1]
    assert s.first_turn() == ((exp["turns"][0][0], exp["turns"][0][1]) if exp["turns"] else (-1, -1))
    assert list(s.branches()) == ["up" if d > 0 else "down" for d in exp["dirs"]]
    # the noise floor's triples: every sample whose two neighbours lie on its own segment
    assert list(s.interior) == [j for a, b, _ in exp["segments"] for j in range(a + 1, b)]


@settings(max_examples=80, deadline=None)
@given(programs(), st.integers(1, 3))
def test_the_last_pass_of_a_repeated_program_has_the_programs_own_turns(prog, k):
    """A B(H) loop is simulated as its path run k + 1 times (sweep_from_bh): the turns counted from the
    last pass's first sample are the program's own, shifted (a junction between passes is no turn of it)."""
    path, exp = prog
    s = shp.path_shape(np.tile(path, k + 1))
    off = k * path.size
    assert [(a - off, b - off, d) for a, b, d in s.turns(off)] == exp["turns"]
    assert s.counts(off) == (len(exp["turns"]), 1 + exp["cycle_starts"])


def test_paper_sweep_has_27_samples_up_and_26_down():
    cur = ja.paper_current_path(2.0, 27)
    b = branches(cur)
    assert (b == "up").sum() == 27 and (b == "down").sum() == 26 and list(b[:27]) == ["up"] * 27
    s = shp.path_shape(cur)
    assert s.first_turn() == (26, 26) and s.counts() == (1, 1) and s.interior.size == 53 - 3


def test_a_current_that_never_changes_is_one_branch_up_and_no_shape():
    assert list(branches(np.zeros(4))) == ["up"] * 4
    with pytest.raises(ValueError, match="never changes"):
        shp.path_shape(np.ones(3))


def test_noise_floor_recovers_a_known_sigma_on_a_bipolar_loop():
    rng = np.random.default_rng(7)
    q = np.linspace(0.0, 2.0, 101)
    cur = np.concatenate([q, q[::-1][1:], -q[1:], -q[::-1][1:], q[1:]])
    B = 0.8 * np.tanh(cur) + 3e-4 * rng.standard_normal(cur.size)
    got = shp.noise_floor(B, shp.path_shape(cur), None, 3.5)
    assert got == pytest.approx(3e-4, rel=0.1)  # 495 triples: relative sd ~ 0.035


def test_last_full_cycle_is_the_one_generated():
    """0 -> +2 -> -2 -> +2 -> -1: the last full cycle runs from the first +2 to the second (index by construction)."""
    q = np.linspace(0.0, 2.0, 5)
    cur = np.concatenate([q, np.linspace(2, -2, 9)[1:], np.linspace(-2, 2, 9)[1:], np.linspace(2, -1, 7)[1:]])
    assert shp.path_shape(cur).last_cycle() == (4, 20)
    assert loopfigures.last_cycle(cur) == (4, 20)


def _count_derivations(monkeypatch) -> Counter:
    seen = Counter()
    real = shp._derive

    def counting(path, time):
        seen[np.asarray(path, dtype=float).tobytes()] += 1
        return real(path, time)

    monkeypatch.setattr(shp, "_derive", counting)
    return seen


@pytest.mark.slow
def test_one_diagnosis_of_the_raw_sweep_derives_its_shape_once(monkeypatch):
    seen = _count_derivations(monkeypatch)
    sw = dg.load_sweep(RAW, "hall1")
    dg.diagnose(sw, seed=0)
    assert seen[sw.current.tobytes()] == 1
    assert max(seen.values()) == 1  # every other path (a next-measurement variant) once as well


@pytest.mark.slow
def test_one_diagnosis_of_a_bh_loop_derives_each_path_once(tmp_path, monkeypatch):
    """A B(H) loop: the loop as read (branch check, decimation) and the path simulated (the decimated loop
    run conditioning_passes + 1 times) are two paths, each derived once."""
    f = tmp_path / "loop.csv"
    H = write_ja_loop(f, seed=3)[15:]  # from the first tip on: a closed loop, conditioned
    B = np.loadtxt(f, delimiter=",", skiprows=1)[15:, 1]
    f.write_text("H_A_per_m,B_T\n" + "".join(f"{float(h)!r},{float(b)!r}\n" for h, b in zip(H, B)))
    seen = _count_derivations(monkeypatch)
    d = dg.diagnose_bh_file(f)
    k = dg.resolve_config()["bh"]["conditioning_passes"]
    assert d["input"]["closure"]["closed"] and d["input"]["conditioning_passes"] == k
    assert seen[H.tobytes()] == 1 and seen[np.tile(H, k + 1).tobytes()] == 1
    assert max(seen.values()) == 1


def test_a_conditioned_sweep_hands_its_measured_shape_on(monkeypatch):
    """A sweep whose sidecar declares a preconditioning runs the history first: the path simulated (history +
    sweep) and the samples measured are two paths, each derived once; the signatures and the confound table read
    the measured one (:attr:`Sweep.measured_shape`), which is the shape the sweep was made with."""
    from mrhyst.diagnose import confounds, signatures, startstate

    seen = _count_derivations(monkeypatch)
    q = np.linspace(0.0, 2.0, 14)
    cur = np.concatenate([q, q[::-1][1:]])
    B = 0.5 * np.tanh(cur) + 1e-4 * np.cos(7.0 * cur)
    sw = dg.sweep_from_arrays(cur, 0.1 * np.arange(1, cur.size + 1), B, 3000.0)
    made_with = sw.shape
    startstate.apply(sw, {"preconditioning": {"cycles": 2, "i_peak_A": 2.0, "bipolar": True}},
                     dg.resolve_config()["regions"])
    assert sw.start > 0 and sw.measured_shape is made_with and sw.shape is not made_with
    assert np.array_equal(sw.measured_shape.path, sw.current[sw.start:])
    assert confounds.protocol_class(sw.measured_shape) == "unipolar_single"
    signatures.of_sweep(sw, 1e-4, dg.resolve_config()["signatures"])
    assert seen[cur.tobytes()] == 1 and seen[sw.current.tobytes()] == 1 and len(seen) == 2
