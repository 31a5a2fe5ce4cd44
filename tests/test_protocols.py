"""The measurement that would settle an ambiguity is computed from the candidates' fitted models."""

import numpy as np
import pytest
from mrhyst.diagnose import protocols
from mrhyst.model import ja

MU0 = 4e-7 * np.pi
NLE = 3000.0
P = np.array([1.2e6, 2.0e4, 1e-3, 0.3, 5.0e3])
PAPER = ja.paper_current_path(2.0, 27)
T = 2.0 * np.arange(PAPER.size)


def offset_model(offset_T):
    return lambda c, t, dw: ja.simulate(P, c, NLE, form="physical", substeps=4)[0] + offset_T


def remanent_model(M0):
    return lambda c, t, dw: ja.simulate(P, c, NLE, form="physical", substeps=4, M0=M0)[0]


def drift_model(rate_T_per_s):
    return lambda c, t, dw: ja.simulate(P, c, NLE, form="physical", substeps=4)[0] + rate_T_per_s * (t - t[0])


def test_variants_are_well_formed():
    v = protocols.variant_paths(PAPER, T, 2.0)
    assert set(v) == set(protocols.VARIANTS)
    rep, t_rep, _ = v["repeat"]
    assert rep.size == 2 * PAPER.size and np.all(np.diff(t_rep) > 0)
    bip = v["bipolar"][0]
    assert bip.min() == pytest.approx(-2.0) and bip.max() == pytest.approx(2.0) and bip[-1] == pytest.approx(2.0)
    assert v["long_dwell"][2] == 10.0 and v["half_amplitude"][0].max() == pytest.approx(1.0)


def test_a_repeat_of_a_sweep_that_ends_away_from_its_start_goes_back_at_the_sweep_s_own_step():
    """0 -> +2 -> -2 -> +2 A ends at +2 A: the repeat returns to 0 A in the sweep's own steps (a jump of the full
    amplitude in one step left the J-A models' predictions non-finite: every such repeat read 0 sigma), and a drift
    keeps growing there while an offset repeats."""
    k = 13
    down, up = np.linspace(2, -2, 2 * k + 1)[1:], np.linspace(-2, 2, 2 * k + 1)[1:]
    cur = np.concatenate([np.linspace(0, 2, k + 1), down, up])
    t = 2.0 * np.arange(cur.size)
    rep, t_rep, _ = protocols.variant_paths(cur, t, 2.0)["repeat"]
    assert np.max(np.abs(np.diff(rep))) <= 2.0 / k * (1 + 1e-9) and np.all(np.diff(t_rep) > 0)
    assert np.array_equal(rep[: cur.size], cur) and np.array_equal(rep[-cur.size:], cur)
    nm = protocols.next_measurement({"offset": offset_model(2e-3), "drift": drift_model(2e-3 / t[-1])}, cur, t, 2.0,
                                    1.5e-4)
    assert nm["variants"]["repeat"] > 1.5 * nm["measured_sigma"] > 0


def _remanent_fit_to(target):
    """J-A + remanent start fitted to ``target`` on the measured path (log coordinates): the rival explanation
    a diagnosis would have in hand."""
    from scipy.optimize import least_squares

    def model(u):
        p = np.array([np.exp(u[0]), np.exp(u[1]), u[2], u[3], np.exp(u[4])])
        return ja.simulate(p, PAPER, NLE, form="physical", substeps=4, M0=u[5] / MU0 * 1e-3)[0], p

    u0 = np.array([np.log(P[0]), np.log(P[1]), P[2], P[3], np.log(P[4]), 1.0])
    r = least_squares(lambda u: (model(u)[0] - target) * 1e3, u0, x_scale="jac",
                      bounds=([10, 5, 0, 0, 3, -50], [18, 14, 0.1, 0.99, 14, 50]))
    p, M0 = model(r.x)[1], r.x[5] / MU0 * 1e-3
    return lambda c, t, dw: ja.simulate(p, c, NLE, form="physical", substeps=4, M0=M0)[0]


def test_offset_against_remanent_start_is_settled_by_a_bipolar_sweep():
    """On 0 -> max -> 0 a Hall offset and a remanent start (with its own J-A parameters) fit one loop alike;
    after a full reversal to -I_max the remanent start is forgotten while the offset stays, so the bipolar
    sweep separates the two fitted models most."""
    off = offset_model(1.5e-3)
    rem = _remanent_fit_to(off(PAPER, T, 2.0))
    out = protocols.next_measurement({"hall_offset": off, "remanent_start": rem}, PAPER, T, 2.0, sigma=1.5e-4)
    assert out["measured_sigma"] < 10.0  # the ambiguity: both fit the measured sweep within a few sigma
    assert out["protocol"] == "bipolar"
    assert out["separation_sigma"] > 3 * out["measured_sigma"] and out["separation_sigma"] > 5.0
    assert "bipolar" in out["why"] and "hall_offset" in out["why"]


def test_offset_against_drift_is_settled_by_time():
    """A constant offset and a drift that ends at the same level: repeating the sweep or a longer dwell
    makes the drift grow while the offset does not."""
    out = protocols.next_measurement({"hall_offset": offset_model(1e-3), "thermal_drift": drift_model(1e-3 / 104)},
                                     PAPER, T, 2.0, sigma=1.5e-4)
    assert out["protocol"] in ("repeat", "long_dwell")
    assert out["variants"]["half_amplitude"] < out["separation_sigma"]


def test_needs_two_models():
    with pytest.raises(ValueError, match="two"):
        protocols.next_measurement({"a": offset_model(0.0)}, PAPER, T, 2.0, 1e-4)


def test_a_variant_a_candidate_cannot_be_simulated_along_is_not_a_separation_of_zero():
    """A model that fails on a path (NaN: J-A not integrable there) leaves that variant uncomputed (None, listed
    in ``failed``), never chosen and never read as "no better than measured"; with every variant failed there is
    no next measurement to give."""
    off, drift = offset_model(1e-3), drift_model(1e-3 / 104)

    def fails_on(name):
        path = protocols.variant_paths(PAPER, T, 2.0, 5.0)[name][0]
        return lambda c, t, dw: (np.full(c.size, np.nan) if c.shape == path.shape and np.allclose(c, path)
                                 else drift(c, t, dw))

    ok = protocols.next_measurement({"hall_offset": off, "thermal_drift": drift}, PAPER, T, 2.0, sigma=1.5e-4)
    out = protocols.next_measurement({"hall_offset": off, "thermal_drift": fails_on(ok["protocol"])}, PAPER, T,
                                     2.0, sigma=1.5e-4)
    assert out["variants"][ok["protocol"]] is None and out["failed"] == [ok["protocol"]]
    assert out["protocol"] != ok["protocol"] and out["separation_sigma"] > 0
    assert protocols.separation(np.array([np.nan]), np.array([0.0]), 1e-4) is None
    none = protocols.next_measurement({"hall_offset": off, "x": lambda c, t, dw: np.full(c.size, np.nan)},
                                      PAPER, T, 2.0, sigma=1.5e-4)
    assert none is None
