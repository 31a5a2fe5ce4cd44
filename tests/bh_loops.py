"""Small third-party-style B(H) loop files for tests: a known J-A material on a bipolar H path, with noise."""

from __future__ import annotations

import numpy as np
from mrhyst.model import ja

PARAMS = [1.2e6, 60.0, 1e-4, 0.2, 80.0]  # Ms, a, alpha, c, k: a soft material that closes its loop at 400 A/m


def write_ja_loop(path, seed: int) -> np.ndarray:
    """Write ``H_A_per_m,B_T`` (0 -> +400 -> -400 -> +400 A/m, 16 points a quarter, 0.2 mT noise) to ``path``;
    return H."""
    q = np.linspace(0.0, 1.0, 16)
    H = 400.0 * np.concatenate([q, q[::-1][1:], -q[1:], -q[::-1][1:], q[1:]])
    B, ok = ja.simulate_h(PARAMS, H, form="physical", substeps=8)
    assert ok
    B = B + 2e-4 * np.random.default_rng(seed).standard_normal(H.size)
    path.write_text("H_A_per_m,B_T\n" + "".join(f"{float(h)!r},{float(b)!r}\n" for h, b in zip(H, B)))
    return H
