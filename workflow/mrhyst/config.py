"""Loading and checking config.yaml with one-line errors, and the config's defaults.

The JSON schema (workflow/mrhyst/schemas/config.schema.yaml) forbids unknown keys at
every level, so a mistyped key is an error, not a silently ignored setting. It is
also the one place of the defaults (its ``default:`` entries): :func:`defaults`
reads them, :func:`resolve` merges a config over them.
"""

from __future__ import annotations

import copy
import functools
import math
from pathlib import Path

import yaml

from mrhyst.errors import ConfigError  # noqa: F401  (defined without imports: the CLI starts fast)

SCHEMA_PATH = Path(__file__).resolve().parent / "schemas" / "config.schema.yaml"


def _where(err) -> str:
    out = ""
    for p in err.absolute_path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "(top level)"


def _raise_first(schema: dict, instance, source: str, prefix: str = "") -> None:
    """ConfigError for the first (shallowest) schema violation of ``instance``; where = prefix + path."""
    import jsonschema  # only when a config is checked (~0.05 s of imports)

    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(instance), key=lambda e: (len(list(e.absolute_path)), _where(e)))
    if errors:
        e = errors[0]
        where = _where(e)
        if prefix:
            where = prefix if where == "(top level)" else prefix + ("" if where.startswith("[") else ".") + where
        if e.validator == "additionalProperties":
            extra = sorted(set(e.instance) - set(e.schema.get("properties", {})))
            known = ", ".join(sorted(e.schema.get("properties", {})))
            raise ConfigError(f"{source}: {where}: unknown key(s) {', '.join(extra)} (known: {known})")
        msg = e.message if len(e.message) < 200 else e.message[:200] + "..."
        raise ConfigError(f"{source}: {where}: {msg}")
    _check_finite(instance, source, prefix)


def _check_finite(value, source: str, where: str) -> None:
    """No NaN or infinity anywhere (a JSON schema range check lets NaN through)."""
    if isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"{source}: {where or '(top level)'}: must be a finite number, got {value}")
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for k, v in items:
        _check_finite(v, source, f"{where}[{k}]" if isinstance(k, int) else (f"{where}.{k}" if where else str(k)))


def check_config(config: dict, source: str = "config.yaml", schema_path: Path = SCHEMA_PATH) -> dict:
    """Validate ``config`` against the schema; raise ConfigError naming the key and the problem."""
    if not isinstance(config, dict):
        raise ConfigError(f"{source}: expected a mapping at the top level")
    schema = _schema() if Path(schema_path) == SCHEMA_PATH else yaml.safe_load(Path(schema_path).read_text())
    _raise_first(schema, config, source)
    _check_semantics(config, source)
    return config


def check_section(name: str, section, source: str = "config.yaml") -> dict:
    """Validate one top-level section on its own (a partial config, e.g. ``{"external": {...}}``) against
    its part of the schema: the same one-line ConfigError as :func:`check_config`, naming ``name.key``."""
    schema = _schema()
    sub = {"$defs": schema.get("$defs", {}), **schema["properties"][name]}
    _raise_first(sub, section, source, prefix=name)
    return section


# --------------------------------------------------------------------------------------------------
# defaults: the schema's `default:` entries, and a config merged over them
# --------------------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=1)
def _schema() -> dict:
    # libyaml's safe loader where PyYAML has it (the same dict, ~8x faster: every job that imports the diagnosis
    # reads the schema's defaults); the pure-Python one otherwise. A user's own files keep safe_load's messages.
    # Kept parsed beside the schema, checked against its bytes (issue 26's start-up: mrhyst.startup.cached_yaml).
    from mrhyst.startup import cached_yaml

    return cached_yaml(SCHEMA_PATH, lambda text: yaml.load(text, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader)))


_NONE = object()  # "this schema node has no default"


def _node(node: dict) -> dict:
    """A schema node with its local $ref resolved (sibling keys, e.g. its own `default:`, win)."""
    ref = node.get("$ref")
    if not ref:
        return node
    target = _schema()
    for part in ref.removeprefix("#/").split("/"):
        target = target[part]
    return {**target, **{k: v for k, v in node.items() if k != "$ref"}}


def _default_of(node: dict):
    """The node's own ``default``; for an object without one, its properties' defaults (recursively,
    those without a default left out; an object with none of them has no default)."""
    node = _node(node)
    if "default" in node:
        return node["default"]
    out = {}
    for k, p in (node.get("properties") or {}).items():
        d = _default_of(p)
        if d is not _NONE:
            out[k] = d
    return out if out else _NONE


@functools.cache
def _defaults(section: str | None):
    root = _schema()
    d = _default_of(root if section is None else root["properties"][section])
    return {} if d is _NONE else d


@functools.cache
def _defaults_text(section: str) -> str:
    import json

    return json.dumps(_defaults(section), sort_keys=True)


def is_default(section: str, value) -> bool:
    """Whether ``value`` is section ``section``'s schema default, value for value and type for type (1 is not
    1.0 nor True): such settings need no schema check (the defaults pass it: tests/test_config.py), so a
    command run with the defaults starts without jsonschema (~0.1 s, issue 26)."""
    import json

    try:
        return json.dumps(value, sort_keys=True) == _defaults_text(section)
    except (TypeError, ValueError):  # not plain data: checked the ordinary way
        return False


def defaults(section: str | None = None) -> dict:
    """A fresh copy of the schema's default of config section ``section`` (None: the whole config, every
    section that has defaults). A nested object's default is its properties' defaults."""
    if section is not None and section not in _schema()["properties"]:
        raise KeyError(f"no config section {section!r} in {SCHEMA_PATH.name}")
    return copy.deepcopy(_defaults(section))


def _merge(base, over, node: dict):
    """``over`` deep-merged into ``base`` (both plain data) along schema ``node``; a mapping whose schema
    says ``x-merge: replace`` (pso.settings: a user's set of PSO settings is the whole set) replaces."""
    node = _node(node) if isinstance(node, dict) else {}
    if not (isinstance(base, dict) and isinstance(over, dict)) or node.get("x-merge") == "replace":
        return copy.deepcopy(over)
    out = dict(base)
    props = node.get("properties") or {}
    for k, v in over.items():
        out[k] = _merge(base[k], v, props.get(k, {})) if k in base else copy.deepcopy(v)
    return out


def resolve(config=None, sections=None) -> dict:
    """``{section: value}`` for ``sections`` (None: every section with defaults): the schema defaults
    with ``config`` deep-merged over them. config: None (the defaults), a mapping (merged as given; a
    partial config is fine, it is not validated), or a config.yaml path (loaded and checked by
    :func:`load_config`: a bad file is one ConfigError line)."""
    if isinstance(config, (str, Path)):
        config = load_config(config)
    config = config or {}
    props = _schema()["properties"]
    names = list(sections) if sections is not None else list(defaults())
    out = {}
    for sec in names:
        given = config.get(sec)
        out[sec] = defaults(sec) if given is None else _merge(defaults(sec), given, props[sec])
    return out


def _check_semantics(config: dict, source: str) -> None:
    """Checks a JSON schema cannot express (lower < upper and the like)."""
    lo, hi = config.get("nle", {}).get("bracket", [1.0, 2.0])
    if not lo < hi:
        raise ConfigError(f"{source}: nle.bracket: lower ({lo}) must be below upper ({hi})")
    for name, sens in (config.get("rig", {}).get("sensors") or {}).items():
        lo_v, hi_v = sens.get("output_min_V"), sens.get("output_max_V")
        if lo_v is not None and hi_v is not None and not lo_v < hi_v:
            raise ConfigError(f"{source}: rig.sensors.{name}: output_min_V ({lo_v}) must be below "
                              f"output_max_V ({hi_v})")
    pso = config.get("pso") or {}
    settings = pso.get("settings") or {}
    keys = [k for k in ("setting", "cli_setting") if k in pso]  # (a partial config may have neither)
    for key in keys + [f"run_settings[{i}]" for i in range(len(pso.get("run_settings") or []))]:
        name = pso[key] if key in ("setting", "cli_setting") else pso["run_settings"][int(key[13:-1])]
        if settings and name not in settings:
            raise ConfigError(f"{source}: pso.{key}: {name!r} is not one of pso.settings ({', '.join(settings)})")
    dbox = pso.get("default_box") or {}
    lo, hi = dbox.get("lo") or {}, dbox.get("hi") or {}
    for name in lo:
        if name in hi and not lo[name] < hi[name]:
            raise ConfigError(f"{source}: pso.default_box: lower {name} ({lo[name]}) must be below upper ({hi[name]})")
    centre = dbox.get("centre") or {}
    for name, v in centre.items():
        if name in lo and name in hi and not lo[name] <= v <= hi[name]:
            raise ConfigError(f"{source}: pso.default_box.centre.{name} ({v}) lies outside [{lo[name]}, {hi[name]}]")
    # [lo, hi] pairs of the diagnosis and the blind benchmark
    pairs = []
    for sec, keys in (("diagnose", ("box", "start_box")), ("blind", ("truth_box",))):
        for key in keys:
            for name, pair in ((config.get(sec) or {}).get(key) or {}).items():
                pairs.append((f"{sec}.{key}.{name}", pair, False))
    blind = config.get("blind") or {}
    for i, pair in enumerate(blind.get("n_over_le_ranges") or []):
        pairs.append((f"blind.n_over_le_ranges[{i}]", pair, True))
    if "dwell_s" in blind:
        pairs.append(("blind.dwell_s", blind["dwell_s"], True))
    for name, pair in (blind.get("magnitude") or {}).items():
        if isinstance(pair, list):
            pairs.append((f"blind.magnitude.{name}", pair, True))
    for where, pair, equal_ok in pairs:
        if len(pair) == 2 and not (pair[0] <= pair[1] if equal_ok else pair[0] < pair[1]):
            rule = "must not exceed" if equal_ok else "must be below"
            raise ConfigError(f"{source}: {where}: lower ({pair[0]}) {rule} upper ({pair[1]})")
    regions = (config.get("diagnose") or {}).get("regions") or {}
    if "low_frac" in regions and "high_frac" in regions and not regions["low_frac"] < regions["high_frac"]:
        raise ConfigError(f"{source}: diagnose.regions: low_frac ({regions['low_frac']}) must be below "
                          f"high_frac ({regions['high_frac']})")
    ext_setting = (config.get("external") or {}).get("pso_setting")
    if ext_setting is not None and settings and ext_setting not in settings:
        raise ConfigError(f"{source}: external.pso_setting: {ext_setting!r} is not one of pso.settings "
                          f"({', '.join(settings)})")


def load_config(path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: file not found")
    try:
        config = yaml.safe_load(path.read_text())
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        raise ConfigError(f"{path}: not valid YAML{where}") from None
    return check_config(config, str(path))
