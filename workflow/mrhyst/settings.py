"""Frozen, typed, self-validating settings: one config section resolved once, read by the package.

The order is fixed at the boundary (``mrhyst`` commands and the rule scripts): a flag given on the command
line > the ``--config`` file (or the workflow's config) > the schema's default (workflow/mrhyst/schemas/
config.schema.yaml, the one place of every default). :func:`mrhyst.config.resolve` merges the last two; a
:class:`Section` freezes the result, checks it against its part of the schema (and the semantic checks of
:mod:`mrhyst.config`) when it is made, and is what the package reads, by attribute (``s.bic_margin``) or
as a read-only mapping (``s["bic_margin"]``, so code written for the plain dicts reads it unchanged).

A section's fields are its schema's properties, typed from their schema types (integer -> int, number ->
float, boolean -> bool, enum -> str, object -> Mapping, array -> tuple): a key added to the schema is a field,
without a second list of names to keep in step. Nested objects are read-only mappings and lists are tuples, so
nothing downstream can change a setting after it was recorded. :meth:`Section.as_dict` gives the plain data
back (what an output records: the settings that ran).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any, ClassVar

from mrhyst import config as _config


def freeze(value):
    """Plain config data -> read-only: dicts -> MappingProxyType (of frozen values), lists -> tuples."""
    if isinstance(value, Mapping):
        return MappingProxyType({k: freeze(v) for k, v in value.items()})
    if isinstance(value, (list, tuple)):
        return tuple(freeze(v) for v in value)
    return value


def thaw(value):
    """The inverse of :func:`freeze`: plain dicts and lists (JSON- and YAML-ready)."""
    if isinstance(value, Mapping):
        return {k: thaw(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [thaw(v) for v in value]
    return value


class Section(Mapping):
    """Base of a section's settings (a frozen dataclass made by :func:`section_class`)."""

    section: ClassVar[str] = ""
    optional: ClassVar[frozenset] = frozenset()  # fields without a schema default: left out of as_dict when None

    def __post_init__(self):
        for f in dataclasses.fields(self):  # whatever was given, held read-only
            object.__setattr__(self, f.name, freeze(getattr(self, f.name)))
        data = self.as_dict()
        if not _config.is_default(self.section, data):
            _config.check_section(self.section, data, f"{self.section} settings")
        _config._check_semantics({self.section: data}, f"{self.section} settings")

    # read-only mapping access, for code written for the resolved dicts
    def __getitem__(self, key):
        if key not in self.__dataclass_fields__:
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self):
        return iter(self.__dataclass_fields__)

    def __len__(self) -> int:
        return len(self.__dataclass_fields__)

    def as_dict(self) -> dict:
        """The settings as plain data (a fresh copy)."""
        return {k: thaw(getattr(self, k)) for k in self if not (k in self.optional and getattr(self, k) is None)}

    def replace(self, **changes):
        """A copy with ``changes`` (checked like any other)."""
        return dataclasses.replace(self, **changes)

    def __reduce__(self):  # pickle and deepcopy (a read-only mapping is neither): rebuilt from plain data
        return _restore, (self.section, type(self).__name__, type(self).__doc__, self.as_dict())

    @classmethod
    def resolve(cls, config=None, **flags):
        """``flags`` (those not None: given on the command line; a mapping is merged into the config's) >
        ``config`` (this section's mapping, as in config.yaml; None: none) > the schema's defaults."""
        flags = {k: v for k, v in flags.items() if v is not None}
        if isinstance(config, cls) and not flags:
            return config
        node = _config._schema()["properties"][cls.section]
        given = _config._merge(thaw(config) if config is not None else {}, flags, node)
        return cls(**_config.resolve({cls.section: given}, [cls.section])[cls.section])


def _restore(section: str, name: str, doc: str, data: dict):
    return section_class(section, name, doc)(**data)


def frozen(config, section: str) -> Section:
    """The ``section`` of ``config`` (a whole-config mapping, or a config.yaml path, or None) over the schema's
    defaults, frozen and checked: for the sections read whole (reference, realcores, aftercare, gdlaws,
    temperature_laws), which need no flags of their own."""
    data = _config.resolve(config, (section,))[section]
    name = "".join(w.title() for w in section.split("_")) + "Settings"
    return section_class(section, name)(**data)


def schema_or(section: str, **given) -> dict:
    """``given`` with each None ("not given") replaced by the schema's default of ``section.key``: a library
    function called without settings (a test, a notebook) runs the schema's values, which stay their one owner.
    With every value given the schema is not read (no copy of its section: a kernel call per model evaluation
    asks this, e.g. :func:`mrhyst.rig.kernel`)."""
    if all(v is not None for v in given.values()):
        return dict(given)
    d = _config.defaults(section)
    return {k: d[k] if v is None else v for k, v in given.items()}


_TYPES = {"integer": int, "number": float, "boolean": bool, "string": str, "object": Mapping, "array": tuple}


def _type_of(node: dict):
    node = _config._node(node)
    if "enum" in node:
        return str if all(isinstance(v, str) for v in node["enum"]) else Any
    t = node.get("type")
    if isinstance(t, list):
        types = [_TYPES.get(x, type(None)) for x in t]
        return functools.reduce(lambda a, b: a | b, types)
    return _TYPES.get(t, Any)


@functools.cache
def section_class(section: str, name: str, doc: str = "") -> type:
    """A frozen dataclass (subclass of :class:`Section`) with one typed field per property of the schema's
    ``section``. Properties without a schema default are optional fields (default None)."""
    props = _config._schema()["properties"][section].get("properties", {})
    with_default = _config.defaults(section)
    fields = [(k, _type_of(p)) for k, p in props.items() if k in with_default]
    fields += [(k, _type_of(p) | None, dataclasses.field(default=None)) for k, p in props.items()
               if k not in with_default]
    cls = dataclasses.make_dataclass(name, fields, bases=(Section,), frozen=True,
                                     namespace={"section": section, "__doc__": doc or Section.__doc__,
                                                "optional": frozenset(props) - set(with_default),
                                                "__module__": __name__})
    return cls
