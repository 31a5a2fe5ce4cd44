"""Benchmark "real cores, known faults" (issue 23 item 5): measured loops from other laboratories with one
known measurement fault added, as third-party B(H) loops and as stepped Hall sweeps through a sensor chain.

Every loop of ``realcores.sources`` (data/external: M130-27s, Mn-Zn ferrite, Hiperco 50, gadolinium), or those
named in ``cores``, is a *core* (a densely sampled path that jitters in H made of monotone legs first,
:func:`monotone_legs`):

* **B(H) cases** - the loop itself (decimated to ``bh_samples`` along its path), clean, with a constant B
  offset (a fraction of the loop's peak |B|) or clipped symmetrically at a fraction of its peak, through the
  registry's own forward actions (``hall_offset`` and ``sensor_saturation`` of :mod:`mrhyst.model.effects`).
* **Hall cases** - the loop as a core: its descending and ascending branches interpolated in H, sampled at
  stepped currents 0 -> +max -> -max -> +max -> -max -> +max (``hall.steps_per_half`` per half branch: the
  core was left by an excursion to -max, so it starts at its remanence on the ascending branch: a real
  remanent start), H = (N/Le) I with N/Le = Hmax / ``hall.i_max_A``. The field then goes through the chain in
  physical order: eddy settling of the flux (``eddy_lag``), the Hall zero (``hall_offset``, ``thermal_drift``
  at an output-referred rate in V/s), the sensor V = Vq + S B with S scaled so that the peak is
  ``hall.peak_V_above_q`` above the quiescent output, white output noise, the output limits (a clip is an
  output limit lowered into the loop and declared in the sidecar), the ADC.

Each core gets every fault its protocol can show, the sizes cycled over the cores from barely detectable to
large (``faults``), plus a clean case. Cases are anonymous files (``cases/rc_NNN.csv``, a Hall case with its
JSON sidecar); the key (``key.json``: core, protocol, fault, size as the diagnosis reports it) is read only
by the scorer (:mod:`mrhyst.blind.realscore`). Deterministic for a given config (``seed``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from mrhyst import rig
from mrhyst.data import io, loops
from mrhyst.diagnose.sweep import decimate
from mrhyst.model import effects as fx
from mrhyst.model import hall
from mrhyst.settings import Section, frozen, thaw

BH_FAULTS = ("hall_offset", "sensor_saturation")
HALL_FAULTS = ("hall_offset", "thermal_drift", "eddy_lag", "sensor_saturation")
PARAM = {"hall_offset": "offset_T", "thermal_drift": "drift_T_per_s", "eddy_lag": "lag",
         "sensor_saturation": "B_sat_T"}


def core_loops(sources: dict, want=None, reversal_frac: float = 0.0) -> list[dict]:
    """Every loop of every source file (or those named in ``want``): [{"core": "NAME_LIDX", "path", "loop_index",
    "H", "B"}], each path made of monotone legs (:func:`monotone_legs`)."""
    out = []
    for name in sorted(sources):
        path = sources[name]
        if want and not any(w.rsplit("_L", 1)[0] == name for w in want):
            continue  # no core of this file wanted: not read (the gadolinium file takes ~1.5 s)
        lps = io.read_loops(path)
        for lp, idx in zip(lps, io.loop_indices(lps)):
            core = f"{name}_L{0 if idx is None else idx}"
            if want and core not in want:
                continue
            v = np.asarray(lp.valid, dtype=bool)
            H, B = monotone_legs(np.asarray(lp.H_A_per_m, dtype=float)[v], np.asarray(lp.B_T, dtype=float)[v],
                                 reversal_frac)
            out.append({"core": core, "path": str(path), "loop_index": idx, "H": H, "B": B})
    return out


def monotone_legs(H, B, frac: float) -> tuple[np.ndarray, np.ndarray]:
    """(H, B) as monotone legs between the path's real reversals (:func:`mrhyst.data.loops.monotone_index`, which
    the diagnosis of a B(H) loop applies too, config diagnose.bh.reversal_frac); the arrays themselves when
    nothing is dropped."""
    k = loops.monotone_index(H, frac)
    if k.size == np.size(H):
        return H, B
    return H[k], B[k]


def major_branches(H, B) -> tuple[tuple, tuple]:
    """((H, B) of the descending branch, (H, B) of the ascending branch) of a path that holds a full major
    loop: the last descending segment and the last ascending one, sorted by H, closed at the tips: every sample
    at max H (min H) of the loop, on either branch, is replaced by their mean (the M130-27s loops as measured
    miss closure there by 2-4 mT: kept, the core would read that non-closure as an off-centre loop), and the
    loop centred between its tips (the measured M130-27s loops sit 1.0-1.1 mT off centre: a clean core would
    carry a small real offset). The B(H) cases keep the loops exactly as measured."""
    segs = loops.segments(H)
    dn = [s for s in segs if s.direction < 0][-1]
    up = [s for s in segs if s.direction > 0][-1]
    hi, lo = float(np.max(H)), float(np.min(H))
    b_hi, b_lo = float(np.mean(B[H == hi])), float(np.mean(B[H == lo]))
    c = 0.5 * (b_hi + b_lo)  # a material's major loop is odd: the lab's own off-centre (~1 mT on M130-27s) removed
    B = B - c
    tips = ((hi, b_hi - c), (lo, b_lo - c))

    def branch(s):
        h, b = H[s.start:s.stop + 1], B[s.start:s.stop + 1]
        keep = (h != hi) & (h != lo)
        h = np.r_[h[keep], [t[0] for t in tips]]
        b = np.r_[b[keep], [t[1] for t in tips]]
        o = np.argsort(h, kind="stable")
        return h[o], b[o]

    return branch(dn), branch(up)


def stepped_path(steps_per_half: int) -> np.ndarray:
    """Normalised currents 0 -> +1 -> -1 -> +1 -> -1 -> +1 in equal steps (``steps_per_half`` per 0 -> 1)."""
    k = int(steps_per_half)
    up0 = np.arange(0, k + 1) / k
    down = 1.0 - np.arange(1, 2 * k + 1) / k
    up = -1.0 + np.arange(1, 2 * k + 1) / k
    return np.concatenate([up0, down, up, down, up])


def core_field(core: dict, path: np.ndarray) -> np.ndarray:
    """B of the core along the normalised path: the ascending branch while the path rises, the descending one
    while it falls (every reversal at +-max: the major loop), interpolated in H."""
    (hd, bd), (hu, bu) = major_branches(core["H"], core["B"])
    hmax = float(np.max(np.abs(core["H"])))
    H = path * hmax
    d = loops.directions(path)
    return np.where(d > 0, np.interp(H, hu, bu), np.interp(H, hd, bd))


def fault_size(fault: str, level: float, peak_T: float, sens: float) -> dict:
    """The fault's contract parameter from its level (config ``faults``): offset and clip depth as fractions of
    the peak |B|, the drift as an output-referred rate (V/s) over the sensitivity, the lag as is."""
    if fault == "hall_offset":
        return {"offset_T": level * peak_T}
    if fault == "sensor_saturation":
        return {"B_sat_T": (1.0 - level) * peak_T}
    if fault == "thermal_drift":
        return {"drift_T_per_s": level / sens}
    return {"lag": level}


def bh_case(core: dict, fault: str | None, level: float, sign: float, cfg: dict) -> tuple[pd.DataFrame, dict]:
    keep = decimate(core["H"], int(cfg["bh_samples"]))
    H, B = core["H"][keep], core["B"][keep]
    peak = float(np.max(np.abs(B)))
    key = {"protocol": "bh", "fault": fault or "none", "level": level if fault else None}
    if fault:
        ep = fault_size(fault, level, peak, 1.0)
        if fault == "hall_offset":
            ep["offset_T"] *= sign
        B = fx.REGISTRY[fault].signal(B[None, :], ep[PARAM[fault]], np.arange(B.size, dtype=float))[0]
        key["size"] = ep[PARAM[fault]]
    return pd.DataFrame({"H_A_per_m": H, "B_T": B}), key


def hall_case(core: dict, fault: str | None, level: float, sign: float, cfg: dict, seed: int):
    """(volts, time, current, sidecar, key) of one stepped Hall sweep of a real core."""
    hc = cfg["hall"]
    path = stepped_path(int(hc["steps_per_half"]))
    hmax = float(np.max(np.abs(core["H"])))
    i_max = float(hc["i_max_A"])
    current = path * i_max
    t = rig.sample_times(path.size, float(hc["dwell_s"]))
    B = core_field(core, path)
    peak = float(np.max(np.abs(B)))
    supply = float(hc["supply_V"])
    q = supply / 2.0
    sens = float(hc["peak_V_above_q"]) / peak
    v_lo, v_hi = float(hc["output_min_V"]), float(hc["output_max_V"])
    key = {"protocol": "hall", "fault": fault or "none", "level": level if fault else None}
    if fault:
        ep = fault_size(fault, level, peak, sens)
        if fault in ("hall_offset", "thermal_drift"):
            ep[PARAM[fault]] *= sign
        if fault == "sensor_saturation":  # the output limit lowered into the loop (and declared so)
            v_hi, v_lo = q + sens * ep["B_sat_T"], q - sens * ep["B_sat_T"]
        else:
            B = fx.REGISTRY[fault].signal(B[None, :], ep[PARAM[fault]], t)[0]
        key["size"] = ep[PARAM[fault]]
    rng = np.random.default_rng([int(seed), 23])
    V = hall.tesla_to_volts(B, sens, q) + float(hc["noise_V"]) * rng.standard_normal(path.size)
    V = rig.quantise(np.clip(V, v_lo, v_hi))
    v_lo, v_hi = float(rig.quantise(v_lo)), float(rig.quantise(v_hi))
    side = {"supply_V": supply, "coil_turns_per_m": hmax / i_max, "dwell_s": float(hc["dwell_s"]),
            "sensors": {"hall1": {"sensitivity_V_per_T": sens, "quiescent_V": q,
                                  "output_min_V": rig._as_csv_float(v_lo), "output_max_V": rig._as_csv_float(v_hi)}}}
    key.update(sensitivity_V_per_T=sens, noise_T=float(hc["noise_V"]) / sens)
    return {"hall1": V}, t, current, side, key


def plan(cores, cfg: dict) -> list[tuple]:
    """(core index, protocol, fault or None, level, sign) of every case: per core a clean case and every
    fault of each protocol, the level cycled over the cores through ``faults[fault]``, signs alternating."""
    rows = []
    for ci in range(cores if isinstance(cores, int) else len(cores)):
        sign = 1.0 if ci % 2 == 0 else -1.0
        for proto, faults in (("bh", BH_FAULTS), ("hall", HALL_FAULTS)):
            if proto not in cfg["protocols"]:
                continue
            rows.append((ci, proto, None, 0.0, sign))
            for f in faults:
                lv = cfg["faults"][proto][f]
                rows.append((ci, proto, f, float(lv[ci % len(lv)]), sign))
    return rows


def cores_of(cfg: dict) -> list:
    """The cores of the config: every loop of its sources, or those named in ``cores``."""
    want = list(cfg.get("cores") or [])
    cores = core_loops(cfg["sources"], set(want), float(cfg["reversal_frac"]))
    missing = sorted(set(want) - {c["core"] for c in cores})
    if missing:
        raise ValueError(f"realcores.cores: no loop {', '.join(missing)} in the sources")
    return cores


def n_cores(cfg: dict) -> int:
    """How many cores the config makes, without reading the sources when it names them (the workflow asks at
    every parse; the gadolinium file takes ~1.5 s to read)."""
    return len(cfg.get("cores") or []) or len(cores_of(cfg))


def generate(cfg: dict, out_dir, key_path) -> dict:
    """Write every case (``out_dir/rc_NNN.csv``, a Hall case with its sidecar) and the key; returns the key."""
    cfg = resolve(cfg)  # as it is when resolved already (the workflow's params): one resolution
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cores = cores_of(cfg)
    key = {}
    for n, (ci, proto, fault, level, sign) in enumerate(plan(cores, cfg)):
        cid = f"rc_{n:03d}"
        core = cores[ci]
        if proto == "bh":
            df, k = bh_case(core, fault, level, sign, cfg)
            io.write_csv(df, out_dir / f"{cid}.csv")
        else:
            volts, t, cur, side, k = hall_case(core, fault, level, sign, cfg, int(cfg["seed"]) + n)
            io.write_raw(out_dir / f"{cid}.csv", np.arange(cur.size), t, cur, volts, side)
        key[cid] = {"core": core["core"], **k}
    io.write_json({"cases": key, "config": thaw(cfg)}, Path(key_path))
    return key


def case_ids(cfg: dict) -> list[str]:
    """The case ids the config makes (known before generating: the workflow's outputs)."""
    return [f"rc_{n:03d}" for n in range(len(plan(n_cores(cfg), cfg)))]


def diagnose_cases(csvs, outs, config: dict, log=print, material=None) -> list[str]:
    """Diagnose each case from its own file(s) only, as ``mrhyst diagnose`` would: a Hall sweep (a sidecar
    beside it) on channel hall1, a third-party B(H) loop otherwise; never the key. A refused sweep is recorded
    as ``"effect": "failed"`` (counted as a miss). ``material``: the B(H) loops' material fit's settings
    (sections ja, pso, lsm, external; :func:`mrhyst.diagnose.diagnose_bh_file`)."""
    from mrhyst import diagnose
    from mrhyst.blind.run import diagnose_each
    from mrhyst.materials.extsettings import loop_fit_settings

    config, material = diagnose.resolve_config(config), loop_fit_settings(material)  # once, for every case

    def one(csv, out):
        if io.sidecar_path(csv).exists():
            return diagnose.diagnose_file(csv, sensor="hall1", out=out, config=config)
        return diagnose.diagnose_bh_file(csv, out=out, config=config, material=material)

    return diagnose_each(csvs, outs, one, log)


def resolve(cfg) -> Section:
    """The ``realcores`` section over the schema's defaults (the one place they live), frozen and checked; a section
    resolved already is returned as it is. Resolved once: the rule file does it at parse time and hands the section
    on in the rules' params (Snakemake pickles them; a section pickles as its plain data, mrhyst.settings)."""
    if isinstance(cfg, Section) and cfg.section == "realcores":
        return cfg
    return frozen({"realcores": thaw(cfg or {})}, "realcores")


def case_protocols(cfg: dict) -> dict:
    """{case id: "bh" | "hall"} (a Hall case has a JSON sidecar beside its CSV)."""
    return {f"rc_{n:03d}": p[1] for n, p in enumerate(plan(n_cores(cfg), cfg))}
