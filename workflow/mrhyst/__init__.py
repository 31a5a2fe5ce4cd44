"""mrhyst: Jiles-Atherton hysteresis of MR-damper Hall sweeps (Li & Gong 2019), reproduced and diagnosed."""

__version__ = "0.1.0"
