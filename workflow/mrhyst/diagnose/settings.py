"""The diagnosis's settings: defaults from the config schema (the one place they live), overridden by a
config ``diagnose:`` section key by key (nested mappings merged one level deep)."""

from __future__ import annotations

import copy
import functools

import yaml

from ..config import SCHEMA_PATH
from ..io import InputError


@functools.lru_cache(maxsize=1)
def _defaults() -> dict:
    schema = yaml.safe_load(SCHEMA_PATH.read_text())
    props = schema["properties"]["diagnose"]["properties"]
    missing = [k for k, p in props.items() if "default" not in p]
    if missing:
        raise RuntimeError(f"{SCHEMA_PATH}: diagnose.{missing[0]} has no default")
    return {k: p["default"] for k, p in props.items()}


def defaults() -> dict:
    """A fresh copy of every diagnose setting's default (from workflow/schemas/config.schema.yaml)."""
    return copy.deepcopy(_defaults())


def resolve_config(config: dict | None = None) -> dict:
    """The defaults overridden key by key by ``config`` (the `diagnose:` section); unknown key -> InputError."""
    cfg = defaults()
    for k, v in (config or {}).items():
        if k not in cfg:
            raise InputError(f"diagnose config: unknown key {k!r} (known: {', '.join(sorted(cfg))})")
        if isinstance(v, dict) and isinstance(cfg[k], dict):
            cfg[k].update(copy.deepcopy(v))
        else:
            cfg[k] = copy.deepcopy(v)
    return cfg
