"""Held-out check of `mrhyst diagnose` on real cores with faults written apart from mrhyst (issue 23's goals).

The project's own benchmark "real cores, known faults" adds each fault with the effect functions the diagnosis
fits. This one does not: it reads the measured loops of data/external itself (its own leg extraction and branch
interpolation), drives them through its own protocols and sensor chain, and writes each fault its own way:

* stepped Hall sweeps (ARCHITECTURE 4: NAME.csv + NAME.json), three protocols none of which is the project's
  (0 -> +2 -> -2 -> +2 -> -2 -> +2 A, 18 steps per half, 2 s dwell):
  - `tip12`: from the negative tip, -I -> +I -> -I -> +I (one and a half cycles), 12 steps per quarter; the sidecar
    declares the preconditioning that put the core there (3 bipolar cycles to +-I, ending at -I);
  - `zero25`: 0 -> +I -> -I -> +I, 25 steps per quarter, start undeclared (the core was left at -I: it starts at
    its negative remanence on the ascending branch);
  - `neg12`: 0 -> -I -> +I -> -I -> +I, 12 steps per quarter, start undeclared (left at +I: positive remanence);
  dwell 0.3-3 s (log-uniform), 3.3 or 5 V supply, sensitivity putting the peak 45-65 % of half the supply above
  the quiescent output, white noise 0.5-3 mV, a 10-12 bit ADC over 0-5 V.
  Faults: `hall_offset` (a constant output offset, 0.5-8 % of the peak, log-uniform); `thermal_drift` (the
  quiescent output warming towards a new level, V_q0 + dV (1 - exp(-t/tau)), tau 0.3-3x the sweep's duration, the
  initial rate 0.2-0.95x the physical bound 3e-4 x supply per s; one case in three linear at that rate);
  `eddy_lag` (the flux relaxing towards the static B of the applied current in continuous time, tau_e with a
  per-dwell decay exp(-dwell/tau_e) of 0.1-0.5; `end`: read at the end of each dwell, the current slewing over the
  first 0-20 % of it; `mid`: read mid-dwell); `sensor_saturation` (`hard`: the output clipped at a declared
  output_max_V lowered to 80-95 % of the peak; `soft`: an amplifier bending smoothly over the last 5-10 % before a
  declared rail and then flat at it); clean sweeps of every core on every protocol.
* B(H) loops (CSV H_A_per_m,B_T, no sidecar): the measured samples of a descending and an ascending leg as one
  closed loop from a tip, resampled uniformly in arc length (`arc`, 200-300 points) or every k-th sample (`kth`,
  ~250): clean, a constant B offset (3-10 % of the peak), a hard clip at 80-95 % of the peak (symmetric, or one
  rail only), a soft clip (a smooth knee over 5-10 % of the level, then flat).

Cores: gadolinium loops the project's benchmark does not use (L1, L3, L4, L6, L7, L9, L12, L13, L16), M130-27s L0-L2,
Mn-Zn ferrite L0-L3, Hiperco 50. Scored as issue 23 says: the fault named (the verdict, its accepted `secondary`, or
in `ambiguous_with` with a `next_measurement`), its size within 25 % (like with like: an output offset in tesla is
volts / sensitivity, plus the source loop's own centre, which the data carry too; a drift's rate as the mean rate over
the sweep and, reported beside it, the least-squares slope; a lag as the per-step lag of a discrete filter with the
same delay on a steady ramp, the physical exp(-dwell/tau_e) reported beside it), a measurement fault named on a clean
loop (`remanent_start` on an undeclared start is physics, not a false alarm; an offset the source loop itself shows,
`excl. src.`, is the source lab's), and the budget.

Independence: imports nothing from mrhyst; written from the docs, ARCHITECTURE section 4 and config.yaml's
comments, without reading the project's real-cores generator, effect functions, rig or diagnosis code.

    python bench/heldout_realcores.py --out /tmp/hrc.csv [--seed 0] [--workflow /work/main/workflow] [--jobs 2]
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
EXT = ROOT / "data" / "external"
MEASUREMENT = ("hall_offset", "thermal_drift", "eddy_lag", "sensor_saturation")
GD_HELD_OUT = (1, 3, 4, 6, 7, 9, 12, 13, 16)
PROTOCOLS = ("tip12", "zero25", "neg12")
HALL_FAULTS = ("hall_offset", "thermal_drift", "eddy_lag", "sat_hard", "sat_soft")
BH_FAULTS = ("offset", "clip_hard", "clip_soft")
TRUTH = {"hall_offset": "hall_offset", "thermal_drift": "thermal_drift", "eddy_lag": "eddy_lag",
         "sat_hard": "sensor_saturation", "sat_soft": "sensor_saturation", "offset": "hall_offset",
         "clip_hard": "sensor_saturation", "clip_soft": "sensor_saturation"}
ADC_SPAN_V = 5.0
DRIFT_BOUND_PER_V_SUPPLY = 3.0e-4   # config.yaml diagnose.plausible: 3e-4 Vcc/K x 1 K/s at the output


# ----------------------------------------------------------------------------------------------- the cores
def legs(h: np.ndarray, tol: float) -> list[tuple[int, np.ndarray]]:
    """Monotone legs of a jittering path: a reversal counts once H has moved back by more than `tol` from the
    leg's extreme; within a leg only samples that extend it are kept. Returns (direction, indices) per leg."""
    out, cur, d, ext = [], [0], 0, h[0]
    for i in range(1, h.size):
        if (d >= 0 and h[i] > ext) or (d <= 0 and h[i] < ext):
            d = d or int(np.sign(h[i] - ext))
            ext = h[i]
            cur.append(i)
        elif d != 0 and abs(h[i] - ext) > tol:
            out.append((d, np.array(cur)))
            cur, d, ext = [cur[-1], i], -d, h[i]
    out.append((d, np.array(cur)))
    return out


def _smooth_branch(h: np.ndarray, b: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """B on `grid` from one monotone leg: sorted by H, a running mean over ~n/200 samples (the 3 Hz loops' jitter),
    interpolated, then made non-decreasing in H (no material's branch falls while H rises)."""
    o = np.argsort(h, kind="stable")
    h, b = h[o], b[o]
    m = max(1, h.size // 200)
    if m > 1:
        k = np.ones(m) / m
        h, b = np.convolve(h, k, "valid"), np.convolve(b, k, "valid")
    return np.maximum.accumulate(np.interp(grid, h, b))


def load_core(name: str) -> dict:
    """The measured legs and smoothed major-loop branches of one core: {h, b: raw samples of the descending and
    ascending legs; grid, b_desc, b_asc: branches meeting at both tips; hmax, bpeak}."""
    src, idx = name.rsplit("_L", 1)
    if src == "hiperco50":
        df = pd.read_csv(EXT / "hiperco50-pyjam" / "loop.csv").rename(columns={"H": "H_A_per_m", "B": "B_T"})
    else:
        folder = {"gd": "gd-temperature-nowicki", "m130": "m130-27s-jamodel", "ferrite": "mnzn-ferrite-jamodel"}[src]
        df = pd.read_csv(EXT / folder / "loops.csv")
        df = df[df["loop_index"] == int(idx)]
    h, b = df["H_A_per_m"].to_numpy(float), df["B_T"].to_numpy(float)
    tol = 0.01 * np.abs(h).max()
    span = np.ptp(h)
    full = [(d, i) for d, i in legs(h, tol) if np.ptp(h[i]) > 0.97 * span]
    desc = [i for d, i in full if d < 0]
    asc = [i for d, i in full if d > 0]
    if not desc or not asc:
        raise RuntimeError(f"{name}: no full descending and ascending leg")
    hd, bd = np.concatenate([h[i] for i in desc]), np.concatenate([b[i] for i in desc])
    ha, ba = np.concatenate([h[i] for i in asc]), np.concatenate([b[i] for i in asc])
    hmax = 0.999 * min(hd.max(), ha.max(), -hd.min(), -ha.min())
    grid = np.linspace(-hmax, hmax, 801)
    b_desc, b_asc = _smooth_branch(hd, bd, grid), _smooth_branch(ha, ba, grid)
    b_desc, b_asc = _close_tips(grid, b_desc, b_asc)
    inner = np.abs(grid) <= 0.9 * hmax  # the source loop's own centre: (B_up(H) + B_down(-H)) / 2, averaged
    centre = float(np.mean(0.5 * (b_asc[inner] + np.interp(-grid[inner], grid, b_desc))))
    return {"name": name, "desc_idx": desc[0], "asc_idx": asc[0], "h": h, "b": b, "grid": grid,
            "b_desc": b_desc, "b_asc": b_asc, "hmax": hmax, "bpeak": float(max(b_desc.max(), -b_asc.min())),
            "centre_T": centre}


def _close_tips(grid, b_desc, b_asc, frac=0.05):
    """Make the branches meet at both tips (a major loop closes there): each is pulled to the mean tip value by a
    linear ramp over the last `frac` of the range; where noise leaves the ascending branch above the descending
    one, both take their mean."""
    hmax = grid[-1]
    w = np.clip((np.abs(grid) - (1 - frac) * hmax) / (frac * hmax), 0, 1)
    top, bot = grid > 0, grid < 0
    for tip, sel in ((-1, bot), (0, top)):
        mean = 0.5 * (b_desc[tip] + b_asc[tip])
        b_desc = b_desc + np.where(sel, w * (mean - b_desc[tip]), 0.0)
        b_asc = b_asc + np.where(sel, w * (mean - b_asc[tip]), 0.0)
    bad = b_asc > b_desc
    mid = 0.5 * (b_asc + b_desc)
    return np.where(bad, mid, b_desc), np.where(bad, mid, b_asc)


def branch_b(core: dict, h: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Static B on the major loop: the ascending branch where H rises, the descending one where it falls."""
    up = np.interp(h, core["grid"], core["b_asc"])
    down = np.interp(h, core["grid"], core["b_desc"])
    return np.where(direction > 0, up, down)


CORES = ([f"gd_L{i}" for i in GD_HELD_OUT] + [f"m130_L{i}" for i in range(3)]
         + [f"ferrite_L{i}" for i in range(4)] + ["hiperco50_L0"])


# ----------------------------------------------------------------------------------------------- protocols
def current_path(protocol: str, i_max: float) -> tuple[np.ndarray, int]:
    """Applied currents and the direction of the branch the core sits on at the first reading."""
    def seg(a, b, n):
        return np.linspace(a, b, n + 1)[1:]
    if protocol == "tip12":
        q = 12
        cur = np.concatenate([[-i_max], seg(-i_max, i_max, 2 * q), seg(i_max, -i_max, 2 * q),
                              seg(-i_max, i_max, 2 * q)])
        return cur, +1
    if protocol == "zero25":
        q = 25
        cur = np.concatenate([[0.0], seg(0, i_max, q), seg(i_max, -i_max, 2 * q), seg(-i_max, i_max, 2 * q)])
        return cur, +1
    q = 12
    cur = np.concatenate([[0.0], seg(0, -i_max, q), seg(-i_max, i_max, 2 * q), seg(i_max, -i_max, 2 * q),
                          seg(-i_max, i_max, 2 * q)])
    return cur, -1


def directions(cur: np.ndarray, first: int) -> np.ndarray:
    d = np.sign(np.diff(cur, prepend=cur[0]))
    d[0] = first
    for i in range(1, d.size):
        if d[i] == 0:
            d[i] = d[i - 1]
    return d


def eddy_sweep(core, n_per_m, cur, dirs, dwell, tau, slew, read_frac, sub=200) -> np.ndarray:
    """The flux relaxes towards the static B of the applied current: dB/dt = (B_static(I(t)) - B) / tau. The
    current slews linearly over the first `slew` of each dwell, then holds; the reading is taken at `read_frac`
    of the dwell. The core has settled at the first current before the sweep."""
    b = branch_b(core, n_per_m * cur[:1], dirs[:1])[0]
    out = np.empty(cur.size)
    out[0] = b
    ts = (np.arange(sub) + 0.5) / sub
    decay = np.exp(-dwell / sub / tau)
    for k in range(1, cur.size):
        frac = np.clip(ts / slew, 0, 1) if slew > 0 else np.ones(sub)
        i_t = cur[k - 1] + (cur[k] - cur[k - 1]) * frac
        target = branch_b(core, n_per_m * i_t, np.full(sub, dirs[k]))
        read_at = int(round(read_frac * sub))
        for j in range(sub):
            b = target[j] + (b - target[j]) * decay
            if j + 1 == read_at:
                out[k] = b
    return out


def equivalent_lag(dwell, tau, slew, read_frac, n=60) -> float:
    """The per-step lag L of a discrete filter B_k = (1 - L) T_k + L B_(k-1) with the same delay on a steady
    ramp as this continuous relaxation: delay d steps, L = d / (1 + d) (= exp(-dwell/tau) for an instant step
    read at the end of the dwell)."""
    core = {"grid": np.array([-1e9, 1e9]), "b_asc": np.array([-1e9, 1e9]), "b_desc": np.array([-1e9, 1e9])}
    cur = np.arange(n, dtype=float)
    out = eddy_sweep(core, 1.0, cur, np.ones(n), dwell, tau, slew, read_frac)
    d = cur[-1] - out[-1]
    return float(d / (1 + d))


# ----------------------------------------------------------------------------------------------- Hall sweeps
def hall_case(core: dict, protocol: str, fault: str, rng, noise_rng) -> tuple[dict, dict]:
    """One stepped Hall sweep of `core`: the case's files' content and its key."""
    supply = float(rng.choice([3.3, 5.0]))
    vq = supply / 2
    out_min, out_max = (0.2, 3.1) if supply == 3.3 else (0.25, 4.75)
    i_max = float(rng.choice([1.5, 2.0, 3.0, 5.0, 10.0]))
    n_per_m = core["hmax"] / i_max
    swing = rng.uniform(0.45, 0.65) * vq
    sens = swing / core["bpeak"]
    dwell = float(np.exp(rng.uniform(np.log(0.3), np.log(3.0))))
    noise_v = rng.uniform(0.5e-3, 3e-3)
    bits = int(rng.choice([10, 11, 12]))
    cur, first = current_path(protocol, i_max)
    dirs = directions(cur, first)
    t_read = dwell * (np.arange(cur.size) + 1.0)
    b_static = branch_b(core, n_per_m * cur, dirs)
    b = b_static.copy()
    key = {"fault": fault, "truth": TRUTH.get(fault, "none"), "variant": ""}
    v_add = np.zeros(cur.size)
    decl_max = out_max
    if fault == "hall_offset":
        frac = np.exp(rng.uniform(np.log(0.005), np.log(0.08))) * rng.choice([-1.0, 1.0])
        dv = frac * swing
        v_add[:] = dv
        key.update(size=dv / sens, size_frac_peak=frac)
    elif fault == "thermal_drift":
        bound = DRIFT_BOUND_PER_V_SUPPLY * supply
        r0 = rng.uniform(0.2, 0.95) * bound * rng.choice([-1.0, 1.0])
        dur = t_read[-1]
        if rng.random() < 2 / 3:
            tau = dur * float(np.exp(rng.uniform(np.log(0.3), np.log(3.0))))
            v_add = r0 * tau * (1 - np.exp(-t_read / tau))
            key.update(variant="exp", tau_s=tau)
        else:
            v_add = r0 * t_read
            key.update(variant="linear")
        ls = np.polyfit(t_read, v_add, 1)[0]
        mean = (v_add[-1] - v_add[0]) / (t_read[-1] - t_read[0])
        key.update(size=mean / sens, size_ls=ls / sens, rate0_T_per_s=r0 / sens, rate0_V_per_s=r0,
                   bound_V_per_s=bound, total_T=(v_add[-1] - v_add[0]) / sens)
    elif fault == "eddy_lag":
        q = rng.uniform(0.1, 0.5)
        tau = -dwell / np.log(q)
        if rng.random() < 0.5:
            slew, read_frac, var = rng.uniform(0.0, 0.2), 1.0, "end"
        else:
            slew, read_frac, var = 0.0, 0.5, "mid"
            t_read = dwell * (np.arange(cur.size) + 0.5)
        b = eddy_sweep(core, n_per_m, cur, dirs, dwell, tau, slew, read_frac)
        key.update(variant=var, size=equivalent_lag(dwell, tau, slew, read_frac), lag_physical=q, tau_e_s=tau,
                   slew_frac=slew, read_frac=read_frac)
    v = vq + sens * b + v_add + noise_v * noise_rng.standard_normal(cur.size)
    if fault in ("sat_hard", "sat_soft"):
        if fault == "sat_hard":
            level, w = rng.uniform(0.80, 0.95), 0.0
        else:
            w = rng.uniform(0.05, 0.10)
            level = rng.uniform(0.78, 0.95 / (1 + w))
        decl_max = vq + level * swing
        width = w * level * swing
        v = soft_rail(v, decl_max, width)
        key.update(variant="hard" if w == 0 else "soft", size=level * core["bpeak"], size_frac_peak=level,
                   knee_frac=w, rail_V=decl_max)
    lsb = ADC_SPAN_V / 2 ** bits
    v = np.clip(np.round(v / lsb), 0, 2 ** bits - 1) * lsb
    side = {"supply_V": supply, "coil_turns_per_m": round(n_per_m, 6), "dwell_s": round(dwell, 6),
            "provenance": "SYNTHETIC - bench/heldout_realcores.py: a measured loop of data/external through an "
                          "independent held-out sensor chain",
            "sensors": {"hall1": {"sensitivity_V_per_T": round(sens, 9), "quiescent_V": vq,
                                  "output_min_V": out_min, "output_max_V": round(decl_max, 6)}}}
    if protocol == "tip12":
        side["start_state"] = "cycled"
        side["preconditioning"] = {"cycles": 3, "i_peak_A": i_max, "bipolar": True}
    sigma_b = np.hypot(noise_v, lsb / np.sqrt(12)) / sens
    key.update(protocol=protocol, supply_V=supply, sens_V_per_T=sens, dwell_s=dwell, noise_V=noise_v, adc_bits=bits,
               i_max_A=i_max, n_samples=int(cur.size), peak_T=core["bpeak"], sigma_T=sigma_b,
               declared_start=protocol == "tip12", duration_s=float(t_read[-1]))
    key["fault_rms_sigma"] = _fault_sigma(v, vq, sens, b_static, sigma_b) if fault != "clean" else 0.0
    return {"kind": "hall", "time": t_read, "current": cur, "volts": v, "side": side}, key


def soft_rail(v: np.ndarray, rail: float, w: float) -> np.ndarray:
    """An output stage that bends smoothly (C1, quadratic) from rail - w to the rail, flat above it; w = 0: a hard
    clip."""
    if w <= 0:
        return np.minimum(v, rail)
    x = v - (rail - w)
    bent = v - np.clip(x, 0, 2 * w) ** 2 / (4 * w)
    return np.where(x >= 2 * w, rail, bent)


def _fault_sigma(v, vq, sens, b_static, sigma_b) -> float:
    """RMS of what the fault changed in the recorded B (noise removed only in expectation), in noise sigmas."""
    diff = (v - vq) / sens - b_static
    excess = max(np.mean(diff ** 2) - sigma_b ** 2, 0.0)
    return float(np.sqrt(excess) / sigma_b)


# ----------------------------------------------------------------------------------------------- B(H) loops
def bh_case(core: dict, fault: str, rng) -> tuple[dict, dict]:
    """A closed B(H) loop from a tip (its measured samples, resampled) with an optional B-channel fault."""
    h, b = core["h"], core["b"]
    d_i, a_i = core["desc_idx"], core["asc_idx"]
    start_top = bool(rng.random() < 0.5)
    first, second = (d_i, a_i) if start_top else (a_i, d_i)
    how = "arc" if rng.random() < 0.5 else "kth"
    n_total = int(rng.integers(200, 301))
    parts = []
    for j, idx in enumerate((first, second)):
        hh, bb = h[idx], b[idx]
        if how == "arc":
            s = np.concatenate([[0], np.cumsum(np.hypot(np.diff(hh) / core["hmax"], np.diff(bb) / core["bpeak"]))])
            u = np.linspace(0, s[-1], n_total // 2 + 1)
            hh, bb = np.interp(u, s, hh), np.interp(u, s, bb)
        else:
            k = max(1, int(np.ceil((h[first].size + h[second].size) / n_total)))
            keep = np.unique(np.concatenate([np.arange(0, hh.size, k), [hh.size - 1]]))
            hh, bb = hh[keep], bb[keep]
        parts.append((hh[1:], bb[1:]) if j else (hh, bb))
    hh, bb = np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
    clean = bb.copy()
    peak = float(np.max(np.abs(bb)))
    key = {"fault": fault, "truth": TRUTH.get(fault, "none"), "variant": how + (" +tip" if start_top else " -tip"),
           "n_samples": int(hh.size), "peak_T": peak, "protocol": "bh"}
    if fault == "offset":
        frac = rng.uniform(0.03, 0.10) * rng.choice([-1.0, 1.0])
        bb = bb + frac * peak
        key.update(size=frac * peak, size_frac_peak=frac)
    elif fault in ("clip_hard", "clip_soft"):
        w = 0.0 if fault == "clip_hard" else rng.uniform(0.05, 0.10)
        level = rng.uniform(0.80, 0.95) if w == 0 else rng.uniform(0.78, 0.95 / (1 + w))
        both = bool(rng.random() < 0.5)
        c = level * peak
        bb = soft_rail(bb, c, w * c)
        if both:
            bb = -soft_rail(-bb, c, w * c)
        key.update(size=c, size_frac_peak=level, knee_frac=w, rails="both" if both else "top")
    key["fault_rms_T"] = float(np.sqrt(np.mean((bb - clean) ** 2)))
    return {"kind": "bh", "h": hh, "b": bb}, key


# ----------------------------------------------------------------------------------------------- writing
def write_case(folder: Path, name: str, case: dict) -> Path:
    path = folder / f"{name}.csv"
    with path.open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        if case["kind"] == "bh":
            w.writerow(["H_A_per_m", "B_T"])
            for hv, bv in zip(case["h"], case["b"]):
                w.writerow([f"{hv:.8g}", f"{bv:.8g}"])
        else:
            w.writerow(["step", "time_s", "current_A", "hall1_V"])
            for i, (t, c, v) in enumerate(zip(case["time"], case["current"], case["volts"])):
                w.writerow([i, f"{t:.6f}", f"{c:.10g}", f"{v:.10g}"])
            path.with_suffix(".json").write_text(json.dumps(case["side"], indent=1, sort_keys=True) + "\n")
    return path


def plan() -> list[tuple[str, str, str]]:
    """(core, kind, fault/protocol) of every case: every core clean on every protocol and as a B(H) loop; each Hall
    fault on one protocol per core, rotated; each B(H) fault once per core."""
    jobs = []
    for j, core in enumerate(CORES):
        jobs += [(core, p, "clean") for p in PROTOCOLS]
        jobs += [(core, PROTOCOLS[(j + c) % 3], f) for c, f in enumerate(HALL_FAULTS)]
        jobs += [(core, "bh", "clean")] + [(core, "bh", f) for f in BH_FAULTS]
    return jobs


def generate(folder: Path, seed: int, only: list[str] | None = None) -> list[dict]:
    """Every case from its own child generator keyed by (seed, core, protocol, fault): same seed, same files."""
    cores, rows = {}, []
    for n, (core, proto, fault) in enumerate(plan()):
        if only and core not in only:
            continue
        if core not in cores:
            cores[core] = load_core(core)
        ckey = [seed, CORES.index(core), (PROTOCOLS + ("bh",)).index(proto),
                (("clean",) + HALL_FAULTS + BH_FAULTS).index(fault)]
        rng, noise_rng = np.random.default_rng(ckey), np.random.default_rng(ckey + [1])
        case, key = bh_case(cores[core], fault, rng) if proto == "bh" else hall_case(cores[core], proto, fault,
                                                                                      rng, noise_rng)
        name = f"hrc_{n:03d}_{core}_{proto}_{fault}"
        rows.append(dict(key, case=name, core=core, source_centre_T=cores[core]["centre_T"],
                         file=str(write_case(folder, name, case))))
    return rows


# ----------------------------------------------------------------------------------------------- diagnosis
def run_one(row: dict, workflow: str, timeout: float) -> dict:
    """One `python -m mrhyst diagnose` subprocess; its CPU s (user + sys, from wait4) and the JSON's fields."""
    out = Path(row["file"]).with_suffix(".diag.json")
    env = dict(os.environ, PYTHONPATH=workflow, NUMBA_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MPLBACKEND="agg")
    cmd = [sys.executable, "-m", "mrhyst", "diagnose", row["file"], "--out", str(out), "--quiet"]
    if row["protocol"] != "bh":
        cmd[5:5] = ["--sensor", "hall1"]
    t0 = time.perf_counter()
    with open(out.with_suffix(".err"), "w") as err:
        p = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=err)
        timer = threading.Timer(timeout, p.kill)
        timer.start()
        _, status, ru = os.wait4(p.pid, 0)
        timer.cancel()
    rc = os.waitstatus_to_exitcode(status)
    row = dict(row, wall_s=round(time.perf_counter() - t0, 2), cpu_s=round(ru.ru_utime + ru.ru_stime, 2), rc=rc)
    if rc != 0 or not out.exists():
        lines = out.with_suffix(".err").read_text().strip().splitlines() or [""]
        return dict(row, effect="error", error=lines[-1][:300])
    return dict(row, **read_diag(json.loads(out.read_text()), row["truth"]))


def _size_of(d: dict, effect: str):
    """The size the diagnosis gives `effect`: effect_size when it is the verdict, else its layered increment's."""
    es = d.get("effect_size") or {}
    if d.get("effect") == effect and es.get("value") is not None:
        return es.get("value"), "effect_size"
    sec = d.get("secondary") or {}
    if sec.get("accepted") and sec.get("effect") == effect and (sec.get("size") or {}).get("value") is not None:
        return sec["size"]["value"], "secondary"
    inc = (((d.get("layers") or {}).get("evidence") or {}).get("increments") or {}).get(effect) or {}
    if inc.get("size") is not None:
        return inc["size"], "increment"
    for u in ((d.get("layers") or {}).get("verdict") or {}).get("unseparated") or []:
        if u.get("effect") == effect and u.get("size") is not None:
            return u["size"], "unseparated"
    return None, ""


def _r1(x):
    return None if x is None else round(float(x), 1)


def read_diag(d: dict, truth: str) -> dict:
    nm = d.get("next_measurement") or {}
    bud = d.get("budget") or {}
    part = d.get("partial") or {}
    amb = list(d.get("ambiguous_with") or [])
    size, size_from = _size_of(d, truth) if truth != "none" else (None, "")
    sigs = d.get("signatures") or []
    inc = (((d.get("layers") or {}).get("evidence") or {}).get("increments") or {}).get(truth) or {}
    checks = (((d.get("layers") or {}).get("verdict") or {}).get("checks") or {}).get(truth)
    sec = d.get("secondary") or {}
    return {"effect": d.get("effect"), "ambiguous_with": "|".join(amb), "next_measurement": nm.get("protocol") or "",
            "secondary": sec.get("effect") or "" if sec.get("accepted") else "",
            "secondary_size": (sec.get("size") or {}).get("value") if sec.get("accepted") else None,
            "partial_effect": part.get("effect") or "", "partial_failed": "|".join(part.get("failed") or []),
            "material_T": bud.get("material_T"), "measurement_T": bud.get("measurement_T"),
            "left_T": bud.get("left_T"), "budget_base": bud.get("base") or "",
            "noise_floor_T": d.get("noise_floor_T"), "rms_before_T": d.get("rms_before_T"),
            "rms_after_T": d.get("rms_after_T"), "judged_on": (d.get("layers") or {}).get("judged_on") or "",
            "signatures": "|".join(f"{s.get('kind')}:{_r1(s.get('sigma'))}" for s in sigs),
            "size_found": size, "size_from": size_from, "verdict_size": (d.get("effect_size") or {}).get("value"),
            "inc_bic_gain": inc.get("bic_gain"), "inc_checks": json.dumps(checks) if checks is not None else "",
            "start_state": (d.get("start_state") or {}).get("source", ""), "verdict": (d.get("verdict") or "")[:400]}


# ----------------------------------------------------------------------------------------------- scoring
def score(row: dict) -> dict:
    """named: the truth is the verdict, its accepted second effect (``secondary``: a drift beside the remanent start of
    an undeclared start, the physics), or in ambiguous_with with a next measurement; size_err: |found - true| / |true|
    (also against the drift's least-squares slope and the physical lag; an offset's true size is the one added
    plus the source loop's own centre, :func:`load_core`, the added one alone its alt size); false_alarm on a
    clean case: a measurement fault named as the verdict; false_alarm_remanent: the same, less those on an
    undeclared start that carry remanent_start (the physics) in ambiguous_with with a next measurement;
    false_alarm_source: false_alarm less a hall_offset the source loop itself shows (its own centre,
    :func:`load_core`, has the named offset's sign and at least half its size: the test the diagnosis's layered
    rule makes on the sweep, made here on the source; a "clean" case carries the offset of the lab that measured
    its core)."""
    truth, eff = row["truth"], row.get("effect")
    out = {"named": "", "size_err": "", "size_err_alt": "", "false_alarm": "", "false_alarm_remanent": "",
           "false_alarm_source": "", "in_ambiguous": ""}
    sec = row.get("secondary") or ""
    if truth == "none":  # a measurement fault named as the verdict or as its accepted second effect
        fault = eff in MEASUREMENT or sec in MEASUREMENT
        out["false_alarm"] = int(fault)
        remanent = (str(row.get("declared_start")) in ("False", "false", "0") and bool(row.get("next_measurement"))
                    and "remanent_start" in (row.get("ambiguous_with") or "").split("|"))
        out["false_alarm_remanent"] = int(fault and not remanent)
        other = sec if eff == "hall_offset" else eff  # the fault named beside the offset the source bears out
        out["false_alarm_source"] = int(fault and not (_source_offset(row) and other not in MEASUREMENT))
        out["in_ambiguous"] = int(any(a in MEASUREMENT for a in (row.get("ambiguous_with") or "").split("|")))
        return out
    amb = (row.get("ambiguous_with") or "").split("|")
    named = eff == truth or sec == truth or (truth in amb and bool(row.get("next_measurement")))
    out["named"] = int(named)
    found = row.get("size_found")
    if named and found not in (None, ""):
        found, true = float(found), float(row["size"])
        alt = row.get("size_ls") if truth == "thermal_drift" else row.get("lag_physical")
        if truth == "hall_offset" and row.get("source_centre_T") not in (None, ""):  # the data's offset: the
            true, alt = true + float(row["source_centre_T"]), true  # added one + the source loop's own centre
        out["size_err"] = round(abs(found - true) / abs(true), 4)
        if alt not in (None, ""):
            out["size_err_alt"] = round(abs(found - float(alt)) / abs(float(alt)), 4)
    return out


def _source_offset(row: dict) -> bool:
    """A hall_offset verdict (or accepted second effect) the source loop's own centre bears out (same sign, at least
    half the size)."""
    size = row.get("verdict_size") if row.get("effect") == "hall_offset" else row.get("secondary_size")
    c = row.get("source_centre_T")
    if "hall_offset" not in (row.get("effect"), row.get("secondary")) or size in (None, "") or c in (None, ""):
        return False
    size, c = float(size), float(c)
    return size * c > 0 and abs(c) >= 0.5 * abs(size)


def _cls(r: dict) -> str:
    if r["protocol"] == "bh":
        return f"bh:{r['fault']}"
    var = f"/{r['variant']}" if r.get("variant") else ""
    return f"hall:{r['fault']}{var}" if r["fault"] != "clean" else f"hall:clean/{r['protocol']}"


def summarise(rows: list[dict], tol: float) -> str:
    head = (f"{'class':<26}{'n':>4}{'named':>12}{'size<=25%':>12}{'alt size':>10}{'false al.':>11}"
            f"{'excl. rem.':>11}{'excl. src.':>11}  "
            f"{'material/measurement/left mT (mean)':<37}verdicts")
    lines = [head]
    classes = sorted({_cls(r) for r in rows}, key=lambda c: (c.startswith("bh"), c))
    groups = [(c, [r for r in rows if _cls(r) == c]) for c in classes]
    groups += [("HALL faults", [r for r in rows if r["protocol"] != "bh" and r["truth"] != "none"]),
               ("B(H) faults", [r for r in rows if r["protocol"] == "bh" and r["truth"] != "none"]),
               ("ALL faults", [r for r in rows if r["truth"] != "none"]),
               ("ALL clean", [r for r in rows if r["truth"] == "none"])]
    for name, rs in groups:
        if not rs:
            continue
        f = [r for r in rs if r["truth"] != "none"]
        c = [r for r in rs if r["truth"] == "none"]
        named = sum(int(r["named"] or 0) for r in f)
        sized = [r for r in f if r["size_err"] != ""]
        ok = sum(float(r["size_err"]) <= tol for r in sized)
        alt = [r for r in f if r["size_err_alt"] != ""]
        ok_alt = sum(float(r["size_err_alt"]) <= tol for r in alt)
        fa = sum(int(r["false_alarm"] or 0) for r in c)
        fa2 = sum(int(r.get("false_alarm_remanent") or 0) for r in c)
        fa3 = sum(int(r.get("false_alarm_source") or 0) for r in c)
        bud = [np.nanmean([float(r.get(k)) if r.get(k) not in (None, "") else np.nan for r in rs]) * 1e3
               for k in ("material_T", "measurement_T", "left_T")]
        cnt = {}
        for r in rs:
            cnt[r.get("effect") or "error"] = cnt.get(r.get("effect") or "error", 0) + 1
        lines.append(f"{name:<26}{len(rs):>4}"
                     f"{(f'{named}/{len(f)}' if f else '-'):>12}{(f'{ok}/{len(sized)}' if f else '-'):>12}"
                     f"{(f'{ok_alt}/{len(alt)}' if alt else '-'):>10}{(f'{fa}/{len(c)}' if c else '-'):>11}"
                     f"{(f'{fa2}/{len(c)}' if c else '-'):>11}{(f'{fa3}/{len(c)}' if c else '-'):>11}  "
                     f"{'/'.join(f'{x:.2f}' for x in bud):<37}"
                     + ", ".join(f"{k} {v}" for k, v in sorted(cnt.items(), key=lambda kv: -kv[1])))
    return "\n".join(lines)


LEGEND = ('named: the fault is the verdict, its accepted second effect, or in ambiguous_with with a next '
          'measurement; size<=25%: of those named with a size (drift: the mean rate over the sweep; lag: the '
          "per-step lag with the same delay on a steady ramp; offset: the one added plus the source loop's own "
          "centre, the B offset the data carry); alt size: against the drift's least-squares slope / the "
          'physical exp(-dwell/tau_e) / the added offset alone; false al.: a measurement fault named on a clean'
          ' case (the verdict or its accepted second effect); excl. rem.: less those on an undeclared start '
          'that carry remanent_start with a next measurement; excl. src.: false al. less a hall_offset the '
          "source loop's own centre shows (same sign, at least half the named size: the offset of the lab that "
          'measured the core)')


FIELDS = ["case", "core", "protocol", "fault", "variant", "truth", "size", "size_ls", "lag_physical",
          "size_frac_peak", "fault_rms_sigma", "fault_rms_T", "sigma_T", "noise_floor_T", "effect", "ambiguous_with",
          "next_measurement", "secondary", "secondary_size", "named", "size_found", "size_from", "size_err",
          "size_err_alt", "false_alarm", "false_alarm_remanent", "false_alarm_source", "in_ambiguous",
          "partial_effect", "partial_failed", "material_T", "measurement_T",
          "left_T", "budget_base", "judged_on", "rms_before_T", "rms_after_T", "signatures", "inc_bic_gain",
          "inc_checks", "start_state", "declared_start", "dwell_s", "duration_s", "n_samples", "supply_V",
          "sens_V_per_T", "noise_V", "adc_bits", "i_max_A", "tau_s", "tau_e_s", "rate0_T_per_s", "total_T",
          "knee_frac", "rails", "source_centre_T", "verdict_size", "wall_s", "cpu_s", "rc", "error", "verdict", "file"]


def tree_commit(workflow: str) -> str:
    def git(*a):
        return subprocess.run(["git", "-C", workflow, *a], capture_output=True, text=True).stdout.strip()
    head = git("rev-parse", "--short", "HEAD") or "unknown"
    return head + (" (+ uncommitted changes)" if git("status", "--porcelain", "--", ".") else "")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="/tmp/heldout_realcores.csv", help="per-case CSV (a .json beside it)")
    ap.add_argument("--cases-dir", default=None, help="where the cases go (default: a fresh temp folder)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cores", default="", help="comma-separated subset of " + ",".join(CORES))
    ap.add_argument("--workflow", default=str(ROOT / "workflow"), help="the mrhyst tree to test (PYTHONPATH)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=300.0)
    ap.add_argument("--size-tol", type=float, default=0.25)
    ap.add_argument("--generate-only", action="store_true")
    ap.add_argument("--from-csv", default=None, help="only print the table of an earlier run's per-case CSV")
    a = ap.parse_args(argv)
    if a.from_csv:
        with open(a.from_csv) as f:
            rows = [dict(r, **score(dict(r, size=float(r["size"] or "nan")))) for r in csv.DictReader(f)]
        print(LEGEND + "\n\n" + summarise(rows, a.size_tol))
        return 0
    only = [c for c in a.cores.split(",") if c]
    bad = [c for c in only if c not in CORES]
    if bad:
        sys.stderr.write(f"heldout_realcores: error: --cores: unknown {','.join(bad)}\n")
        return 2
    folder = Path(a.cases_dir or tempfile.mkdtemp(prefix="hrc_cases_"))
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    rows = generate(folder, a.seed, only)
    print(f"{len(rows)} cases in {folder} (seed {a.seed}), generated in {time.perf_counter() - t0:.1f} s")
    if a.generate_only:
        return 0
    print(f"diagnosing with {a.workflow} at commit {tree_commit(a.workflow)}, {a.jobs} jobs ...", flush=True)
    t0 = time.perf_counter()
    with ThreadPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(lambda r: run_one(r, a.workflow, a.timeout), rows))
    wall = time.perf_counter() - t0
    rows = [dict(r, **score(r)) for r in rows]
    with open(a.out, "w", newline="") as f:
        w = csv.DictWriter(f, FIELDS, extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    Path(a.out).with_suffix(".json").write_text(json.dumps(rows, indent=1, default=float) + "\n")
    cpu = [r["cpu_s"] for r in rows]
    print(f"diagnosed in {wall:.0f} s wall, {sum(cpu):.0f} CPU s (per case median {np.median(cpu):.2f}, max "
          f"{max(cpu):.2f} CPU s; shared machine)\n")
    print(LEGEND + "\n\n" + summarise(rows, a.size_tol))
    print(f"\nper-case rows: {a.out} (and {Path(a.out).with_suffix('.json')})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
