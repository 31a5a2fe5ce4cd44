"""The diagnosis's settings (:class:`DiagnoseSettings`): the config ``diagnose:`` section resolved once over the
schema's defaults (workflow/mrhyst/schemas/config.schema.yaml, the one place they live), frozen and checked
(:mod:`mrhyst.settings`). The command line's flags (``--form``, ``--seed``) override the section."""

from __future__ import annotations

from mrhyst import config as _config
from mrhyst.data.io import InputError
from mrhyst.settings import section_class

DiagnoseSettings = section_class(
    "diagnose", "DiagnoseSettings",
    "Every setting of one diagnosis (config section ``diagnose``), frozen: what ran, and what DIAG.json records.")


def defaults() -> dict:
    """A fresh copy of every diagnose setting's default (from workflow/mrhyst/schemas/config.schema.yaml)."""
    return _config.defaults("diagnose")


def resolve_config(config=None, *, form: str | None = None, seed: int | None = None) -> DiagnoseSettings:
    """The :class:`DiagnoseSettings` that run: ``form`` and ``seed`` where given (not None: a flag) > ``config``
    (the ``diagnose:`` section, or settings already resolved) > the schema's defaults. An unknown key ->
    InputError; a bad value -> ConfigError (one line each)."""
    if not isinstance(config, DiagnoseSettings):
        known = defaults()
        unknown = sorted(set(config or {}) - set(known))
        if unknown:
            raise InputError(f"diagnose config: unknown key {unknown[0]!r} (known: {', '.join(sorted(known))})")
    return DiagnoseSettings.resolve(config, form=form, seed=seed)
