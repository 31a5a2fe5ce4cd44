"""Issue 23 items 2-4 through `mrhyst diagnose`: every diagnosis carries its signatures; the lab's bipolar sweep
whose B fell 126 mT between two 0 A readings is reported as B changing while the current did not; a
preconditioned core declared in the sidecar is simulated with its history, and a start state that is not
declared is said to be assumed."""


import numpy as np
import pytest
from mrhyst import diagnose as dg
from mrhyst import rig
from mrhyst.model import ja
from test_signatures import TRUTH, polarity_switch_sweep

FAST = {"n_random": 300, "n_random_deep": 100, "n_starts": 2, "max_iter": 80, "budget_seeds": 1,
        "model_form": {"candidates": []}}
NLE = 3000.0


def write(tmp_path, name, cur, t, B, sens=2.0, extra=None, seed=0, sigma=1.5e-4):
    V = 1.65 + sens * (B + sigma * np.random.default_rng(seed).standard_normal(B.size))
    side = {"supply_V": 3.3, "coil_turns_per_m": NLE, "dwell_s": float(t[1] - t[0]),
            "sensors": {"hall1": {"sensitivity_V_per_T": sens, "quiescent_V": 1.65}}, **(extra or {})}
    rig.write_case(tmp_path / f"{name}.csv", {"hall1": V}, t, cur, side)
    return tmp_path / f"{name}.csv"


def test_polarity_switch_sweep_is_reported_as_b_changing_at_held_current(tmp_path):
    cur, t, _, B, j = polarity_switch_sweep()
    d = dg.diagnose_file(write(tmp_path, "bip", cur, t, B, sigma=5e-4), "hall1", config=FAST)
    held = [s for s in d["signatures"] if s["kind"] == "held_current"]
    assert len(held) == 1 and held[0]["samples"] == [j - 1, j]
    assert held[0]["size_T"] == pytest.approx(B[j] - B[j - 1], abs=4 * 2**0.5 * 5e-4)
    assert "B changed while the current did not" in d["verdict"]
    assert d["evidence"]["signatures"] == d["signatures"]
    assert d["start_state"]["source"] == "assumed" and "start state assumed demagnetised" in d["verdict"]


def cycled_sweep():
    """A core cycled twice between +-2 A (step 2/26 A) and then recorded 0 -> 2 -> 0 A: the truth runs the
    whole history; only the last 53 readings are recorded."""
    step = 2.0 / 26
    leg = lambda a, b: np.linspace(a, b, int(round(abs(b - a) / step)) + 1)[1:]  # noqa: E731
    hist = np.concatenate([np.zeros(1)] + [np.concatenate([leg(0, 2), leg(2, -2), leg(-2, 0)])] * 2)[:-1]
    rec = np.concatenate([np.zeros(1), leg(0, 2), leg(2, 0)])
    full = np.concatenate([hist, rec])
    t = rig.sample_times(full.size, 2.0)
    B, ok = rig.observe(ja.as_param_array(TRUTH), full, t, NLE, [])
    assert ok
    return rec, t[hist.size:], B[hist.size:]


def test_a_declared_preconditioning_is_run_first(tmp_path):
    """With the sidecar's preconditioning, plain J-A fits the cycled core's sweep to the noise and no remanent
    start is searched; without it, the start is assumed demagnetised (and said so), and plain J-A misses."""
    cur, t, B = cycled_sweep()
    pre = {"preconditioning": {"cycles": 2, "i_peak_A": 2.0, "bipolar": True}}
    d1 = dg.diagnose_file(write(tmp_path, "pre", cur, t, B, extra=pre), "hall1", config=FAST)
    assert d1["start_state"]["state"] == "cycled" and d1["start_state"]["source"] == "sidecar"
    assert "remanent_start" in d1["skipped"] and "start state assumed" not in d1["verdict"]
    assert d1["input"]["n_valid"] == cur.size
    assert d1["effect"] == "none" and d1["rms_before_T"] <= 1.5 * d1["noise_floor_T"]
    assert d1["signatures"] == []  # the remanence at the first reading is the declared history's, no signature
    d2 = dg.diagnose_file(write(tmp_path, "nopre", cur, t, B), "hall1", config=FAST)
    assert d2["start_state"]["source"] == "assumed" and "start state assumed demagnetised" in d2["verdict"]
    assert d2["rms_before_T"] > 3 * d1["rms_before_T"]
    assert [s["kind"] for s in d2["signatures"]] == ["first_zero"]  # the remanence the cycling left
