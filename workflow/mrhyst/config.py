"""Loading and checking config.yaml with one-line errors.

The JSON schema (workflow/schemas/config.schema.yaml) forbids unknown keys at
every level, so a mistyped key is an error, not a silently ignored setting.
"""

from __future__ import annotations

from pathlib import Path

import jsonschema
import yaml

SCHEMA_PATH = Path(__file__).resolve().parent.parent / "schemas" / "config.schema.yaml"


class ConfigError(Exception):
    """The one line to show for a bad config."""


def _where(err: jsonschema.ValidationError) -> str:
    out = ""
    for p in err.absolute_path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "(top level)"


def check_config(config: dict, source: str = "config.yaml", schema_path: Path = SCHEMA_PATH) -> dict:
    """Validate ``config`` against the schema; raise ConfigError naming the key and the problem."""
    if not isinstance(config, dict):
        raise ConfigError(f"{source}: expected a mapping at the top level")
    schema = yaml.safe_load(Path(schema_path).read_text())
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(config), key=lambda e: (len(list(e.absolute_path)), _where(e)))
    if errors:
        e = errors[0]
        if e.validator == "additionalProperties":
            extra = sorted(set(e.instance) - set(e.schema.get("properties", {})))
            known = ", ".join(sorted(e.schema.get("properties", {})))
            raise ConfigError(f"{source}: {_where(e)}: unknown key(s) {', '.join(extra)} (known: {known})")
        msg = e.message if len(e.message) < 200 else e.message[:200] + "..."
        raise ConfigError(f"{source}: {_where(e)}: {msg}")
    _check_semantics(config, source)
    return config


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
    keys = ["setting"] + (["cli_setting"] if "cli_setting" in pso else [])
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
