"""Virtual test rig: a richer forward model than plain J-A, then the sensor chain, then raw sweep files.

Li & Gong (2019) never published their measured sweeps, so the workflow's
"measurements" come from here. A sweep is made in four stages:

1. **Core** - J-A ground truth (Eqs. 4-13, physical form by default: a real
   core follows physics, not the printing of Eq. 13; ARCHITECTURE 5) along the
   applied-current path, H = (N/Le) I (Eq. 12). Model-level effects
   (``remanent_start``, ``air_gap``) act here.
2. **Flux and sensor zero** - signal-level effects in physical order: eddy-current
   settling of the flux (``eddy_lag``), then the Hall zero error (``hall_offset``,
   ``thermal_drift``). Every effect is applied with the functions of
   :mod:`mrhyst.model.effects` (``forward``, ``eddy_filter``, ``air_gap_alpha``), the
   same ones the diagnosis refits; with one effect and no noise,
   :func:`observe` equals ``effects.forward`` bit for bit.
3. **Sensor** - A1304 transfer V = Vq + S B (ratiometric, Vq = Vcc/2), white
   output noise (sigma given in tesla, input-referred), then the limits of the
   linear output range (``sensor_saturation`` lowers the upper limit to
   Vq + S B_sat, which with no noise is exactly ``min(B, B_sat)``).
4. **ADC** - NI PXIe-6363: 16-bit over +-10 V, one code = 20 V / 2^16 = 305 uV.

Everything random comes from one ``numpy.random.Generator``; the noise draws
are made whatever sigma is (sigma only scales them), so the same seed gives the
same noise pattern at every noise level (common random numbers for the blind
benchmark) and the same bytes on disk.

Entry points: :func:`simulate_case` (one sensor, any list of effects; the blind
benchmark's generator), :func:`generate_sweep` (the two-sensor sweep of config
``rig``, written with :func:`mrhyst.data.io.write_raw`) and ``python -m mrhyst.rig``.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from mrhyst.config import resolve as resolve_config
from mrhyst.data import io
from mrhyst.model import effects as fx
from mrhyst.model import hall, ja
from mrhyst.settings import schema_or

ADC_BITS = 16  # NI PXIe-6363 analog input resolution
ADC_RANGE_V = 10.0  # +-10 V input range
SIDE_DIGITS = 10  # io.write_csv writes floats as %.10g; sidecar limits are rounded the same way
# optional sidecar field of the rig's sweeps (fig06 prints it on the figure)
PROVENANCE = "SYNTHETIC - mrhyst virtual test rig, not the paper's measurements (see data/raw/README.md)"


def adc_lsb(bits: int = ADC_BITS, range_V: float = ADC_RANGE_V) -> float:
    """Voltage of one ADC code: full span / 2^bits (20 V / 65536 = 305.18 uV for the 6363)."""
    return 2.0 * float(range_V) / float(2 ** int(bits))


def quantise(V, bits: int = ADC_BITS, range_V: float = ADC_RANGE_V):
    """Nearest ADC code (two's complement, clipped to the range) times the LSB."""
    lsb = adc_lsb(bits, range_V)
    half = 2 ** (int(bits) - 1)
    code = np.clip(np.rint(np.asarray(V, dtype=float) / lsb), -half, half - 1)
    return code * lsb


def _as_csv_float(x: float) -> float:
    """x as it reads back from a CSV written by io.write_csv (%.10g)."""
    return float(f"{float(x):.{SIDE_DIGITS}g}")


def normalise_effects(effects) -> dict:
    """{name: eparams} from a list of (name, eparams) pairs (or a mapping); checked against the registry
    (:func:`mrhyst.model.effects.normalise`: ``none`` dropped; unknown name, missing/extra parameter or a
    repeated effect is an error)."""
    if isinstance(effects, str):
        raise ValueError(f"each effect must be a (name, params) pair, got {effects!r}")
    return {k: {p: float(v) for p, v in ep.items()} for k, ep in fx.normalise(effects or ()).items()}


def kernel(form: str | None = None, substeps: int | None = None) -> dict:
    """The rig's J-A integration: ``form`` and ``substeps`` where given (not None), else the schema's rig.form and
    rig.substeps (the one place of their defaults: the rig's "reality" is physical J-A, integrated finely)."""
    k = schema_or("rig", form=form, substeps=substeps)
    return {"form": str(k["form"]), "substeps": int(k["substeps"])}


def observe(truth_params, current_A, time_s, n_over_le: float, effects=(), *, form: str | None = None,
            substeps: int | None = None, dman: str = "total"):
    """Noise-free B (T) the sensor would see: J-A truth plus any set of effects, through the one forward
    model :func:`mrhyst.model.effects.forward` (physical order: core, flux, Hall zero, output limit).

    ``sensor_saturation`` acts there as ``clip(B, -B_sat, B_sat)`` (what the sensor output limit does without
    noise). Returns ``(B, ok)`` for one parameter set.
    """
    eff = normalise_effects(effects)
    P = np.array(truth_params, dtype=float)
    if P.shape != (5,):
        raise ValueError(f"truth_params must be the 5 J-A parameters {ja.PARAM_NAMES}, got shape {P.shape}")
    return fx.forward(P, current_A, time_s, n_over_le, eff, **kernel(form, substeps), dman=dman)


def sample_times(n: int, dwell_s: float, t0_s: float = 0.0) -> np.ndarray:
    """When each sample is read: the current is stepped every dwell_s and read just before the next step."""
    if not dwell_s > 0:
        raise ValueError(f"dwell_s must be > 0, got {dwell_s}")
    return t0_s + dwell_s * np.arange(1, n + 1, dtype=float)


def simulate_case(
    truth_params,
    effects,
    noise_sigma_T: float,
    seed: int | np.random.Generator,
    current_path=None,
    *,
    n_over_le: float,
    dwell_s: float,
    sensor: str = "hall1",
    form: str | None = None,
    substeps: int | None = None,
    dman: str = "total",
    supply_V: float = hall.A1304_SUPPLY_V,
    sensitivity_V_per_T: float = hall.A1304_SENSITIVITY_V_PER_T,
    quiescent_V: float | None = None,
    output_min_V: float = 0.2,
    output_max_V: float = 3.1,
    adc_bits: int | None = ADC_BITS,
    adc_range_V: float = ADC_RANGE_V,
    declare_limits: bool = True,
):
    """One sensor's raw sweep: J-A truth + effects -> A1304 -> noise -> output limits -> ADC.

    ``truth_params``: (Ms, a, alpha, c, k) or a mapping with those keys. ``effects``: list of ``(name, eparams)``
    from the fixed vocabulary (:data:`mrhyst.model.effects.EFFECTS`), e.g. ``[("eddy_lag", {"lag": 0.3})]``;
    empty or ``[("none", {})]`` for plain J-A. ``noise_sigma_T``: white output noise, input-referred (T).
    ``seed``: int or a Generator (to draw several sensors from one stream). ``noise_sigma_T``, ``seed``,
    ``dwell_s`` (s per sample): no default here, each caller passes its config's (rig, blind, aftercare).
    ``current_path``: applied currents in order (default: the paper's 0 -> 2 A -> 0 in 53 samples).
    ``quiescent_V``: the zero-field output, used for the signal and stated in the sidecar (default supply_V / 2;
    a zero error the reader does not know about is ``hall_offset``). ``adc_bits=None`` skips quantisation.
    ``declare_limits``: write the output limits into the sidecar (so a reader flags samples at them); they always
    act on the signal.

    Returns ``(volts, time_s, current_A, sidecar)`` with ``volts = {sensor: array}``,
    ready for ``io.write_raw(path, range(n), time_s, current_A, volts, sidecar)``
    (or :func:`write_case`). Raises ValueError if the J-A integration fails.
    """
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    if hasattr(truth_params, "keys"):  # a mapping (a dict, or frozen settings)
        truth_params = ja.as_param_array(truth_params)
    current = (ja.paper_current_path() if current_path is None else np.asarray(current_path, dtype=float)).copy()
    if current.ndim != 1 or current.size < 2:
        raise ValueError("current_path must be a 1-D array of at least 2 currents")
    if not noise_sigma_T >= 0:
        raise ValueError(f"noise_sigma_T must be >= 0, got {noise_sigma_T}")
    if not output_min_V < output_max_V:
        raise ValueError(f"output_min_V ({output_min_V}) must be below output_max_V ({output_max_V})")
    time_s = sample_times(current.size, dwell_s)
    eff = normalise_effects(effects)
    # an effect at the sensor's output limit (sensor_saturation; Effect.output_limit) is realised as that limit, below
    lims = [eff.pop(n)[fx.REGISTRY[n].param] for n in list(eff) if fx.REGISTRY[n].output_limit]
    B, ok = observe(truth_params, current, time_s, n_over_le, list(eff.items()), form=form,
                    substeps=substeps, dman=dman)
    if not ok:
        raise ValueError(f"J-A integration failed for truth {ja.as_param_dict(truth_params)} "
                         f"with effects {sorted(eff)} at N/Le = {n_over_le:g} /m")
    Vq = hall.quiescent_voltage(supply_V, quiescent_V)
    V = hall.tesla_to_volts(B, sensitivity_V_per_T, Vq)
    V = V + (sensitivity_V_per_T * noise_sigma_T) * rng.standard_normal(current.size)
    v_hi, v_lo = float(output_max_V), float(output_min_V)
    for b_sat in lims:  # the linear range |B| <= B_sat, symmetric about the quiescent output (effects)
        v_hi = min(v_hi, float(hall.tesla_to_volts(b_sat, sensitivity_V_per_T, Vq)))
        v_lo = max(v_lo, float(hall.tesla_to_volts(-b_sat, sensitivity_V_per_T, Vq)))
    if not v_lo < v_hi:
        raise ValueError(f"saturation level {v_hi} V is not above output_min_V {v_lo} V")
    V = np.clip(V, v_lo, v_hi)
    if adc_bits is not None:
        V = quantise(V, adc_bits, adc_range_V)
        v_lo, v_hi = float(quantise(v_lo, adc_bits, adc_range_V)), float(quantise(v_hi, adc_bits, adc_range_V))
    s_side = {"sensitivity_V_per_T": float(sensitivity_V_per_T), "quiescent_V": float(Vq)}
    if declare_limits:
        # as the clipped samples read back from the CSV, so that a sample at a limit compares equal to it
        s_side["output_min_V"] = _as_csv_float(v_lo)
        s_side["output_max_V"] = _as_csv_float(v_hi)
    sidecar = {"supply_V": float(supply_V), "coil_turns_per_m": float(n_over_le), "dwell_s": float(dwell_s),
               "sensors": {sensor: s_side}}
    return {sensor: V}, time_s, current, sidecar


def write_case(path, volts: dict, time_s, current_A, sidecar: dict) -> None:
    """Write what :func:`simulate_case` returned as a raw sweep (CSV + JSON sidecar)."""
    io.write_raw(path, np.arange(len(current_A)), time_s, current_A, volts, sidecar)


# --------------------------------------------------------------------------
# the committed two-sensor sweep (config rig)
# --------------------------------------------------------------------------
RIG_KEYS = {"seed", "form", "substeps", "dman", "dwell_s", "eddy_tau_s", "supply_V", "noise_sigma_T", "adc", "sensors",
            "variants"}
# what a variant (config rig.variants.NAME) may change; pso_seeds says how many PSO seeds its fits use
VARIANT_KEYS = {"form", "pso_seeds"}
SENSOR_KEYS = {"truth", "sensitivity_V_per_T", "output_min_V", "output_max_V", "effects"}


def eddy_lag(dwell_s: float, tau_s: float) -> float:
    """Fraction of a flux step still unsettled when sampled: exp(-dwell / tau) (first-order settling)."""
    if not (dwell_s > 0 and tau_s > 0):
        raise ValueError(f"dwell_s and eddy_tau_s must be > 0, got {dwell_s}, {tau_s}")
    return math.exp(-dwell_s / tau_s)


def sensor_effects(rig_cfg: dict, sensor: str) -> list:
    """The effects acting on one sensor of the rig: eddy settling of the common core, then its own."""
    own = rig_cfg["sensors"][sensor].get("effects") or {}
    out = []
    if rig_cfg.get("eddy_tau_s"):
        out.append(("eddy_lag", {"lag": eddy_lag(float(rig_cfg["dwell_s"]), float(rig_cfg["eddy_tau_s"]))}))
    out += [(name, dict(ep)) for name, ep in own.items()]
    return out


def _check_rig(rig_cfg: dict) -> None:
    unknown = set(rig_cfg) - RIG_KEYS
    if unknown:
        raise ValueError(f"rig: unknown key(s) {sorted(unknown)}; expected {sorted(RIG_KEYS)}")
    missing = {"dwell_s", "sensors"} - set(rig_cfg)
    if missing:
        raise ValueError(f"rig: missing key(s) {sorted(missing)}")
    if not rig_cfg["sensors"]:
        raise ValueError("rig.sensors is empty")
    for name, s in rig_cfg["sensors"].items():
        bad = set(s) - SENSOR_KEYS
        if bad:
            raise ValueError(f"rig.sensors.{name}: unknown key(s) {sorted(bad)}; expected {sorted(SENSOR_KEYS)}")
        if "truth" not in s:
            raise ValueError(f"rig.sensors.{name}: missing 'truth' (the J-A ground-truth parameters)")


def variant_config(rig_cfg: dict, name: str) -> dict:
    """The rig of variant ``name`` (config rig.variants.NAME): the rig with the variant's keys replaced
    (only the truth's J-A form so far), everything else - truth parameters, effects, noise seed - kept."""
    variants = rig_cfg.get("variants") or {}
    if name not in variants:
        raise ValueError(f"rig.variants: no variant {name!r} (have {', '.join(sorted(variants)) or 'none'})")
    v = variants[name] or {}
    bad = set(v) - VARIANT_KEYS
    if bad:
        raise ValueError(f"rig.variants.{name}: unknown key(s) {sorted(bad)}; expected {sorted(VARIANT_KEYS)}")
    out = {k: val for k, val in rig_cfg.items() if k != "variants"}
    out.update({k: val for k, val in v.items() if k != "pso_seeds"})
    return out


def simulate_sweep(rig_cfg: dict, n_over_le: float, seed: int, current_path=None):
    """All sensors of config ``rig`` along one sweep, noise drawn in sensor order from one Generator.

    Returns ``(volts, time_s, current_A, sidecar)`` as :func:`simulate_case`, with every sensor.
    """
    _check_rig(rig_cfg)
    rc = resolve_config({"rig": rig_cfg}, ["rig"])["rig"]  # the config's values over the schema's defaults
    rng = np.random.default_rng(seed)
    adc = rc["adc"]
    volts, sensors, time_s, current, side = {}, {}, None, None, None
    for name in sorted(rig_cfg["sensors"]):
        s = rig_cfg["sensors"][name]
        v, time_s, current, side = simulate_case(
            ja.as_param_array(s["truth"]), sensor_effects(rig_cfg, name), float(rc["noise_sigma_T"]),
            rng, current_path, n_over_le=float(n_over_le), sensor=name, dwell_s=float(rig_cfg["dwell_s"]),
            form=rc["form"], substeps=int(rc["substeps"]), dman=rc["dman"], supply_V=float(rc["supply_V"]),
            sensitivity_V_per_T=float(s.get("sensitivity_V_per_T", hall.A1304_SENSITIVITY_V_PER_T)),
            output_min_V=float(s.get("output_min_V", 0.2)), output_max_V=float(s.get("output_max_V", 3.1)),
            adc_bits=int(adc["bits"]), adc_range_V=float(adc["range_V"]),
        )
        volts.update(v)
        sensors.update(side["sensors"])
    side = dict(side, sensors=sensors)
    side["provenance"] = PROVENANCE
    return volts, time_s, current, side


def generate_sweep(rig_cfg: dict, n_over_le: float, seed: int, path) -> dict:
    """Write the rig's two-sensor sweep to ``path`` (CSV) and its sidecar (JSON); return the sidecar."""
    volts, time_s, current, side = simulate_sweep(rig_cfg, n_over_le, seed)
    write_case(path, volts, time_s, current, side)
    return side


def main(argv=None) -> int:
    """``python -m mrhyst.rig --config config.yaml --seed N --out data/raw/li_gong_rig.csv``."""
    from mrhyst.config import ConfigError, load_config
    from mrhyst.paper.nle import infer_n_over_le

    ap = argparse.ArgumentParser(prog="python -m mrhyst.rig", description=__doc__.splitlines()[0])
    ap.add_argument("--config", default="config.yaml", help="study config (sections paper, ja, nle, rig)")
    ap.add_argument("--seed", type=int, default=None, help="noise seed (default: config rig.seed)")
    ap.add_argument("--out", required=True, help="raw sweep CSV to write (sidecar JSON beside it)")
    a = ap.parse_args(argv)
    try:
        cfg = load_config(a.config)
        if "rig" not in cfg:
            raise ValueError(f"{a.config}: no 'rig' section")
        seed = a.seed if a.seed is not None else int(cfg["rig"]["seed"])
        # the coil spec is the inferred N/Le rounded to 0.001 turns/m: a last-digit change of the float
        # (e.g. a different but equally exact Langevin formula) must not change the committed data
        nle = round(float(infer_n_over_le(cfg)["n_over_le"]), 3)
        generate_sweep(cfg["rig"], nle, seed, a.out)
    except (OSError, ValueError, KeyError, ConfigError, io.InputError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"wrote {a.out} and {io.sidecar_path(a.out)} (N/Le = {nle!r} /m, seed {seed})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
