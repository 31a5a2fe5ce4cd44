"""The settings of a fit of third-party loops (config section ``external``) and of one measured loop's fit (the fit's
sections plus ``external``), frozen (:mod:`mrhyst.settings`): resolved once, at the boundary (``mrhyst fit`` /
``diagnose --config``, the rules external_fit, external_diagnose, realcores_diagnose), recorded where they ran."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from mrhyst.config import ConfigError, check_section, load_config
from mrhyst.fit import identify
from mrhyst.fit.settings import FitSettings
from mrhyst.settings import section_class

ExternalSettings = section_class("external", "ExternalSettings",
                                 "Config section ``external``: the fits of third-party loops, frozen.")


def external_config(config, source: str = "config.yaml") -> ExternalSettings:
    """The ``external:`` section of ``config`` (a config mapping, or settings already resolved: returned as they
    are) checked against its part of the config schema (unknown keys, types and ranges: one :class:`ConfigError`
    line naming the key, as :func:`mrhyst.config.check_config`), merged over the schema's defaults (the one place
    they live) and frozen."""
    if isinstance(config, ExternalSettings):
        return config
    sec = (config or {}).get("external") or {}
    check_section("external", sec, source)
    for name, s in (sec.get("sources") or {}).items():  # a check the schema cannot state: the code's models
        for m in s.get("joint_models", []) + ([s["joint_model"]] if "joint_model" in s else []):
            if m not in identify.model_choices():
                raise ConfigError(f"{source}: external.sources.{name}.joint_models: {m!r} is not a J-A model "
                                  f"({', '.join(identify.model_choices())})")
    return ExternalSettings.resolve(sec)


@dataclasses.dataclass(frozen=True)
class LoopFitSettings:
    """Every setting one measured loop's fit (:func:`fit_path`) reads, frozen: the fit's sections (``fit``: ja,
    pso, lsm, ...) and ``external``. A B(H) diagnosis fits its material with these (``mrhyst diagnose --config``:
    the file's, not the schema's) and records them (:meth:`as_dict`)."""

    fit: FitSettings
    external: ExternalSettings

    def as_dict(self) -> dict:
        """What a diagnosis records: the sections the loop's fit reads (external without its per-source table)."""
        ext = {k: v for k, v in self.external.as_dict().items() if k not in ("sources", "peers")}
        return {"ja": self.fit.ja.as_dict(), "pso": self.fit.pso.as_dict(), "lsm": self.fit.lsm.as_dict(),
                "external": ext}


def loop_fit_settings(config=None, source: str = "config.yaml") -> LoopFitSettings:
    """:class:`LoopFitSettings` from a config mapping (sections ja, pso, lsm, external; those left out: the
    schema's) or a config.yaml path; settings already resolved are returned as they are."""
    if isinstance(config, LoopFitSettings):
        return config
    if isinstance(config, (str, Path)):
        source, config = str(config), load_config(config)
    return LoopFitSettings(identify.resolve_config(config), external_config(config, source))
