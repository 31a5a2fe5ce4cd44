"""A multi-start LSM fit (mrhyst.fit.identify._search) and its RK4 substep count: a start that does not win sets
neither the count of the fit nor that of the starts after it, and a start beaten by more than its own step error
is not refined (issue 23's build time: M130-27s, amplitude, joint, 45 -> 6 CPU s, the same optimum).

A stand-in problem with a known step error: B(x, n) = x + e(x) / n^4 (RK4's order), so max|B(n) - B(2 n)| =
e(x) (1 - 1/16) / n^4, and an LSM that goes from each start to a fixed end point with a fixed J."""

from types import SimpleNamespace

import numpy as np
import pytest
from mrhyst.fit import identify


class Stub:
    fail_cost_T = 1.0

    def __init__(self, err_at):
        self.substeps = 2
        self.err_at = err_at  # end point -> e(x)
        self.runs = []

    def model(self, X, substeps=None):
        n = substeps or self.substeps
        x = float(np.asarray(X)[0, 0])
        e = next((v for k, v in self.err_at.items() if abs(x - k) < 1e-9), 0.0)
        return np.array([[x + e / n**4, 0.0]]), np.array([True])

    def cost(self, X):
        return np.zeros(len(X))


# start -> (end point, J); None: set per test. A refinement runs LSM again from the end point (0.6 -> 0.6).
ENDS = {0.0: (0.1, 1.0e-3), 0.5: (0.6, None), 0.6: (0.6, None), 0.9: (0.1, 1.0e-3)}


def _search(monkeypatch, bad_J, bad_err):
    prob = Stub({0.6: bad_err})

    def run_lsm(p, box, x0, **kw):
        end, J = ENDS[round(float(x0[0]), 6)]
        p.runs.append((round(float(x0[0]), 6), p.substeps))
        return {"x": np.array([end]), "J": bad_J if J is None else J, "J_start": 1.0, "status": 1, "message": ""}

    monkeypatch.setattr(identify, "run_lsm", run_lsm)
    box = SimpleNamespace(centre=np.array([0.0]), lo=np.array([-1.0]), hi=np.array([1.0]), names=["x"])
    cfg = identify.resolve_config(None)
    r, extra = identify._search(prob, box, "lsm", cfg, seed=None, setting=None, pso_overrides=None, tol=1e-6,
                                starts=[("bad", np.array([0.5])), ("good", np.array([0.9]))])
    return prob, r, extra


def test_a_start_that_loses_does_not_set_the_count(monkeypatch):
    # the bad start ends at J 1.5e-3, above the best (1e-3) by less than its step error at 2 substeps
    # (16 (1/16 - 1/256) = 0.94):
    # it may still win at a finer count, so it is refined (the count rises), loses, and the count goes back
    prob, r, extra = _search(monkeypatch, 1.5e-3, 16.0)
    counts = [n for _, n in prob.runs]
    assert prob.runs[0] == (0.0, 2) and prob.runs[1] == (0.5, 2)
    assert max(counts) > 2  # the bad start was refined at a finer count ...
    assert prob.runs[-1] == (0.9, 2)  # ... the start after it ran at the count before it
    assert extra["substeps"] == 2 and extra["lsm_start"] == "box centre"


def test_a_start_beaten_by_more_than_its_step_error_is_not_refined(monkeypatch):
    # J 0.5 against 1e-3, its step error at 2 substeps 1.6e-2 (1/16 - 1/256) = 9.4e-4: hopeless at any count
    prob, r, extra = _search(monkeypatch, 0.5, 1.6e-2)
    assert prob.runs == [(0.0, 2), (0.5, 2), (0.9, 2)]  # every start once, at the count of the fit
    assert extra["substeps"] == 2 and r["J"] == pytest.approx(1e-3)
