"""The blind benchmark's settings (:class:`BlindSettings`): config section ``blind`` resolved once over the schema's
defaults (workflow/mrhyst/schemas/config.schema.yaml), frozen and checked (:mod:`mrhyst.settings`). ``mrhyst blind
generate --seed/--n-per-class`` override ``blind.seed/n_per_class``; the rule scripts pass the section."""

from __future__ import annotations

import dataclasses

from mrhyst import config as _config
from mrhyst.settings import freeze, section_class


class BlindSettings(section_class("blind", "BlindSettings")):
    """Every setting of one blind benchmark (config section ``blind``), frozen: what its key and score record.

    Checked against the schema when made, but for a class the effect registry knows and the schema's enum of
    classes does not (an effect registered at run time, e.g. a test's toy: the registry is the owner of the
    vocabulary, issue 22 item 3): such a class is checked by the registry (:func:`mrhyst.blind.cases.class_kind`
    when the cases are drawn), not by the schema's list."""

    def __post_init__(self):
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, freeze(getattr(self, f.name)))
        data = self.as_dict()
        extra = [c for c in data.get("classes") or () if _registry_only(c)]
        if extra:  # the schema's view: the registry's own classes left out (they are checked there)
            data["classes"] = [c for c in data["classes"] if c not in extra] or ["none"]
            data["counts"] = {k: v for k, v in (data.get("counts") or {}).items() if k not in extra}
        _config.check_section("blind", data, "blind settings")
        _config._check_semantics({"blind": data}, "blind settings")

    def __reduce__(self):  # pickle and deepcopy rebuild this class (not the base the schema made)
        return _rebuild, (self.as_dict(),)


def _rebuild(data: dict) -> BlindSettings:
    return BlindSettings(**data)


def _registry_only(cls: str) -> bool:
    """A class of effects the registry knows, at least one of them unknown to the schema's enum of classes."""
    from mrhyst.model import effects as fx

    enum = set(_config._schema()["$defs"]["blindclass"]["anyOf"][0]["enum"])
    parts = str(cls).split("+")
    return cls not in enum and all(p in fx.REGISTRY for p in parts) and any(p not in enum for p in parts)

# the workflow's, not a benchmark's: its key and its score never record them (a change of the job split or of
# another benchmark's variant changes no benchmark's bytes)
WORKFLOW_KEYS = ("cases_per_job", "key_jobs", "variants")


def blind_settings(config=None, **flags) -> BlindSettings:
    """:class:`BlindSettings` from the ``blind:`` section (or settings already resolved): ``flags`` given (not
    None) > ``config`` > the schema's defaults. A bad value or a missing required key: one ConfigError line."""
    return BlindSettings.resolve(config, **flags)


def recorded(s: BlindSettings) -> dict:
    """What a key or a score records of the settings that ran (plain data, keys sorted)."""
    return {k: v for k, v in sorted(s.as_dict().items()) if k not in WORKFLOW_KEYS}
