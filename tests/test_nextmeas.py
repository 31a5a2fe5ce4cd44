"""The next measurement's predictors are the fitted models: on the measured path they give the fit's own B, also
where the model runs a conditioning prefix first (a B(H) loop's own passes): each predictor starts from the state
the fit had (:func:`mrhyst.diagnose.nextmeas.after_prefix`)."""

import numpy as np
import pytest
from mrhyst.diagnose import core, nextmeas
from mrhyst.diagnose import sweep as swm
from mrhyst.diagnose.settings import resolve_config

ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent
FERRITE = ROOT / "data" / "external" / "mnzn-ferrite-jamodel" / "loops.csv"


def test_after_prefix_runs_the_history_and_returns_the_rest():
    seen = {}

    def predict(c, t, d):
        seen["c"], seen["t"] = c, t
        return 10.0 * c

    run = nextmeas.after_prefix(predict, np.array([1.0, 2.0]), np.array([0.0, 1.0]))
    out = run(np.array([3.0, 4.0]), np.array([2.0, 3.0]), 1.0)
    assert list(seen["c"]) == [1, 2, 3, 4] and list(seen["t"]) == [0, 1, 2, 3] and list(out) == [30.0, 40.0]
    assert nextmeas.after_prefix(predict, np.array([]), np.array([])) is predict


@pytest.fixture(scope="module")
def ferrite_loop():
    """A real B(H) loop (Mn-Zn ferrite, loop 3, whose bipolar and half-amplitude variants J-A could not integrate
    from the tip in one jump: the model runs it once before the pass it is compared on), its
    diagnosis and the predictors next_measurement built."""
    cfg = resolve_config({"model_form": {"candidates": ["two_phase"]}})
    sw = swm.sweep_from_bh(FERRITE, 3, cfg)
    assert sw.start > 0
    made = []
    orig_mf, orig_eff = nextmeas._model_form_predictor, nextmeas._effect_predictor
    try:
        nextmeas._model_form_predictor = lambda *a: made.append(("mf", a[1], orig_mf(*a))) or made[-1][2]
        nextmeas._effect_predictor = lambda prob, fit: made.append(("eff", fit, orig_eff(prob, fit))) or made[-1][2]
        d = core.diagnose(sw, cfg)
    finally:
        nextmeas._model_form_predictor, nextmeas._effect_predictor = orig_mf, orig_eff
    return sw, d, made


def test_predictors_of_a_conditioned_loop_give_the_fits_own_b_on_the_measured_path(ferrite_loop):
    sw, d, made = ferrite_loop
    a = sw.start
    assert d["next_measurement"]["measured_sigma"] is not None and "failed" not in d["next_measurement"]
    kinds = set()
    for kind, what, predict in made:
        B = nextmeas.after_prefix(predict, sw.current[:a], sw.time[:a])(sw.current[a:], sw.time[a:], 1.0)
        assert np.all(np.isfinite(B))
        if kind == "eff":
            np.testing.assert_allclose(B, what.B[a:], rtol=0, atol=1e-12)
        else:
            rms = float(np.sqrt(np.mean((B - sw.B[a:])[sw.valid[a:]] ** 2)))
            assert rms == pytest.approx(d["evidence"]["model_form"][what]["rms_T"], rel=1e-9)
        kinds.add(kind)
    assert kinds == {"eff", "mf"}


def test_a_path_that_starts_away_from_the_prefix_end_is_reached_by_a_ramp_at_the_sweep_s_step():
    seen = {}

    def predict(c, t, d):
        seen["c"], seen["t"] = c, t
        return c

    run = nextmeas.after_prefix(predict, np.array([0.0, 1.0, 2.0]), np.array([0.0, 1.0, 2.0]), step=0.5)
    out = run(np.array([0.0, 1.0]), np.array([3.0, 4.0]), 1.0)
    np.testing.assert_allclose(seen["c"], [0, 1, 2, 1.5, 1.0, 0.5, 0, 1])
    assert np.all(np.diff(seen["t"]) > 0) and list(out) == [0.0, 1.0]


def test_every_variant_of_a_conditioned_loop_is_simulated(ferrite_loop):
    _, d, _ = ferrite_loop
    v = d["next_measurement"]["variants"]
    assert all(x is not None and x > 0 for x in v.values()), v
