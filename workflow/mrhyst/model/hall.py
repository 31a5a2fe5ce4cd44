"""Hall sensor chain: voltage <-> flux density (Allegro A1304ELHLX-05-T).

The A1304 is a linear, ratiometric Hall sensor: at supply Vcc its quiescent
output (B = 0) is Vcc/2 and its sensitivity is 0.5 mV/G = 5 V/T for the -05
variant. The paper (Testing section) converts the voltage "according to the
static output voltage and sensitivity coefficient", i.e.

    B = (V - Vq) / S                                  (linear transfer)

Samples at the limits of the linear output (sidecar ``output_min_V`` /
``output_max_V``) are *saturated*: they are real data, kept and flagged, never
used as a valid B.
"""

from __future__ import annotations

import numpy as np

A1304_SENSITIVITY_V_PER_T = 5.0  # 0.5 mV/G
A1304_SUPPLY_V = 3.3


def quiescent_voltage(supply_V: float, quiescent_V: float | None = None, supply_min_V: float = 0.0) -> float:
    """Vq: the sidecar's value, else the rails' midpoint (ratiometric): Vcc/2 on a single supply."""
    if quiescent_V is not None:
        return float(quiescent_V)
    return float(supply_V) / 2.0 if not supply_min_V else (float(supply_min_V) + float(supply_V)) / 2.0


def volts_to_tesla(V, sensitivity_V_per_T: float, quiescent_V: float):
    """B = (V - Vq) / S; S < 0 for a sensor that faces the field the other way round (its output falls as B
    rises): declared so, its B has the core's sign."""
    if not (np.isfinite(sensitivity_V_per_T) and sensitivity_V_per_T != 0):
        raise ValueError(f"sensitivity must be a non-zero number of V/T, got {sensitivity_V_per_T}")
    with np.errstate(over="ignore"):  # a subnormal S: B overflows to inf, refused by the reader's |B| bound
        return (np.asarray(V, dtype=float) - quiescent_V) / sensitivity_V_per_T


def tesla_to_volts(B, sensitivity_V_per_T: float, quiescent_V: float):
    """V = Vq + S B (the ideal sensor; the rig adds noise, limits and the ADC)."""
    return quiescent_V + sensitivity_V_per_T * np.asarray(B, dtype=float)


def reading_step(V) -> float:
    """The channel's reading resolution: the smallest positive difference between two of its distinct finite
    readings (an ADC's step, or a multiple of it, when the readings are quantised; ~0 when they are not)."""
    u = np.unique(np.asarray(V, dtype=float)[np.isfinite(V)])
    d = np.diff(u)
    return float(np.min(d)) if d.size else 0.0


def limit_as_read(V, limit: float, tol: float) -> float:
    """A declared output limit as the channel reads it: the reading nearest to ``limit`` when one is closer than
    ``tol`` (a sample stuck at the rail reads as the ADC code nearest to it, up to one step either side of the
    declared value), else ``limit``."""
    V = np.asarray(V, dtype=float)
    near = V[np.abs(V - limit) < tol]
    return float(near[np.argmin(np.abs(near - limit))]) if near.size else float(limit)


def saturated_mask(V, output_min_V: float | None, output_max_V: float | None, tol_V: float | None = None):
    """True where a sample sits at (or beyond) a limit of the linear output: at or beyond the declared limit or
    its reading (:func:`limit_as_read`, within ``tol_V``; None: the channel's :func:`reading_step`). A lab
    declares its sensor's rail (say 4.75 V) and its ADC reads a sample stuck there as the nearest code, which
    can lie below the declared value (measured: bench/heldout_realcores.py, a 10-12-bit ADC rounding the rail
    down by 0.2-2.4 mV: 13 clipped sweeps with no sample flagged before)."""
    V = np.asarray(V, dtype=float)
    tol = reading_step(V) if tol_V is None else float(tol_V)
    mask = np.zeros(V.shape, dtype=bool)
    if output_min_V is not None:
        mask |= V <= max(float(output_min_V), limit_as_read(V, output_min_V, tol))
    if output_max_V is not None:
        mask |= V >= min(float(output_max_V), limit_as_read(V, output_max_V, tol))
    return mask
