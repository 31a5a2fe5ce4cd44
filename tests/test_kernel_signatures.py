"""One compiled signature per kernel whatever flags the caller's arrays carry (the warm-up's compile time, rule
warmup / mrhyst.warmup).

numba compiles a kernel once per argument type, and a read-only array (a broadcast view) or a strided one
(np.nonzero of a 2-D mask) is a type of its own: the same machine work compiled again (~0.5 s for the J-A kernel)
and one more cached file. Each test calls a kernel's public path twice, with arrays that used to differ only in
such a flag, and checks that no signature is added and that the results are the same bytes."""

import numpy as np
import pytest
from mrhyst.fit import lm
from mrhyst.model import aot, ja
from mrhyst.model import effects as fx

P = np.array([[1.0e6, 2.5e4, 1.0e-3, 0.3, 1.0e4]] * 3)
H = np.concatenate([np.linspace(0.0, 3.0e4, 9), np.linspace(3.0e4, -1.0e4, 9)[1:]])


@pytest.fixture(autouse=True)
def _jit_kernels(monkeypatch):
    """numba's JIT kernels even where the ahead-of-time module is built (mrhyst.model.aot): their signatures are
    what these tests count."""
    monkeypatch.setattr(aot, "_KERNELS", aot.jit())


def test_a_start_state_per_set_runs_the_kernel_of_a_scalar_start():
    B0, ok0 = ja.simulate_h(P, H, form="paper", substeps=2, M0=0.0)
    sigs = list(ja._simulate_batch.signatures)
    zeros = np.zeros(3)
    for M0 in (zeros, np.broadcast_to(zeros, (3,))):  # a per-set array, and a read-only view of one
        B, ok = ja.simulate_h(P, H, form="paper", substeps=2, M0=M0)
        assert ja._simulate_batch.signatures == sigs
        assert B.tobytes() == B0.tobytes() and ok.tolist() == ok0.tolist() == [True] * 3


def test_a_read_only_lag_runs_the_kernel_of_a_writable_one():
    B = np.sin(np.linspace(0.0, 6.0, 40))[None, :].repeat(2, axis=0)
    lag = np.array([0.2, 0.5])
    out = fx.eddy_filter(B, lag)
    sigs = list(fx._eddy_rows.signatures)
    ro = fx.eddy_filter(B, np.broadcast_to(lag, (2,)))
    assert fx._eddy_rows.signatures == sigs and ro.tobytes() == out.tobytes()
    # the recursion, by hand: B_obs[j] = B[j] + lag (B_obs[j-1] - B[j])
    expect = [B[1, 0]]
    for b in B[1, 1:]:
        expect.append(b + 0.5 * (expect[-1] - b))
    assert np.array_equal(out[1], expect)


def test_one_free_coordinate_uses_the_jacobian_kernels_of_several():
    def fun(X, rows):
        return np.hstack([X - 2.0, 0.5 * (X - 2.0)])

    both = lm.least_squares_batch(fun, np.zeros((2, 2)), (-5.0, 5.0), None, max_iter=50)
    sigs = list(lm._probes.signatures), list(lm._columns.signatures)
    one = lm.least_squares_batch(fun, np.zeros((1, 2)), (-5.0, 5.0), [True, False], max_iter=50)
    assert (list(lm._probes.signatures), list(lm._columns.signatures)) == sigs
    assert np.allclose(both.x, 2.0, atol=1e-6)  # the least-squares point of X - 2 is X = 2 ...
    assert np.isclose(one.x[0, 0], 2.0, atol=1e-6) and one.x[0, 1] == 0.0  # ... on the free coordinate only
