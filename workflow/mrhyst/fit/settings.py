"""Constants of the identification and its settings (:class:`FitSettings`: the config sections ja, pso, lsm,
identifiability, metrics resolved once over the schema's defaults, frozen and checked; mrhyst.settings)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path

from mrhyst.config import load_config
from mrhyst.config import resolve as config_resolve
from mrhyst.model import ja
from mrhyst.settings import freeze, section_class, thaw

MU0 = ja.MU0
JA_NAMES = ja.PARAM_NAMES  # ("Ms", "a", "alpha", "c", "k")
M0_NAME = "m0"  # fitted initial magnetisation M0 / Ms (start="fit")
METHODS = ("pso", "lsm")
START_STATES = ("demagnetised", "first_sample", "fit", "cyclic")
BH_STRATEGIES = ("nearest", "reflective")  # pyswarms' default "periodic" would wrap c ~ 1 to c ~ 0

SECTIONS = ("ja", "pso", "lsm", "identifiability", "metrics")  # the config sections identify reads

JaSettings = section_class("ja", "JaSettings", "Config section ``ja``: the J-A model of every fit, frozen.")
PsoSettings = section_class("pso", "PsoSettings", "Config section ``pso``: the swarm, its settings and box, frozen.")
LsmSettings = section_class("lsm", "LsmSettings", "Config section ``lsm``: scipy least_squares, frozen.")
IdentifiabilitySettings = section_class("identifiability", "IdentifiabilitySettings",
                                        "Config section ``identifiability``: the profiles, frozen.")
MetricsSettings = section_class("metrics", "MetricsSettings", "Config section ``metrics``: Table 2-3 measures.")
_CLASSES = {"ja": JaSettings, "pso": PsoSettings, "lsm": LsmSettings, "identifiability": IdentifiabilitySettings,
            "metrics": MetricsSettings}


@dataclasses.dataclass(frozen=True)
class FitSettings(Mapping):
    """Every setting a fit reads, frozen (read by attribute or as a read-only mapping, ``s["pso"]["seeds"]``);
    ``paper``: the config's paper section (Table 1 boxes), None without a config."""

    ja: JaSettings
    pso: PsoSettings
    lsm: LsmSettings
    identifiability: IdentifiabilitySettings
    metrics: MetricsSettings
    paper: Mapping | None = None

    def __post_init__(self):
        for name, cls in _CLASSES.items():
            if not isinstance(getattr(self, name), cls):
                raise TypeError(f"FitSettings.{name} must be {cls.__name__}")
        if self.paper is not None:
            object.__setattr__(self, "paper", freeze(self.paper))

    def __getitem__(self, key):
        if key not in self.__dataclass_fields__ or (key == "paper" and self.paper is None):
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self):
        return iter([k for k in self.__dataclass_fields__ if not (k == "paper" and self.paper is None)])

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def as_dict(self) -> dict:
        return {k: thaw(v) for k, v in self.items()}

    def __reduce__(self):  # pickle and deepcopy: the sections pickle themselves, paper as plain data
        return FitSettings, tuple(getattr(self, k) for k in _CLASSES) + (thaw(self.paper),)

    def replace(self, **sections) -> FitSettings:
        """A copy with some sections changed: ``replace(ja={"form": "paper"})`` merges into section ja."""
        new = {k: _CLASSES[k].resolve(getattr(self, k), **v) if k in _CLASSES else v for k, v in sections.items()}
        return dataclasses.replace(self, **new)


def resolve_config(config=None) -> FitSettings:
    """The sections ja, pso, lsm, identifiability, metrics: their defaults (the config schema's, the one
    place they live: mrhyst.config.defaults) overridden by a config mapping or a config.yaml path (a path
    is checked: a bad file is one ConfigError line); with a config, also its ``paper`` section. Settings already
    resolved are returned as they are."""
    if isinstance(config, FitSettings):
        return config
    if isinstance(config, (str, Path)):
        config = load_config(config)
    out = config_resolve(config, SECTIONS)
    paper = None if config is None else thaw(config.get("paper", {}))
    return FitSettings(**{k: _CLASSES[k](**v) for k, v in out.items()}, paper=paper)
