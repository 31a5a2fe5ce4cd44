"""The blind key's reference fit stops early only where its result is not recorded: a plain fit told to stop
below a level ends below it once it gets there, and a fit that never gets there is the same bytes."""

import numpy as np
from mrhyst import rig
from mrhyst.blind import reference as ref
from mrhyst.model import ja

TRUTH = {"Ms": 1.3e6, "a": 3.0e4, "alpha": 2.0e-3, "c": 0.35, "k": 1.5e4}


def _offset_loop(offset_T):
    """A noise-free plain J-A loop with a constant offset: plain J-A cannot absorb all of it."""
    I = ja.paper_current_path()
    t = rig.sample_times(I.size, 0.1)
    B, _ = rig.observe(ja.as_param_array(TRUTH), I, t, 3.0e4, [], substeps=8)
    return ref.Loop(B + offset_T, I, t, 3.0e4, 8)


def test_plain_fit_stops_below_the_level_and_is_unchanged_above_it(small):
    box = small["reference"]["box"]
    loop = _offset_loop(2e-3)
    start = ja.as_param_array(TRUTH) * np.array([1.3, 0.75, 1.3, 0.8, 1.3])
    start_rms = ref.start_rms(loop, start, box)
    full, P = ref.plain_fit(loop, [start], box, 300)
    assert 1e-4 < full < start_rms  # the offset leaves a gap the fit cannot close, and the fit improved
    # a level the fit never gets below (its final RMS): the same fit, bit for bit
    same, P2 = ref.plain_fit(loop, [start], box, 300, stop_below=0.999 * full)
    assert (same, P2.tobytes()) == (full, P.tobytes())
    # a level it passes on the way (between the start and the end): it ends below the level, above the full fit
    level = 0.5 * (start_rms + full)
    early, _ = ref.plain_fit(loop, [start], box, 300, stop_below=level)
    assert full < early < level  # it stopped: scipy halts only on a StopIteration (a True return is ignored)
    # several starts: the search ends with the first that gets below; without a level every start runs
    assert ref.plain_fit(loop, [start, start * 1.1], box, 300, stop_below=level)[0] < level


def test_batched_rows_are_the_bytes_of_one_forward_call_each():
    """Loop.model_rows (the fits' batched path: the integration prepared once, fx.apply) gives for every row the
    bytes of Loop.model of that row alone (rig.observe, the one forward model with its checks), plain and with
    each effect of the registry at its reference starts and at half the first."""
    from mrhyst.model import effects as fx

    loop = _offset_loop(1e-3)
    P = ja.as_param_array(TRUTH) * np.random.default_rng(5).uniform(0.7, 1.3, size=(3, 5))
    B, ok = loop.model_rows(P)
    assert all(ok[i] and B[i].tobytes() == loop.model(P[i]).tobytes() for i in range(3))
    for name in fx.REGISTRY:
        starts, _ = ref._effect_starts(loop, name, ja.as_param_array(TRUTH))
        vals = [float(v) for v in starts] + [0.5 * float(starts[0])]
        rows = np.resize(P, (len(vals), 5))
        Bv, okv = loop.model_rows(rows, name, vals)
        for i, v in enumerate(vals):
            one = loop.model(rows[i], name, v)
            assert (one is None and not okv[i]) or (okv[i] and Bv[i].tobytes() == one.tobytes()), (name, v)


def test_a_loose_effect_refit_ends_above_the_tight_one_and_goes_on_near_a_decision_level(small):
    """blind.reference.effect_tol: a loose TRF stop is on the tight run's trajectory (never below it); a value that
    lands just above a decision level goes on at the tight tolerance; effect_tol 1e-12 is the tight fit itself."""
    box = small["reference"]["box"]
    loop = _offset_loop(2e-3)
    _, P = ref.plain_fit(loop, [ja.as_param_array(TRUTH) * np.array([1.1, 0.9, 1.1, 0.9, 1.1])], box, 300)
    tight = ref.effect_fit(loop, "eddy_lag", P, box, 300)
    assert ref.effect_fit(loop, "eddy_lag", P, box, 300, loose=(ref.TIGHT_TOL, (0.99 * tight,), tight)) == tight
    loose = ref.effect_fit(loop, "eddy_lag", P, box, 300, loose=(1e-6, (), 0.0))
    assert tight < loose < tight * (1 + 1e-4)  # the lag cannot take the offset: a gap is left either way
    far = ref.effect_fit(loop, "eddy_lag", P, box, 300, loose=(1e-6, (0.5 * tight,), 0.1 * tight))
    assert far == loose  # far above the level: the loose value decides
    near = ref.effect_fit(loop, "eddy_lag", P, box, 300, loose=(1e-6, (0.5 * (tight + loose),), tight))
    assert near <= tight * (1 + 1e-9)  # just above the level: it went on to the tight fit's value
