"""The stderr widening for residuals correlated along the path (mrhyst.fit.accuracy.correlation_factor).

Checked against what it claims, not against its formula: the spread of a least-squares estimate over many
independent draws of AR(1) noise, which the plain Jacobian stderr understates and the widened one matches.
"""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.fit.accuracy import correlation_factor


def ar1(rng, n: int, rho: float) -> np.ndarray:
    e = rng.standard_normal(n) * math.sqrt(1 - rho**2)
    out = np.empty(n)
    out[0] = rng.standard_normal()
    for t in range(1, n):
        out[t] = rho * out[t - 1] + e[t]
    return out


def test_widened_stderr_matches_the_spread_of_a_fitted_level_under_ar1_noise():
    rng = np.random.default_rng(7)
    n, rho, reps = 300, 0.9, 400
    means, plain, widened = [], [], []
    for _ in range(reps):
        r = ar1(rng, n, rho)
        means.append(r.mean())  # the least-squares level of a constant model
        plain.append(r.std(ddof=1) / math.sqrt(n))
        widened.append(plain[-1] * correlation_factor([r - r.mean()], 0.995)[0])
    spread = float(np.std(means))
    assert np.median(plain) < 0.4 * spread  # the plain Jacobian stderr: ~4x too small at rho 0.9
    assert 0.75 < np.median(widened) / spread < 1.25


def test_white_residuals_are_not_widened_and_a_smooth_one_is_capped():
    rng = np.random.default_rng(3)
    k, rho = correlation_factor([rng.standard_normal(2000)], 0.995)
    assert k < 1.1 and rho < 0.05
    k, rho = correlation_factor([np.sin(np.linspace(0, 3, 5000))], 0.995)  # model form: smooth along the path
    assert rho == 0.995 and math.isclose(k, math.sqrt(1.995 / 0.005))


@settings(max_examples=30, deadline=None, derandomize=True)
@given(st.integers(0, 10_000), st.floats(0.0, 0.95))
def test_pieces_pool_lags_within_each_loop_only(seed, rho):
    """Two loops are two pieces: no lag is taken across the joint, so swapping them changes nothing and the
    factor is never below 1."""
    rng = np.random.default_rng(seed)
    a, b = ar1(rng, 120, rho), ar1(rng, 80, rho) + 5.0
    k1, r1 = correlation_factor([a, b], 0.995)
    k2, r2 = correlation_factor([b, a], 0.995)
    assert math.isclose(k1, k2) and math.isclose(r1, r2) and k1 >= 1.0


def test_a_law_coordinate_at_its_bound_or_without_effect_has_a_null_stderr_that_says_why():
    """templaws.stderr / null_reasons on a hand-made Jacobian: coordinate 0 is well determined, 1 sits on its
    bound, 2 moves nothing (a zero column: pinv would give it stderr 0, i.e. perfect precision), 3 is held."""
    from types import SimpleNamespace

    from mrhyst.fit.box import Box
    from mrhyst.materials import templaws as tl

    box = Box(("a", "b", "c", "d"), np.zeros(4), np.ones(4), ("linear",) * 4, np.full(4, 0.5))
    x = np.array([0.5, 1.0, 0.5, 0.5])
    Ju = np.zeros((50, 3))
    Ju[:, 0] = np.linspace(1, 2, 50)
    Ju[:, 1] = np.linspace(2, 1, 50)
    r = {"jac_u": Ju, "x": x, "J": 0.01, "free": np.array([0, 1, 2])}
    se = tl.stderr(SimpleNamespace(nv=50), box, r, 2.0)
    assert np.isfinite(se[0]) and se[0] > 0 and np.all(np.isnan(se[1:]))
    why = tl.null_reasons(box, r, se)
    assert set(why) == {"b", "c", "d"}
    assert why["b"].startswith("at its bound") and why["c"].startswith("not identified") and why["d"].startswith("held")


def _jacobian_stderr(cap: float, noise) -> np.ndarray:
    """The diagnosis's J-A stderr (mrhyst.diagnose.candidates.std_errors) at the rig's truth, on a 2-cycle bipolar
    sweep whose measured B is the model plus ``noise`` scaled to an RMS of 0.5 mT (the same RSS whatever its shape:
    the plain stderr is then the same, only the widening can differ)."""
    from mrhyst.blind.cases import current_path
    from mrhyst.diagnose import Problem, resolve_config, std_errors
    from mrhyst.diagnose.problem import Fit
    from mrhyst.diagnose.reference import ref_coords
    from mrhyst.diagnose.sweep import sweep_from_arrays
    from mrhyst.model import ja

    P0, nle = np.array([1.357e6, 2.6882e4, 1.4697e-4, 0.4199, 5.6943e3]), 3026.4
    cur = current_path({"i_max_A": 2.0, "n_up": 27, "protocol": "bipolar2"})
    cfg = resolve_config({"stderr_rho_max": cap})
    B, _ = ja.simulate(P0, cur, nle, form=cfg["form"], substeps=int(cfg["substeps"]))
    r = np.asarray(noise(cur.size), dtype=float)
    r *= 5e-4 / math.sqrt(np.mean(r**2))
    prob = Problem(sweep_from_arrays(cur, np.arange(cur.size) * 0.1, B + r, nle, cfg=cfg), cfg)
    u = prob.null.copy()  # every effect at its null, the J-A coordinates at the truth
    u[:5] = ref_coords(P0)
    fit = Fit((), u, float(np.sum(r**2)), cur.size, True, B)
    se = std_errors(prob, fit, prob.sw.valid)
    return se[np.isfinite(se)]


def test_every_diagnosis_stderr_is_widened_for_a_residual_correlated_along_the_path():
    """One owner (issue 26's house list): the shared Jacobian stderr of the diagnosis, not reference mode only.
    A smooth residual (model form: AR(1), rho 0.9) leaves the data fewer independent values than white noise of
    the same RMS, so every J-A stderr is several times larger (sqrt(19) = 4.4 for rho = 0.9; the short sweep's
    estimate of rho is biased low); the cap diagnose.stderr_rho_max = 0.5 holds the factor at sqrt(3) or less."""
    rng = np.random.default_rng(7)
    white = _jacobian_stderr(0.995, lambda n: rng.standard_normal(n))
    rng = np.random.default_rng(7)
    smooth = _jacobian_stderr(0.995, lambda n: ar1(rng, n, 0.9))
    assert white.size == 5 and np.all(smooth / white > 2.5), smooth / white
    rng = np.random.default_rng(7)
    capped = _jacobian_stderr(0.5, lambda n: ar1(rng, n, 0.9))
    assert np.all(capped / white < math.sqrt(3.0) + 1e-9) and np.all(capped / white > 1.2), capped / white
