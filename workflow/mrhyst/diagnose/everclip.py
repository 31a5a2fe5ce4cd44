"""A clip's increment on the flexible base (:mod:`.everett`): at a declared output limit, between the declared
rails, its flagged samples censored readings; else at a flat extreme of the data, on one rail or both. Called by
:func:`mrhyst.diagnose.everett.increment` for ``sensor_saturation``."""

from __future__ import annotations

import numpy as np

from mrhyst.diagnose.everett import Model
from mrhyst.diagnose.sweep import Sweep


def _kinked(sigs, cens, first: int) -> bool:
    """A ``flat_kink`` signature (B flatter than a material can be, with a kink: :mod:`.signatures`) on one of the
    ``cens`` samples (signature samples count from the sweep's first measured sample, ``first``)."""
    at = set((np.flatnonzero(cens) - first).tolist())
    return any(s.get("kind") == "flat_kink" and at & set(s.get("samples") or ()) for s in sigs or ())


def _rails(B, rows, tol: float, min_flat: int):
    """(clip, level, censored samples) of a loop flat at its extreme B on one rail or both (at least ``min_flat``
    samples within ``tol`` of that extreme), or None: the clip (lo, hi) is infinite on a rail that is not flat
    (a channel that saturates on one side: an integrator's or an ADC's), the level the smaller |B| of a flat
    rail. Measured: bench/heldout_realcores.py, B(H) loops clipped on one rail at 80-95 % of that tip, 0 of 18
    named when the clip was symmetric at the extreme |B| (the other, unclipped tip)."""
    lim, cens, levels = [-np.inf, np.inf], np.zeros(B.size, dtype=bool), []
    for k, sign in ((1, 1.0), (0, -1.0)):
        ext = float(np.max(sign * B[rows]))
        at = rows & (sign * B >= ext - tol)
        if ext > 0 and int(at.sum()) >= min_flat:
            lim[k], cens, levels = sign * ext, cens | at, [*levels, ext]
    return (tuple(lim), min(levels), cens) if levels else None


def clip(base: dict, sw: Sweep, cfg: dict, sigs=None, size_only: bool = False) -> dict | None:
    """A symmetric clip: at a declared output limit where the sweep has samples flagged there (compared on all
    samples, the flagged ones included as data), else at the data's extreme |B| when at least ``min_flat``
    samples sit exactly there (a flat top no core makes: its B still rises with H), on one rail or both
    (:func:`_rails`). Where the sweep's own
    ``flat_kink`` signature marks those samples (flatter than mu0 H allows, with a kink), they are compared as at
    a declared limit (``kink``): the base fitted without them, extrapolated there, against the clip; without
    it the base fitted to every sample may bend to follow the flat top (measured: a Hiperco 50 loop clipped at
    95 % of its peak, kink 18-19 sigma, gained 6 BIC on a base that leaves 29 mT elsewhere)."""
    ev, m, lam, rows = base["design"], base["model"], base["lam"], base["rows"]
    flagged = ~sw.valid & (np.arange(sw.n) >= sw.start)
    info = sw.sensor_info
    kink = False
    if flagged.any() and info.get("sensitivity_V_per_T") and info.get("quiescent_V") is not None:
        s, q = float(info["sensitivity_V_per_T"]), float(info["quiescent_V"])
        lims = [abs((float(info[k]) - q) / s) for k in ("output_min_V", "output_max_V") if info.get(k) is not None]
        if not lims:
            return None
        # the rails in B, each where it is declared (the A1304's 0.2 / 3.1 V about 1.65 V are symmetric; a sensor
        # whose quiescent output is off centre is not): a symmetric clip at the nearer rail cut the far half of a
        # bipolar loop, whose samples there were read inside their limit (2026-11-27: 13.9 mT left on a probe's loop)
        rail = sorted((float(info[k]) - q) / s for k in ("output_min_V", "output_max_V") if info.get(k) is not None)
        lim = (rail[0] if rail[0] < 0 else -np.inf, rail[-1] if rail[-1] > 0 else np.inf)
        c, cens, rows_all, declared = min(lims), flagged, rows | flagged, True
    else:
        c = float(np.max(np.abs(sw.B[rows])))
        tol = 1e-9 * c + (float(cfg["adc_lsb_V"]) / abs(float(info["sensitivity_V_per_T"]))
                          if info.get("sensitivity_V_per_T") else 0.0)
        flat = _rails(sw.B, rows, tol, int(cfg["min_flat"]))
        if flat is None:
            return None
        lim, c, cens = flat
        rows_all, declared = rows, False
        kink = _kinked(sigs, cens, int(sw.start))
    if size_only:
        return {"size": c}
    K = int(cfg["cv_folds"])
    fold = np.where(rows_all, (np.cumsum(rows_all) - 1) % K, -1)
    # a declared limit (or a flat kink): the same fit (to the samples inside it) with and without the clip at the
    # flagged ones; a flat top: the base fitted to every sample, which may bend to follow it, against the clip
    plain = Model(m.X, m.y, m.D, cens=cens if declared or kink else None).stats(rows_all, lam, fold)
    st = Model(m.X, m.y, m.D, clip=lim, cens=cens, fixed=ev.fixed).stats(rows_all, lam, fold)
    return {"stats": st, "size": c, "base_stats": plain, "declared": declared, "n_at_clip": int(cens.sum()),
            "kink": kink, "compared": rows_all}
