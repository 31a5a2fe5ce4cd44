"""A densely sampled measured B(H) loop jitters back and forth in H; the diagnosis reads its real legs
(diagnose.sweep.dejitter, config diagnose.bh.reversal_frac). Before, 16 of the 18 gadolinium loops of
data/external were refused ("the descending branch from here has 2 usable samples")."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from mrhyst.data import loops
from mrhyst.data.io import InputError
from mrhyst.diagnose.settings import resolve_config
from mrhyst.diagnose.sweep import JITTER_FRAC_CAP, check_branches, dejitter, sweep_from_bh

ROOT = Path(__file__).resolve().parents[1]
GD = ROOT / "data/external/gd-temperature-nowicki/loops.csv"


def _tips_only(H) -> bool:
    """Every reversal of the path at a tip of the major loop (|H| >= 0.9 max |H|): no jitter left as a branch."""
    H = np.asarray(H)
    turns = np.flatnonzero(loops.turning_mask(H))
    return bool(np.all(np.abs(H[turns]) >= 0.9 * np.max(np.abs(H))))


@pytest.mark.parametrize("loop", [2, 5, 8, 11, 14, 17])  # the 0.4 kA/m loops: H wanders by 1-5 % of the peak
def test_every_jittering_gadolinium_loop_is_read_as_its_major_loop(loop):
    cfg = resolve_config(None)
    sw = sweep_from_bh(GD, loop, cfg)
    H = sw.current[sw.start:]
    assert _tips_only(H) and sw.pass_shape.reversals in (2, 4)
    assert all(sg.stop - sg.start + 1 >= cfg["min_per_branch"] for sg in sw.pass_shape.segments)
    assert sw.dejittered["samples_dropped"] > 0 and 0.01 <= sw.dejittered["reversal_frac"] <= JITTER_FRAC_CAP


def test_one_spike_above_the_tolerance_is_jitter_not_a_branch():
    """A single sample 2 % of the peak below the one before it on a rising leg: at 1 % a reversal (two legs of 2
    samples, as many legs with it dropped or not); at 2 % (a step back must exceed the tolerance) jitter."""
    H = np.concatenate([np.linspace(0, 100, 40), np.linspace(100, -100, 80)[1:], np.linspace(-100, 100, 80)[1:]])
    H[20] -= 2.0 + (H[20] - H[19])
    legs = dejitter(H, 0.01, 4, 160)
    assert legs.index.tolist() == [j for j in range(H.size) if j != 20] and legs.frac == 0.02
    assert loops.reversals(H[legs.index]) == 2


def test_a_loop_without_jitter_is_read_as_it_is_and_jitter_off_refuses_the_jittering_one():
    cfg = resolve_config(None)
    sw = sweep_from_bh(ROOT / "data/external/m130-27s-jamodel/loops.csv", 2, cfg)
    assert sw.dejittered == {}
    off = resolve_config({"bh": dict(cfg["bh"], reversal_frac=0.0)})
    with pytest.raises(InputError, match=r"loop_index 11\): sample \d+: the \w+ branch from here has [23] samples"):
        sweep_from_bh(GD, 11, off)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), amp=st.floats(100.0, 6e4), wobble=st.floats(0.0, 0.02),
       spike=st.floats(0.0, 0.04), n=st.integers(300, 3000))
@example(seed=300, amp=100.0, wobble=0.00390625, spike=0.01953125, n=300)  # CI's draw: one spike, as many legs
def test_jitter_and_spikes_below_the_cap_leave_the_three_tips_of_a_major_loop(seed, amp, wobble, spike, n):
    """0 -> +A -> -A -> +A sampled densely, every sample moved by up to ``wobble`` x A and one in 50 by up to
    ``spike`` x A: the legs read are the three of the protocol, turning at its tips."""
    rng = np.random.default_rng(seed)
    q = n // 4
    legs = (np.linspace(0, amp, q), np.linspace(amp, -amp, 2 * q)[1:], np.linspace(-amp, amp, 2 * q)[1:])
    clean = np.concatenate(legs)
    H = clean + wobble * amp * rng.uniform(-1, 1, clean.size)
    hit = rng.random(clean.size) < 0.02
    H[hit] += spike * amp * rng.uniform(-1, 1, int(hit.sum()))
    legs = dejitter(H, 0.01, 4, 160)
    k = legs.index
    assert legs.frac <= JITTER_FRAC_CAP and legs.shape.n == k.size
    if k.size < H.size:  # jitter found: only the protocol's legs are left
        assert loops.reversals(H[k]) == 2 and _tips_only(H[k])
    else:  # nothing stepped back by the tolerance: the path as read, and it is the protocol's
        assert loops.reversals(H) == 2


def test_a_clean_path_with_a_real_short_branch_is_not_smoothed_away():
    """A real minor excursion of 20 % of the peak (above the tolerance's cap) on 3 samples stays, and
    check_branches names it (the input's, not noise)."""
    H = np.concatenate([np.linspace(0, 100, 20), [90.0, 80.0], np.linspace(85, 100, 4), np.linspace(95, -100, 30)])
    assert dejitter(H, 0.01, 4, 160).index.size == H.size
    with pytest.raises(InputError, match="has 3 samples"):
        check_branches(H, np.ones(H.size, bool), resolve_config(None), "clean.csv", row_offset=0)
