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


def quiescent_voltage(supply_V: float, quiescent_V: float | None = None) -> float:
    """Vq: the sidecar's value, else Vcc/2 (ratiometric)."""
    return float(quiescent_V) if quiescent_V is not None else float(supply_V) / 2.0


def volts_to_tesla(V, sensitivity_V_per_T: float, quiescent_V: float):
    """B = (V - Vq) / S."""
    if not sensitivity_V_per_T > 0:
        raise ValueError(f"sensitivity must be > 0 V/T, got {sensitivity_V_per_T}")
    return (np.asarray(V, dtype=float) - quiescent_V) / sensitivity_V_per_T


def tesla_to_volts(B, sensitivity_V_per_T: float, quiescent_V: float):
    """V = Vq + S B (the ideal sensor; the rig adds noise, limits and the ADC)."""
    return quiescent_V + sensitivity_V_per_T * np.asarray(B, dtype=float)


def saturated_mask(V, output_min_V: float | None, output_max_V: float | None, tol_V: float = 0.0):
    """True where a sample sits at (or beyond) a limit of the linear output."""
    V = np.asarray(V, dtype=float)
    mask = np.zeros(V.shape, dtype=bool)
    if output_min_V is not None:
        mask |= V <= output_min_V + tol_V
    if output_max_V is not None:
        mask |= V >= output_max_V - tol_V
    return mask
