"""Blind benchmark of the diagnosis: cases with a withheld cause, a key, and the score.

Three steps, three rules, and only the last one may read the key:

* :func:`generate` (rule ``blind_generate``, module :mod:`.cases`) draws the cases of every class of
  ``blind.classes`` - closed world (one vocabulary effect or none, the rig), compound (two vocabulary
  effects, the rig), open world (an out-of-vocabulary mechanism, :mod:`mrhyst.blind.openworld`) - writes them as
  anonymous raw sweeps ``case_000.csv/.json`` ... in shuffled order, and the key ``key.json``. Whether a
  case's gap can be named at all comes from an independent reference fit (:mod:`.reference`: scipy
  ``least_squares`` from the truth on the noise-free loop), never from the diagnosis it judges.
* the diagnosis of a case (rules ``blind_diagnose``, a block of cases per process, and ``blind_diagnose_rest``;
  :func:`diagnose_cases`, module :mod:`.run`) is :func:`mrhyst.diagnose.diagnose_file` on its own files; it
  never sees the key.
* :func:`score` (rule ``blind_score``, module :mod:`.scoring`) reads the diagnoses and the key: closed-world
  top-1, compound one-of-pair / both-named, open-world false attribution / model-form recall, per class;
  and, given a selection policy, the trade-off curve (:mod:`.tradeoff`).
"""

# The names below are loaded on first use (PEP 562): a blind_diagnose job needs the diagnosis and .run only, not
# the rig, the open-world mechanisms and scipy's least_squares that generating cases needs (~0.3 s of imports
# per job, 26 jobs in a build).
_NAMES = {
    "cases": ("CLASSES", "CLOSED", "EFFECTS", "KEY_FILENAME", "PROTOCOLS", "SENSOR", "case_ids", "class_kind", "counts",
              "current_path", "detectability", "draw_cases", "effective_sigma", "generate", "key_parts", "members",
              "noise_free", "simulate", "true_size", "variant_config"),
    "run": ("block_digits", "diagnose_cases", "split_blocks"),
    "scoring": ("FAILED", "judge", "named_effects", "score"),
    "tradeoff": ("curve", "load_policy", "policy_grid"),
}
_WHERE = {name: module for module, names in _NAMES.items() for name in names}
_MODULES = ("cases", "openworld", "reference", "run", "scoring", "tradeoff")


def __getattr__(name: str):
    import importlib

    if name in _MODULES:  # a submodule not imported yet (blind.reference, ...)
        return importlib.import_module(f"{__name__}.{name}")
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_WHERE) | set(_MODULES))


__all__ = sorted(_WHERE)
