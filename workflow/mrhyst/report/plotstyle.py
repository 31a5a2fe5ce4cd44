"""One place for how figures say where their data come from (issue 14, point 3).

Every figure drawn from the virtual test rig (mrhyst.rig) must say so on the image itself, so that a PNG
taken out of the report cannot pass for a measurement: the data's legend entry is :data:`RIG_LABEL`
(via :func:`data_label`) and :func:`mark_synthetic` writes a mark in the lower-right corner of the figure.
Whether a sweep is synthetic is read from its sidecar's ``provenance`` field (the rig writes
"SYNTHETIC - ..."), never assumed: a real sweep dropped into data/raw/ is drawn as "measured".
Used by notebooks/fig06, fig08, diagnosis and blind (plotting only, no Snakemake).
"""

from __future__ import annotations

import json
from pathlib import Path

RIG_LABEL = "rig (synthetic)"
MEASURED_LABEL = "measured"
MARK_TEXT = "SYNTHETIC DATA: mrhyst virtual test rig, not a measurement"


def sidecar_synthetic(path) -> bool:
    """True when the raw sweep's sidecar (``NAME.json``, or the JSON itself; ``NAME.csv`` is mapped to its
    sidecar) states a synthetic provenance. A missing sidecar or field counts as not synthetic."""
    p = Path(path)
    if p.suffix.lower() != ".json":
        p = p.with_suffix(".json")
    try:
        side = json.loads(p.read_text())
    except (OSError, ValueError):
        return False
    return isinstance(side, dict) and "SYNTHETIC" in str(side.get("provenance", "")).upper()


def data_label(synthetic: bool, what: str = "") -> str:
    """Legend entry of the data points: 'rig (synthetic)' or 'measured'; with ``what`` (e.g. 'Hall'):
    'rig (synthetic, Hall)' or 'measured (Hall)'."""
    if synthetic:
        return f"rig (synthetic, {what})" if what else RIG_LABEL
    return f"{MEASURED_LABEL} ({what})" if what else MEASURED_LABEL


def _add_bottom_strip(fig, pad_in: float) -> None:
    """Make the figure ``pad_in`` inches taller at the bottom, keeping every axes and figure text where it
    was relative to the top (call after tight_layout), so that a mark there covers nothing."""
    h = fig.get_figheight()
    H = h + pad_in
    fig.set_figheight(H)

    def y(v):
        return (v * h + pad_in) / H

    for ax in fig.axes:
        b = ax.get_position()
        ax.set_position([b.x0, y(b.y0), b.width, b.height * h / H])
    texts = list(fig.texts) + [t for t in (getattr(fig, "_suptitle", None),) if t is not None]
    for t in texts:
        x0, y0 = t.get_position()
        t.set_position((x0, y(y0)))


def mark_synthetic(fig, synthetic: bool = True, text: str = MARK_TEXT, pad_in: float = 0.22):
    """Write the synthetic-data mark into the lower-right corner of ``fig``, in a strip of ``pad_in`` inches
    added below everything (call after tight_layout); nothing when ``synthetic`` is False. Returns the Text
    artist or None."""
    if not synthetic:
        return None
    _add_bottom_strip(fig, pad_in)
    return fig.text(0.995, 0.004, text, ha="right", va="bottom", fontsize=7, color="#b00000", zorder=10,
                    bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": "#b00000", "lw": 0.7, "alpha": 0.9})
