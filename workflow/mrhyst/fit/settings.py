"""Constants of the identification and its config sections (defaults: the config schema)."""

from __future__ import annotations

import copy
from pathlib import Path

from mrhyst.config import load_config
from mrhyst.config import resolve as config_resolve
from mrhyst.model import ja

MU0 = ja.MU0
JA_NAMES = ja.PARAM_NAMES  # ("Ms", "a", "alpha", "c", "k")
M0_NAME = "m0"  # fitted initial magnetisation M0 / Ms (start="fit")
METHODS = ("pso", "lsm")
START_STATES = ("demagnetised", "first_sample", "fit", "cyclic")
BH_STRATEGIES = ("nearest", "reflective")  # pyswarms' default "periodic" would wrap c ~ 1 to c ~ 0

SECTIONS = ("ja", "pso", "lsm", "identifiability", "metrics")  # the config sections identify reads


def resolve_config(config=None) -> dict:
    """The sections ja, pso, lsm, identifiability, metrics: their defaults (the config schema's, the one
    place they live: mrhyst.config.defaults) overridden by a config mapping or a config.yaml path (a path
    is checked: a bad file is one ConfigError line); with a config, also its ``paper`` section."""
    if isinstance(config, (str, Path)):
        config = load_config(config)
    out = config_resolve(config, SECTIONS)
    if config is not None:
        out["paper"] = copy.deepcopy(config.get("paper", {}))
    return out
