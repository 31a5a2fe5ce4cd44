"""Cheaper model-form fits (issue 23's build time) with the same bytes: the dampings the LM tries per model call
(``lanes``: 1 for the Preisach candidate, whose rows cost in proportion) never change a step; the two-phase
candidate integrates each distinct phase set once."""

import numpy as np
import pytest
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


