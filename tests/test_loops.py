"""Any current path: segments, cycles, turning points and the regions of a loop (mrhyst.data.loops)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.config import defaults
from mrhyst.data import loops
from mrhyst.model import ja

PAPER = ja.paper_current_path(2.0, 27)
REG = defaults("diagnose")["regions"]  # the schema's


def bipolar(cycles: int = 2, imax: float = 2.0, n: int = 20) -> np.ndarray:
    up = np.linspace(0.0, imax, n + 1)
    down = np.linspace(imax, -imax, 2 * n + 1)[1:]
    back = np.linspace(-imax, imax, 2 * n + 1)[1:]
    return np.concatenate([up] + [np.concatenate([down, back])] * cycles)


def test_paper_protocol_gives_the_eight_regions_it_always_had():
    lab = loops.region_labels(PAPER, None, REG)
    assert lab[0] == "asc_low" and lab[26] == "turning" and lab[-1] == "remanence"
    assert set(lab) == {"asc_low", "asc_mid", "asc_high", "turning", "desc_high", "desc_mid", "desc_low", "remanence"}
    assert list(lab[:26]).count("asc_low") == 9 and "desc_low" in lab[27:]
    assert loops.reversals(PAPER) == 1 and set(loops.cycle_index(PAPER)) == {0}


def test_a_repeated_current_at_the_top_is_one_turning_point():
    cur = np.array([0.0, 1.0, 2.0, 2.0, 2.0, 1.0, 0.0])
    assert list(loops.turning_mask(cur)) == [False, False, True, True, True, False, False]
    segs = loops.segments(cur)
    assert [(s.start, s.stop, s.direction) for s in segs] == [(0, 4, 1), (4, 6, -1)]


def test_bipolar_two_cycles_regions_and_cycles():
    cur = bipolar(2)
    segs = loops.segments(cur)
    assert [s.direction for s in segs] == [1, -1, 1, -1, 1]
    assert loops.reversals(cur) == 4
    cyc = loops.cycle_index(cur)
    assert set(cyc) == {0, 1, 2} and cyc[0] == 0 and cyc[-1] == 2
    lab = loops.region_labels(cur, None, REG)
    assert np.sum(lab == "turning") == 4
    # zero current after the first turn: two per descent and ascent crossing through 0
    assert np.sum(lab == "remanence") == 4
    # negative currents are labelled by |I| like positive ones
    j = int(np.argmin(cur))
    assert lab[j] == "turning" and lab[j - 1] == "desc_high" and lab[j + 1] == "asc_high"


def test_coercive_points_where_b_changes_sign_after_a_turn():
    cur = bipolar(1)
    H = 3000.0 * cur
    B, ok = ja.simulate_h([1.2e6, 2.0e3, 1e-3, 0.2, 2.0e3], H, form="physical", substeps=4)
    assert ok
    lab = loops.region_labels(cur, B, REG)
    co = np.flatnonzero(lab == "coercive")
    assert co.size == 2  # once on the descent, once on the ascent
    for j in co:
        assert cur[j] != 0.0 and abs(B[j]) <= np.max(np.abs(B)) * 0.2


def test_a_path_that_never_changes_is_an_error():
    with pytest.raises(ValueError, match="never changes"):
        loops.segments(np.ones(5))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(-5, 5), min_size=3, max_size=60))
def test_segments_tile_any_path_and_are_monotone(steps):
    cur = np.cumsum(np.array(steps, dtype=float))
    if np.all(np.diff(cur) == 0):
        return
    segs = loops.segments(cur)
    assert segs[0].start == 0 and segs[-1].stop == cur.size - 1
    for a, b in zip(segs[:-1], segs[1:]):
        assert a.stop == b.start and a.direction == -b.direction
    for s in segs:
        d = np.diff(cur[s.start: s.stop + 1])
        assert np.all(d * s.direction >= 0)
    if np.max(np.abs(cur)) > 0:
        lab = loops.region_labels(cur, None, REG)
        assert set(lab) <= set(loops.REGIONS) and lab.size == cur.size
