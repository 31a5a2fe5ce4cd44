"""Cheaper model-form fits (issue 23's build time) with the same bytes: the dampings the LM tries per model call
(``lanes``: 1 for the Preisach candidate, whose rows cost in proportion) never change a step; the two-phase
candidate integrates each distinct phase set once."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.diagnose import modelform, problem
from mrhyst.diagnose.problem import Problem
from mrhyst.diagnose.settings import resolve_config
from mrhyst.diagnose.sweep import load_sweep
from mrhyst.fit import lm
from mrhyst.model import ja

T = np.linspace(0.0, 4.0, 40)
Y = 2.0 * np.exp(-T / 0.7) + 0.3 + 0.01 * np.random.default_rng(0).standard_normal(T.size)


def decay(X, rows):
    X = np.atleast_2d(X)
    return X[:, :1] * np.exp(-T[None, :] / np.exp(X[:, 1:2])) + X[:, 2:3] - Y


@pytest.mark.parametrize("lanes", [1, 4, 16])
def test_the_dampings_per_call_never_change_a_step(lanes):
    starts = np.array([[1.0, 0.0, 0.0], [3.0, -1.0, 1.0], [5.0, 3.0, 0.0]])
    ref = lm.least_squares_batch(decay, starts, ftol=1e-14, max_iter=300, lanes=2)
    res = lm.least_squares_batch(decay, starts, ftol=1e-14, max_iter=300, lanes=lanes)
    assert res.x.tobytes() == ref.x.tobytes() and list(res.nit) == list(ref.nit)
    assert lm._attempts(3, 1) == 1 and lm._attempts(3, 16) == 5 and lm._attempts(3, 4) == 1


@pytest.fixture(scope="module")
def hall1():
    return Problem(load_sweep("data/raw/li_gong_rig.csv", "hall1"), resolve_config(None))


def test_two_phase_integrates_each_distinct_phase_once_with_the_same_bytes(hall1):
    """A Jacobian's probes (each moves one phase) and a start magnetisation split by Ms: the deduplicated forward
    gives the bytes of simulating all 2n phase sets."""
    tp = modelform.TwoPhase(hall1)
    sw = hall1.sw
    base = np.concatenate([[14.0, 10.2, 1.5e-4, 0.4, 8.6], [12.0, 9.0, 0.0, 0.5, 7.5]])
    X = np.repeat(base[None, :], 11, axis=0)
    X[np.arange(1, 11), np.arange(10)] += tp.steps * 10.0
    for M0 in (0.0, 2.0e4):
        sw.M0 = M0
        try:
            B, ok = tp.forward(X)
            P = problem.ja_sets(np.vstack([X[:, :5], X[:, 5:]]))
            share = P[:11, 0] / (P[:11, 0] + P[11:, 0])
            Bf, okf = ja.simulate(P, sw.current, sw.n_over_le, form=hall1.form, substeps=hall1.substeps,
                                  dman=hall1.dman, M0=M0 * np.concatenate([share, 1.0 - share]))
        finally:
            sw.M0 = 0.0
        want = Bf[:11] + Bf[11:] - ja.MU0 * tp.H[None, :]
        assert ok.all() and B.tobytes() == want.tobytes() and ok.tobytes() == (okf[:11] & okf[11:]).tobytes()
    keep, inv = modelform.distinct_rows(np.array([[1.0, 2.0], [3.0, 4.0], [1.0, 2.0], [5.0, 6.0], [3.0, 4.0]]))
    assert list(keep) == [0, 1, 3] and list(inv) == [0, 1, 0, 2, 1]




WORDS = np.array([0.0, -0.0, 1.0, -1.0, np.nan, np.inf, 5e-324, 1e-7])


@settings(max_examples=200, deadline=None)
@given(n=st.integers(0, 80), k=st.integers(1, 6), seed=st.integers(0, 2**32 - 1))
def test_distinct_rows_are_those_of_a_dict_of_row_bytes(n, k, seed):
    """The compiled hash table finds the rows a dict keyed by each row's bytes finds (first of each pattern, in order;
    -0.0 and 0.0 differ, NaN equals its own pattern), on rows drawn from a few words so that most repeat."""
    A = np.random.default_rng(seed).choice(WORDS, size=(n, k))
    first: dict = {}
    want_inv = [first.setdefault(r.tobytes(), len(first)) for r in A]
    keep, inv = modelform.distinct_rows(A)
    assert list(keep) == [want_inv.index(c) for c in range(len(first))]
    assert list(inv) == want_inv
    assert A[keep][inv].tobytes() == A.tobytes()


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), turns=st.integers(1, 5))
def test_the_compiled_hysteron_states_follow_the_field_path(seed, turns):
    """Each hysteron (up, down) is +1 from the first sample where H >= up until one where H <= down, and so on; before
    either its start state: checked sample by sample against a plain scan of the path."""
    rng = np.random.default_rng(seed)
    hc, hu = rng.uniform(0.0, 2.0, 60), rng.uniform(-2.0, 2.0, 60)
    up, down = hu + hc, hu - hc
    H = np.concatenate([np.linspace(a, b, 15) for a, b in zip(rng.uniform(-3, 3, turns), rng.uniform(-3, 3, turns))])
    start = -np.sign(hu)
    ST = modelform._states(up, down, start, H)
    for i in range(up.size):
        s = start[i]
        for j, h in enumerate(H):
            s = -1.0 if h <= down[i] else (1.0 if h >= up[i] else s)
            assert ST[i, j] == s


def test_candidates_sharing_an_lm_batch_get_the_bytes_of_their_own_fits(hall1):
    """jtd1992 and venkataraman fitted in one lock-step batch (modelform._fit_batch), full fits and fold refits with
    their own weights: each model's x, RSS and B are the bytes of fitting it alone."""
    a, b = modelform.build(hall1, ["jtd1992", "venkataraman"])
    assert modelform._groups([a, b]) == [[a, b]]
    u = np.array([14.0, 10.2, 1.5e-4, 0.4, 8.6])
    v = hall1.sw.valid.astype(float)
    W = np.vstack([v, v * (np.arange(v.size) % 3 != 0), v * (np.arange(v.size) < v.size // 2)])
    jobs = [(a, np.vstack([u, u + 0.05, u - 0.05]), W), (b, np.vstack([u, u * 1.01, u]), W[::-1].copy())]
    together = modelform._fit_batch(jobs, 30, 1e-9)
    for job, got in zip(jobs, together):
        alone = modelform._fit_batch([job], 30, 1e-9)[0]
        assert all(np.asarray(g).tobytes() == np.asarray(w).tobytes() for g, w in zip(got, alone))
    assert not np.array_equal(together[0][0], together[1][0])  # two different fits, not one
