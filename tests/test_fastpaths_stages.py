"""The diagnosis' stage-level fast paths (issue 23's speed goals) against the slow paths they replace, bit for bit:
the prepared J-A integration against ja.simulate / effects.forward, the Preisach sum over distinct state columns
against the full sum, the layers' size-only stability refits against full increments. The same bytes, so no
verdict or committed number moves."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.diagnose import everett, modelform
from mrhyst.diagnose.problem import Fit, Problem
from mrhyst.diagnose.settings import resolve_config
from mrhyst.diagnose.sweep import sweep_from_arrays
from mrhyst.model import effects as fx
from mrhyst.model import ja

TRUTH = np.array([1.357e6, 2.6882e4, 1.4697e-4, 0.4199, 5.6943e3])


def sets(rng, n):
    return TRUTH * np.exp(rng.normal(0.0, 0.3, (n, 5))) * np.array([1, 1, 1, 0, 1]) + np.array(
        [0, 0, 0, 1, 0]) * rng.uniform(0.05, 0.9, (n, 1))


@settings(max_examples=15, deadline=None)
@given(st.integers(1, 40), st.integers(0, 2**32 - 1), st.sampled_from(["physical", "paper"]), st.booleans())
def test_prepared_integration_is_simulates_bytes(n, seed, form, scalar_start):
    rng = np.random.default_rng(seed)
    P, cur = sets(rng, n), np.concatenate([ja.paper_current_path(), -ja.paper_current_path()[1:]])
    M0 = 1.5e4 if scalar_start else rng.uniform(-1e5, 1e5, n)
    B, ok = ja.simulate(P, cur, 3026.4, form=form, substeps=3, dman="total", M0=M0)
    b, o = ja.prepared(cur, 3026.4, form=form, substeps=3, dman="total")(P, M0)
    assert b.tobytes() == B.tobytes() and o.tobytes() == ok.tobytes()


def rig_sweep(seed=3):
    cur = ja.paper_current_path()
    B, _ = ja.simulate(TRUTH, cur, 3026.4, form="physical", substeps=8)
    B = B + 3e-3 + np.random.default_rng(seed).normal(0.0, 2e-4, cur.size)
    return sweep_from_arrays(cur, np.arange(cur.size) * 0.1, B, 3026.4, dwell_s=0.1)


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_problems_forward_is_effects_forward(seed):
    """Problem.forward (a prepared integration, the effect order kept per set of names) gives effects.forward's
    bytes for the same J-A sets with every coordinate effect at its physical size."""
    rng = np.random.default_rng(seed)
    prob = Problem(rig_sweep(), resolve_config(None))
    U = np.tile(prob.null, (6, 1))
    U[:, :5] = np.log(TRUTH) * np.array([1, 1, 0, 0, 1]) + np.array([0, 0, 1, 1, 0]) * TRUTH
    U[:, :5] += rng.normal(0.0, 0.05, (6, 5)) * np.array([1, 1, 0, 0, 1])
    for e in prob.coord_effects:  # each inside its bounds, a third to a half of the way up
        j = prob.col[e.name]
        U[:, j] = prob.lo[j] + (prob.hi[j] - prob.lo[j]) * rng.uniform(0.33, 0.5, 6)
    B, ok = prob.forward(U)
    eff = {e.name: {e.param: U[:, prob.col[e.name]] * e.unit(prob.ctx)} for e in prob.coord_effects}
    b, o = fx.forward(prob.ja_sets(U), prob.sw.current, prob.sw.time, prob.sw.n_over_le, eff, form=prob.form,
                      substeps=prob.substeps, dman=prob.dman, M0=prob.sw.M0)
    assert o.tobytes() == ok.tobytes() and b.tobytes() == B.tobytes()
    assert ok.any()


@pytest.fixture(scope="module")
def problem():
    prob = Problem(rig_sweep(), resolve_config(None))
    u = prob.null.copy()
    u[:5] = [np.log(TRUTH[0]), np.log(TRUTH[1]), TRUTH[2], TRUTH[3], np.log(TRUTH[4])]
    B, _ = prob.forward(u[None, :])
    base = Fit((), u, float(np.sum((prob.sw.B - B[0]) ** 2)), prob.sw.n, True, B[0])
    return prob, base


def test_the_preisach_sum_over_distinct_columns_is_the_full_sum(problem):
    prob, _ = problem
    p = modelform.Preisach(prob, 12)
    assert p.ST_distinct.shape[1] < p.ST.shape[1]  # 0 -> max -> 0 revisits no state, but its ends agree
    X = np.column_stack([np.zeros(7), np.linspace(p.lo[1], p.hi[1], 7), np.full(7, -0.5), np.full(7, -1.0),
                         np.zeros(7)])
    wc = np.exp(-0.5 * ((p.lnhc[None, :] - X[:, 1:2]) / np.exp(X[:, 2:3])) ** 2)
    wu = np.exp(-0.5 * (p.hu[None, :] / (np.exp(X[:, 3:4]) * p.hmax)) ** 2) * p.dhu[None, :]
    w = (wc[:, :, None] * wu[:, None, :]).reshape(7, -1)
    tot = w.sum(axis=1, keepdims=True)
    full = np.einsum("nh,hj->nj", w, p.ST) / np.where(tot > 0, tot, 1.0)
    assert p.shape(X).tobytes() == full.tobytes()


def test_size_only_stability_refits_are_the_full_increments_sizes():
    """The layers' stability refits (size alone, no CV fits) give the sizes of full increments at the same lam,
    for every effect the layers judge (a flat top for the clip)."""
    cfg = dict(resolve_config(None)["layers"], cv_folds=5)
    sw0 = rig_sweep()
    top = 0.9 * float(np.max(sw0.B))
    sw = sweep_from_arrays(sw0.current, sw0.time, np.minimum(sw0.B, top), 3026.4, dwell_s=0.1)
    base = everett.fit_base(sw, cfg)
    for e in ("hall_offset", "thermal_drift", "eddy_lag", "sensor_saturation"):
        want = []
        for lam in sorted({min(base["lams"]), max(base["lams"])} - {base["lam"]}):
            r = everett.increment(dict(base, lam=lam), e, sw, dict(cfg, lag_refine=int(cfg["lag_refine"]) // 2))
            want.append(float(r["size"]))
        assert want and everett.stability_sizes(base, e, sw, cfg) == want
