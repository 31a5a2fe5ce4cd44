"""The diagnosis's settings: defaults from the config schema (the one place they live, read by
:func:`mrhyst.config.defaults` like every other section), overridden by a config ``diagnose:`` section."""

from __future__ import annotations

from mrhyst import config as _config
from mrhyst.data.io import InputError


def defaults() -> dict:
    """A fresh copy of every diagnose setting's default (from workflow/mrhyst/schemas/config.schema.yaml)."""
    return _config.defaults("diagnose")


def resolve_config(config: dict | None = None) -> dict:
    """The defaults with ``config`` (the `diagnose:` section) deep-merged over them; an unknown key ->
    InputError (a diagnose section given to the API or the CLI is not always checked against the schema)."""
    known = defaults()
    unknown = sorted(set(config or {}) - set(known))
    if unknown:
        raise InputError(f"diagnose config: unknown key {unknown[0]!r} (known: {', '.join(sorted(known))})")
    return _config.resolve({"diagnose": dict(config or {})}, ["diagnose"])["diagnose"]
