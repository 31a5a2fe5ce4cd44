"""Physics of the J-A kernel (Eqs. 1-13): accuracy, forms, batching, failure handling."""

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.model import anhysteretic as anh
from mrhyst.model import ja
from mrhyst.paper.fig2 import fig2_current_path

TABLE1 = {
    "group1_lsm": [1.5034e6, 3.4340e4, 5.8263e-3, 0.51524, 6.4481e3],
    "group1_pso": [1.2456e6, 2.6882e4, 1.4697e-4, 0.5385, 5.6943e3],
    "group2_lsm": [0.9018e6, 3.2706e4, 0.3414e-2, 0.39107, 1.1887e4],
    "group2_pso": [1.9332e6, 3.4320e4, 0.9021e-2, 0.2006, 4.6041e4],
}
FIG2 = [1.6e6, 1100.0, 0.0017, 0.26, 400.0]
NLE = 3.0e3
PATH = ja.paper_current_path()

# parameter sets drawn from +-60 % around the Table 1 group-1 PSO set (well inside the physical range)
param_sets = st.tuples(*[st.floats(0.4, 1.6) for _ in range(5)]).map(
    lambda f: [v * s for v, s in zip(TABLE1["group1_pso"], f)]
).filter(lambda p: p[3] < 0.95)


def test_langevin_series_matches_closed_form_at_the_switch():
    x = np.array([ja.SERIES_BELOW * (1 - 1e-12), ja.SERIES_BELOW * (1 + 1e-12)])
    # both sides of the switch agree to the closed form's cancellation error (~3 eps / x^2 relative)
    assert ja.langevin(x[0]) == pytest.approx(ja.langevin(x[1]), rel=1e-11)
    assert ja.dlangevin(x[0]) == pytest.approx(ja.dlangevin(x[1]), rel=1e-9)


def test_langevin_near_zero_is_exact_where_coth_fails():
    x = 1e-9
    assert ja.langevin(x) == pytest.approx(x / 3, rel=1e-12)
    naive = 1 / np.tanh(x) - 1 / x  # catastrophic cancellation
    assert abs(naive - x / 3) > 1e-12  # documents why the series is needed
    assert ja.langevin(-x) == -ja.langevin(x)
    assert ja.dlangevin(0.0) == pytest.approx(1 / 3)


@pytest.mark.parametrize("name", sorted(TABLE1))
@pytest.mark.parametrize("form", ja.FORMS)
def test_table1_sets_integrate_to_1e6_at_default_step(name, form, config):
    sub = config["ja"]["substeps"]
    ref, ok_ref = ja.simulate(TABLE1[name], PATH, NLE, form=form, substeps=400)
    B, ok = ja.simulate(TABLE1[name], PATH, NLE, form=form, substeps=sub)
    assert ok and ok_ref
    assert np.max(np.abs(B - ref)) <= 1e-6


@pytest.mark.parametrize("form", ja.FORMS)
def test_fig2_set_integrates_to_1e6_at_its_default_step(form, config):
    f2 = config["fig2"]
    path = fig2_current_path(f2["i_max_A"], f2["di_A"])
    ref, _ = ja.simulate(FIG2, path, NLE, form=form, substeps=400)
    B, ok = ja.simulate(FIG2, path, NLE, form=form, substeps=f2["substeps"])
    assert ok
    assert np.max(np.abs(B - ref)) <= 1e-6


def test_compiled_kernel_equals_plain_python_reference():
    for p in list(TABLE1.values()) + [FIG2]:
        for form in ja.FORMS:
            B, ok = ja.simulate(p, PATH, NLE, form=form, substeps=3)
            ref = ja.simulate_scalar(p, PATH * NLE, form=form, substeps=3)
            assert ok
            np.testing.assert_allclose(B, ref, rtol=1e-9, atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(st.lists(param_sets, min_size=2, max_size=6), st.sampled_from(ja.FORMS))
def test_batch_equals_one_by_one(sets, form):
    P = np.array(sets)
    B, ok = ja.simulate(P, PATH, NLE, form=form, substeps=8)
    for i, p in enumerate(P):
        b1, ok1 = ja.simulate(p, PATH, NLE, form=form, substeps=8)
        assert ok1 == ok[i]
        np.testing.assert_array_equal(b1, B[i])


def _monotone_violation(current, B):
    """Largest step against the sweep direction (T): > 0 means dB/dI has the wrong sign somewhere."""
    dI = np.diff(current)
    dB = np.diff(B)
    return float(np.max(-np.sign(dI) * dB))


@settings(max_examples=40, deadline=None)
@given(param_sets)
def test_physical_form_has_nonnegative_slope_everywhere(p):
    path = fig2_current_path(2.0, 0.05)
    B, ok = ja.simulate(p, path, NLE, form="physical", substeps=2)
    if ok:
        # B = mu0 (H + M): with dM/dH >= 0, B moves with H on every segment, reversals included
        assert _monotone_violation(path, B) <= 1e-15


def test_paper_form_goes_against_the_field_after_a_reversal():
    """The 1986 form's known defect (ARCHITECTURE 5) is reproduced, not hidden."""
    path = fig2_current_path(2.0, 0.01)
    B, ok = ja.simulate(FIG2, path, NLE, form="paper", substeps=4)
    assert ok
    assert _monotone_violation(path, B) > 1e-4
    Bp, _ = ja.simulate(FIG2, path, NLE, form="physical", substeps=4)
    assert _monotone_violation(path, Bp) <= 1e-15


@pytest.mark.parametrize("form", ja.FORMS)
def test_loop_closes_at_saturation(form):
    """Driven deep into saturation, ascending and descending branches meet and cycles repeat."""
    i = np.linspace(-1, 1, 201)
    cycle = np.concatenate([i[::-1], i[1:]])  # +1 -> -1 -> +1
    path = np.concatenate([np.linspace(0, 1, 101), cycle[1:], cycle[1:], cycle[1:]])
    nle = 60 * FIG2[1]  # H_max = 60 a: deep saturation
    B, ok = ja.simulate(FIG2, path, nle, form=form, substeps=8)
    assert ok
    n = cycle.size - 1
    last, prev = B[-n:], B[-2 * n:-n]
    # cyclic steady state: successive cycles agree
    assert np.max(np.abs(last - prev)) < 1e-6
    # branches meet near the tips: gap at 90 % of H_max is tiny compared with the gap at H = 0
    down = B[-n - 1: -n - 1 + 200 + 1]  # +1 -> -1 of the last cycle (201 samples)
    up = B[-201:]  # -1 -> +1
    hv = path[-201:]
    j0 = np.argmin(np.abs(hv))
    j9 = np.argmin(np.abs(hv - 0.9))
    down_on_hv = down[::-1]  # the descending branch on the ascending grid
    np.testing.assert_allclose(path[-n - 1: -n - 1 + 201][::-1], hv)
    gap0 = abs(up[j0] - down_on_hv[j0])
    gap9 = abs(up[j9] - down_on_hv[j9])
    assert gap0 > 0.1  # a real hysteresis loop
    assert gap9 < 1e-3 * gap0


def test_failed_candidate_is_flagged_not_raised():
    bad = [1.2e6, 2.7e4, 0.5, 0.5, 10.0]  # alpha |Man - Mirr| >> k: Eq. (8) pole
    P = np.array([TABLE1["group1_pso"], bad])
    B, ok = ja.simulate(P, PATH, NLE, form="paper", substeps=8)
    assert ok.tolist() == [True, False]
    assert np.all(np.isfinite(B[0]))
    assert np.isnan(B[1]).any()
    # out-of-range parameters are failures too, not exceptions
    B, ok = ja.simulate([1e6, -1.0, 0.0, 0.5, 1e3], PATH, NLE, form="paper", substeps=8)
    assert ok is False and np.isnan(B).all()


def test_a_set_gives_the_same_bytes_in_every_lane_and_batch_size():
    """The SIMD kernel has no scalar remainder: a set's B does not depend on where it sits in the batch."""
    p = np.array(TABLE1["group2_lsm"])
    ref, _ = ja.simulate(p, PATH, NLE, form="physical", substeps=8)
    others = np.array(list(TABLE1.values()) + [FIG2] * 3)
    for n in (1, ja.LANES - 1, ja.LANES, ja.LANES + 3, 3 * ja.LANES):
        P = np.resize(others, (n, 5)).copy()
        for pos in {0, n // 2, n - 1}:
            Q = P.copy()
            Q[pos] = p
            B, ok = ja.simulate(Q, PATH, NLE, form="physical", substeps=8)
            assert ok[pos]
            assert B[pos].tobytes() == ref.tobytes()


def test_diverging_and_nan_sets_are_flagged_not_silent():
    good = TABLE1["group1_pso"]
    P = np.array([good, [np.nan, 2.7e4, 1e-4, 0.5, 5e3], [1.2e6, 2.7e4, np.inf, 0.5, 5e3],
                  [1.2e6, 2.7e4, 0.5, 0.5, 10.0], good])
    B, ok = ja.simulate(P, PATH, NLE, form="physical", substeps=8)
    assert ok.tolist() == [True, False, False, False, True]
    assert np.isnan(B[~ok][:, -1]).all() and np.isfinite(B[ok]).all()
    np.testing.assert_array_equal(B[0], B[4])


def test_vectorised_exp_and_log_are_accurate_to_an_ulp():
    y = np.linspace(-700.0, 700.0, 20001)
    e = np.array([_vexp(v) for v in y])
    assert np.max(np.abs(e - np.exp(y)) / np.exp(y)) < 5e-16
    q = np.exp(np.linspace(-40.0, 40.0, 20001))
    lg = np.array([_vlog(v) for v in q])
    assert np.max(np.abs(lg - np.log(q))) < 5e-16 * 40


@numba.njit
def _vexp(v):
    return anh.vexp(v)


@numba.njit
def _vlog(v):
    return anh.vlog(v)


def test_bad_shapes_raise_clear_errors():
    with pytest.raises(ValueError, match="5 columns"):
        ja.simulate(np.ones((3, 4)), PATH, NLE, form="paper", substeps=8)
    with pytest.raises(ValueError, match="form"):
        ja.simulate(FIG2, PATH, NLE, form="literal", substeps=8)
    with pytest.raises(ValueError, match="substeps"):
        ja.simulate(FIG2, PATH, NLE, substeps=0, form="paper")


def test_remanent_start_changes_the_start_only_through_M0():
    B0, _ = ja.simulate(TABLE1["group1_pso"], PATH, NLE, form="paper", substeps=8)
    B1, _ = ja.simulate(TABLE1["group1_pso"], PATH, NLE, M0=1e4, form="paper", substeps=8)
    assert B1[0] == pytest.approx(ja.MU0 * 1e4)
    assert B0[0] == 0.0
    assert B1[-1] > B0[-1]
