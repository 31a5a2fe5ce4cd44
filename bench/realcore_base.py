"""Why a real core's B(H) loop keeps a gap on the flexible material base (issue 23: the Hiperco 50 misses).

For one core of the real-cores benchmark (its clean B(H) case, as `mrhyst.blind.realcores` makes it) prints the
loop's own shape (the zero crossings of B on each branch: where the loop is centred in H) and the flexible base's
RMS (`mrhyst.diagnose.everett.fit_base`, every other setting the schema's) as one thing changes at a time:
the decimation (bh_samples), the grid (layers.grid), the grid's |dB| share (layers.grid_db_share), the loop shifted
in H by the measured centre (what an odd base would need), and the RMS without the first branch (a path from an
unknown, not demagnetised state). Optionally draws the loop, the base and the residual.

    python bench/realcore_base.py [--core hiperco50_L0] [--png /tmp/base.png]
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
from pathlib import Path

import numpy as np
from mrhyst.blind import realcores
from mrhyst.data import io, loops
from mrhyst.diagnose import everett
from mrhyst.diagnose.settings import resolve_config
from mrhyst.diagnose.sweep import sweep_from_bh

SOURCES = {"hiperco50": "data/external/hiperco50-pyjam/loop.csv",
           "m130_27s": "data/external/m130-27s-jamodel/loops.csv",
           "mnzn_ferrite": "data/external/mnzn-ferrite-jamodel/loops.csv",
           "nowicki_gd": "data/external/gd-temperature-nowicki/loops.csv"}


def crossings(H, B) -> list:
    """H where B crosses zero on each monotone segment of the path."""
    out = []
    for s in loops.segments(H):
        h, b = H[s.start:s.stop + 1], B[s.start:s.stop + 1]
        for i in np.flatnonzero(np.sign(b[:-1]) * np.sign(b[1:]) < 0):
            out.append((int(s.direction), float(h[i] - b[i] * (h[i + 1] - h[i]) / (b[i + 1] - b[i]))))
    return out


def base_rms(sw, lc, shift=0.0, skip=0) -> tuple[float, float, dict]:
    s2 = dataclasses.replace(sw, current=sw.current + shift / sw.n_over_le)
    b = everett.fit_base(s2, lc)
    r = (sw.B - b["stats"]["pred"] - b["design"].fixed)[sw.valid]
    return b["stats"]["rms_T"], float(np.sqrt(np.mean(r[skip:] ** 2))), b


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--core", default="hiperco50_L0")
    ap.add_argument("--png", default=None)
    a = ap.parse_args(argv)
    rc = realcores.resolve({"sources": SOURCES, "cores": [a.core]})
    core = realcores.cores_of(rc)[0]
    cfg = resolve_config(None)
    lc0 = dict(cfg["layers"], cv_folds=cfg["cv_folds"])
    xs = crossings(core["H"], core["B"])
    up = [h for d, h in xs if d > 0][-1:]
    dn = [h for d, h in xs if d < 0][-1:]
    centre = 0.5 * (up[0] + dn[0]) if up and dn else 0.0
    print(f"{a.core}: B = 0 at H = {', '.join(f'{h:+.2f}' for _, h in xs)} A/m; loop centred at {centre:+.2f} A/m")
    with tempfile.TemporaryDirectory() as tmp:
        for n in (128, 256):
            df, _ = realcores.bh_case(core, None, 0.0, 1.0, dict(rc, bh_samples=n))
            io.write_csv(df, Path(tmp) / f"c{n}.csv")
            sw = sweep_from_bh(Path(tmp) / f"c{n}.csv", None, cfg)
            skip = loops.segments(sw.current[sw.valid])[0].stop  # the first branch (to the first tip)
            for grid, share in ((10, 0.5), (10, lc0["grid_db_share"]), (16, lc0["grid_db_share"])):
                lc = dict(lc0, grid=grid, grid_db_share=share)
                for shift in (0.0, -centre):
                    rms, rest, b = base_rms(sw, lc, shift, skip)
                    print(f"  {n} samples, grid {grid}, |dB| share {share}, H shifted {shift:+.2f} A/m: base RMS "
                          f"{rms * 1e3:.1f} mT ({rest * 1e3:.1f} mT without the first branch)")
            if a.png and n == 128:
                draw(sw, base_rms(sw, lc0)[2], a.png)
    return 0


def draw(sw, b, png):
    import matplotlib

    matplotlib.use("agg")
    import matplotlib.pyplot as plt

    v = sw.valid
    H = sw.n_over_le * sw.current
    p = b["stats"]["pred"] + b["design"].fixed
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
    ax[0].plot(H[v], sw.B[v], "k.", ms=3, label="loop")
    ax[0].plot(H[v], p[v], "r-", lw=0.8, label="flexible base")
    ax[0].set_xlabel("H (A/m)")
    ax[0].set_ylabel("B (T)")
    ax[0].legend()
    ax[1].plot(H[v], (sw.B - p)[v] * 1e3, ".")
    ax[1].set_xlabel("H (A/m)")
    ax[1].set_ylabel("residual (mT)")
    fig.savefig(png, dpi=80)


if __name__ == "__main__":
    raise SystemExit(main())
