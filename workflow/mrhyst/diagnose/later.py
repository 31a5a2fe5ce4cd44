"""A later sweep of the same damper against the model calibrated from the first (issue 26, target `later`).

What a lab does with reference mode (docs/reference.md): it calibrates J-A once on a sweep (`mrhyst fit LOOP.csv
--method lsm`), sweeps the same damper again later, and asks what changed (`mrhyst diagnose LATER.csv --sensor S
--reference FIT.json`). Here the first sweep is the virtual rig's own (config ``rig``, its seed and coil: the bytes
of data/raw's shipped sweep, written again by :func:`generate`, so that a lab's own sweep in data/raw, another
damper on another channel, is never calibrated against the rig's later sweeps) and the later sweeps are the
same virtual rig, the same channel, the same protocol and effects (its eddy lag, its Hall offset), with fresh
noise (config ``later.seed``) and one change each (config ``later.changes``): the core hotter (the truth's Ms times
``Ms_ratio``) or the gap opened (the rig's ``air_gap`` effect, demagnetising factor ``Nd``). Labelled as the
virtual rig everywhere: the sidecar's provenance is the rig's.

Each later sweep is diagnosed twice: against the calibration held (reference mode: the figure of every diagnosis,
mrhyst.report.diagfig) and as a new sweep (normal mode: J-A refitted). :func:`summary` puts side by side what the
reference diagnosis names and what the refit absorbed instead: its J-A parameters against the calibration's.
"""

from __future__ import annotations

import copy
from pathlib import Path

from mrhyst.model import ja

CHANGES = ("core_temperature", "air_gap")  # config later.changes: what the rig can change between sweeps


def later_config(config=None):
    """The ``later`` section, frozen over the schema's defaults (mrhyst.settings.frozen)."""
    from mrhyst.settings import frozen

    return frozen(config, "later")


def rig_after(rig_cfg: dict, sensor: str, change: str, size: dict) -> dict:
    """The rig of config ``rig`` with only ``sensor`` and that sensor's damper after ``change`` (the rest kept): the
    change applied as the aftercare benchmark applies it (mrhyst.blind.aftercare.apply_change, the one mapping)."""
    from mrhyst.blind.aftercare import apply_change

    if change not in CHANGES:
        raise ValueError(f"later.changes: {change!r} is not one of {', '.join(CHANGES)}")
    if sensor not in rig_cfg["sensors"]:
        raise ValueError(f"later.sensor: the rig has no sensor {sensor!r}")
    out = {k: copy.deepcopy(v) for k, v in rig_cfg.items() if k != "variants"}
    s = dict(out["sensors"][sensor])
    truth = dict(s["truth"])
    p, effects = apply_change(change, size, [float(truth[k]) for k in ja.PARAM_NAMES])
    s["truth"] = dict(truth, **{k: float(v) for k, v in zip(ja.PARAM_NAMES, p) if float(v) != float(truth[k])})
    if effects:
        s["effects"] = dict(s.get("effects") or {}, **{name: dict(kw) for name, kw in effects})
    out["sensors"] = {sensor: s}
    return out


def generate(rig_cfg: dict, cfg, n_over_le: float, out_dir) -> list[Path]:
    """Write the rig's first sweep (``out_dir/first.csv`` + sidecar: every sensor, config rig.seed, the coil
    rounded to 0.001 turns/m as `python -m mrhyst.rig` writes data/raw's), one later sweep per change
    (``out_dir/CHANGE.csv`` + sidecar) and ``out_dir/settings.json`` (the ``later`` settings that ran, N/Le, and
    each change's size: the truth the report shows); the later sweeps' paths."""
    from mrhyst import rig
    from mrhyst.data.io import write_json
    from mrhyst.settings import thaw

    if cfg["sensor"] not in rig_cfg["sensors"]:
        raise ValueError(f"later.sensor: the rig has no sensor {cfg['sensor']!r} "
                         f"(it has {', '.join(rig_cfg['sensors'])})")
    first = {k: v for k, v in rig_cfg.items() if k != "variants"}  # the rig as data/raw's sweep was made
    rig.generate_sweep(first, round(float(n_over_le), 3), int(rig_cfg["seed"]), Path(out_dir) / "first.csv")
    out = []
    for change, size in cfg["changes"].items():
        p = Path(out_dir) / f"{change}.csv"
        rig.generate_sweep(rig_after(rig_cfg, cfg["sensor"], change, size), n_over_le, int(cfg["seed"]), p)
        out.append(p)
    write_json({"settings": thaw(cfg), "n_over_le": float(n_over_le), "source": "virtual rig (synthetic)",
                "truth": {c: dict(v) for c, v in cfg["changes"].items()}}, Path(out_dir) / "settings.json")
    return out


def diagnose_both(csv, calibration, sensor: str, config: dict, ref_out, figure, plain_out) -> None:
    """The later sweep against the calibration held (JSON + figure) and as a new sweep (JSON): `mrhyst diagnose
    CSV --sensor S --reference CAL --figure PNG` and `mrhyst diagnose CSV --sensor S`, with ``config``'s
    diagnose, paper and reference sections."""
    from mrhyst.data.io import write_json
    from mrhyst.diagnose import diagnose_file, refdiag, resolve_config
    from mrhyst.report.summary import finish_diagnosis

    d = refdiag.reference_file(csv, str(calibration), sensor=sensor, config=config.get("diagnose"),
                               paper=config.get("paper"), rcfg=refdiag.ref_config(config))
    finish_diagnosis(d, ref_out, figure, quiet=True)
    write_json(diagnose_file(csv, sensor=sensor, config=resolve_config(config.get("diagnose"))), plain_out)


def _moves(cal: dict, refit: dict) -> list:
    return [{"param": k, "calibrated": float(cal[k]), "refit": float(refit[k]),
             "ratio": float(refit[k]) / float(cal[k]) if cal[k] else None} for k in ja.PARAM_NAMES]


def summary(change: str, truth: dict, calibration: dict, ref: dict, plain: dict) -> dict:
    """What the report shows of one later sweep (from the JSONs alone): the truth the rig put in, the reference
    diagnosis (verdict, size, RMS, its plain summary, the text `mrhyst diagnose` prints) and the normal one (its
    verdict and the refit's J-A parameters against the calibration's: what they absorbed)."""
    from mrhyst.report.summary import diagnosis_summary

    size = ref.get("effect_size") or {}
    return {
        "change": change, "truth": dict(truth),
        "calibration": {"source": "virtual rig (synthetic), data/raw", "rms_T": calibration.get("rms_T"),
                        "form": calibration.get("form")},
        "reference": {"effect": ref["effect"], "ambiguous_with": list(ref.get("ambiguous_with") or []),
                      "size_param": size.get("param"), "size": size.get("value"), "size_stderr": size.get("stderr"),
                      "rms_before_T": ref["rms_before_T"], "rms_after_T": ref["rms_after_T"],
                      "floor_T": ref.get("floor_T"), "verdict": ref.get("verdict"),
                      "summary": diagnosis_summary(ref)},
        "plain": {"effect": plain["effect"], "ambiguous_with": list(plain.get("ambiguous_with") or []),
                  "rms_before_T": plain["rms_before_T"], "rms_after_T": plain["rms_after_T"],
                  "summary": diagnosis_summary(plain),
                  "absorbed": _moves(calibration["params"], plain["fit_before"]["ja_params"])},
    }


def collect(calibration, settings, diagnoses: dict) -> list:
    """The report's rows (:func:`summary`), one per change: ``settings`` the later_generate record (its ``truth``
    {change: size}), ``diagnoses`` {change: (reference JSON, normal JSON, figure PNG)}."""
    from mrhyst.data.io import read_json

    cal, truth = read_json(calibration), read_json(settings)["truth"]
    return [dict(summary(c, truth[c], cal, read_json(r), read_json(p)), figure=str(png))
            for c, (r, p, png) in diagnoses.items()]
