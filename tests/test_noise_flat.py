"""The integration tolerance's noise floor on a loop held at one value over runs of samples (a clip).

fit/accuracy.noise_floor used to return 0 when most second differences of B are exactly 0 (a sensor clipped at
80 % of a loop's peak), so the RK4 tolerance fell to its absolute fallback (1e-6 T) and the substep count rose
from ~8 to 68 (the real-cores case of a clipped Gd loop: 23 CPU s of materials search instead of 2.5). The
expected sigma here is the one the loop was drawn with, not a recomputation of the estimator."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from mrhyst.fit import accuracy

SIGMA = 1e-3  # T


def noisy_loop(seed: int, n: int = 400):
    """A smooth closed loop (two tanh branches, 1.5 T peak) along +Hmax -> -Hmax -> +Hmax with white noise."""
    h = np.linspace(1.0, -1.0, n)
    H = np.concatenate([h, -h[1:]]) * 1000.0
    Bup = 1.5 * np.tanh(3 * (H[n - 1:] / 1000.0 + 0.1))
    Bdown = 1.5 * np.tanh(3 * (H[:n] / 1000.0 - 0.1))
    B = np.concatenate([Bdown, Bup[1:]]) + np.random.default_rng(seed).normal(0.0, SIGMA, 2 * n - 1)
    return H, B


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), frac=st.floats(0.5, 0.9))
def test_clipped_loop_keeps_its_noise_floor(seed, frac):
    H, B = noisy_loop(seed)
    lim = frac * float(np.max(np.abs(B)))
    Bc = np.clip(B, -lim, lim)
    assert np.mean(np.diff(Bc) == 0) > 0.3  # most of the loop is held at the limit
    s = accuracy.noise_floor(H, Bc, None, None, 3.5)
    assert 0.7 * SIGMA < s < 1.5 * SIGMA


def test_unclipped_loop_unchanged_and_right():
    H, B = noisy_loop(7)
    s = accuracy.noise_floor(H, B, None, None, 3.5)
    assert 0.8 * SIGMA < s < 1.25 * SIGMA


def test_a_loop_flat_everywhere_has_no_noise_floor():
    H, _ = noisy_loop(0)
    assert accuracy.noise_floor(H, np.full(H.size, 0.3), None, None, 3.5) == 0.0
