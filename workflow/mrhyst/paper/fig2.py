"""Forward simulations the workflow and the CLI need (Fig. 2, any current path)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from mrhyst.data.io import branches
from mrhyst.model import ja


def fig2_current_path(i_max: float = 2.0, di: float = 0.01) -> np.ndarray:
    """Fig. 2 excitation (the paper does not state it; config fig2 says so):
    virgin curve 0 -> +i_max, then one full cycle +i_max -> -i_max -> +i_max, in steps of di."""
    n = int(round(i_max / di))
    if n < 1 or not np.isclose(n * di, i_max):
        raise ValueError(f"fig2: i_max ({i_max}) must be a whole multiple of di ({di})")
    up = np.linspace(0.0, i_max, n + 1)
    down = np.linspace(i_max, -i_max, 2 * n + 1)[1:]
    back = np.linspace(-i_max, i_max, 2 * n + 1)[1:]
    return np.concatenate([up, down, back])


def loop_frame(current_A, n_over_le: float, B_T) -> pd.DataFrame:
    """A loop-format table (ARCHITECTURE 4) for a simulated path."""
    current_A = np.asarray(current_A, dtype=float)
    return pd.DataFrame({
        "step": np.arange(current_A.size),
        "current_A": current_A,
        "H_A_per_m": current_A * n_over_le,
        "B_T": np.asarray(B_T, dtype=float),
        "branch": branches(current_A),
    })


def fig2_loop(config: dict, n_over_le: float) -> pd.DataFrame:
    """The Fig. 2 loop in the configured J-A form, with the other form beside it (B_<form>_T)."""
    f2 = config["fig2"]
    p = ja.as_param_array(config["paper"]["fig2_params"])
    current = fig2_current_path(f2["i_max_A"], f2["di_A"])
    kw = dict(substeps=int(f2["substeps"]), dman=config["ja"]["dman"])
    form = config["ja"]["form"]
    B, ok = ja.simulate(p, current, n_over_le, form=form, **kw)
    if not ok:
        raise RuntimeError("Fig. 2 parameter set failed to integrate")
    df = loop_frame(current, n_over_le, B)
    for other in ja.FORMS:
        Bo, _ = ja.simulate(p, current, n_over_le, form=other, **kw)
        df[f"B_{other}_T"] = Bo
    return df
