"""Held-out open-world check of `mrhyst diagnose` on generators the project never saw (issue 12).

Writes raw Hall sweeps (ARCHITECTURE 4: NAME.csv + NAME.json) from core and sensor laws that are NOT
Jiles-Atherton and not the project's own open-world generators, runs `python -m mrhyst diagnose` on each
(a subprocess; the mrhyst tree is chosen with --workflow, default /work/main/workflow), and prints per
mechanism how often a measurement-chain effect was named (false attribution), model_form, unexplained, none;
plus a small in-vocabulary control set (a Hall offset or a linear drift on a non-J-A core).

Independence: the generator below imports nothing from mrhyst and was written without reading the
diagnosis, the blind generators, the rig or the effect registry; only the file formats and the CLI are shared.

    python bench/heldout_openworld.py --out /tmp/heldout.csv [--seed 0] [--cases-per-mechanism 12] [--repeated]

``--repeated``: every sweep runs its cycle twice (0 -> 2 -> 0 -> 2 -> 0 A; bipolar: the virgin rise, then two cycles
+2 -> -2 -> +2 A), the protocol a lab repeats to tell a drift from a shape. Measured (99e5396 + the zero-field row,
2026-11-27, seed 7, --mechanisms hall_selfheat --cases-per-mechanism 16): the self-heated Hall gain named
thermal_drift on 2 of 9 unipolar sweeps, and on none of 7 bipolar ones (there it scales the loop, an offset drift
shifts it); the column ``next`` shows the zero-field reading carried beside such a drift.
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

MU0 = 4e-7 * np.pi
SUPPLY_V, QUIESCENT_V, SENS_V_PER_T = 3.3, 1.65, 5.0
OUT_MIN_V, OUT_MAX_V, ADC_BITS = 0.2, 3.1, 12
I_MAX, N_EACH = 2.0, 26          # 0 -> 2 A in 26 steps (27 currents each way, 53 samples)
B_CEIL = 0.26                    # peak |B| kept below the sensor's linear range (1.45 V / 5 V/T = 0.29 T)
MEASUREMENT = {"hall_offset", "remanent_start", "eddy_lag", "thermal_drift", "sensor_saturation", "air_gap"}
# Nearest kin: a vocabulary effect that shares part of the mechanism's physics (still counted as a false
# attribution; the table also gives the rate without these). The self-heated Hall gain is a thermal error of the
# chain (but a gain, bound to I^2, not an additive drift); the leakage network does contain a gap (but the miss
# comes from the steel's saturation and the leakage); the heated core is thermal (but in the core, not the Hall).
KIN = {"hall_selfheat": {"thermal_drift"}, "leakage": {"air_gap"}, "thermal_permeability": {"thermal_drift"}}


# ----------------------------------------------------------------------------------------------- protocol
REPEAT = {"cycles": 1}  # --repeated: 2


def current_path(bipolar: bool) -> np.ndarray:
    """0 -> +2 -> 0 (53 samples) or 0 -> +2 -> -2 -> +2 A (131 samples), equal current steps; with --repeated the
    cycle twice (0 -> 2 -> 0 -> 2 -> 0; the virgin rise, then +2 -> -2 -> +2 twice)."""
    up = np.linspace(0.0, I_MAX, N_EACH + 1)
    if not bipolar:
        one = up[-2::-1]
        return np.concatenate([up, *([one] + [np.concatenate([up[1:], one])] * (REPEAT["cycles"] - 1))])
    full = np.linspace(I_MAX, -I_MAX, 2 * N_EACH + 1)
    cyc = np.concatenate([full[1:], full[-2::-1]])
    return np.concatenate([up, *([cyc] * REPEAT["cycles"])])


def coil_temperature(current: np.ndarray, dwell: float, rise_ss: float, tau: float) -> np.ndarray:
    """First-order Joule heating: tau dT/dt = rise_ss (I/Imax)^2 - T, current held for a dwell, read at its end."""
    decay, temp, out = np.exp(-dwell / tau), 0.0, np.empty_like(current)
    for i, cur in enumerate(current):
        target = rise_ss * (cur / I_MAX) ** 2
        temp = target + (temp - target) * decay
        out[i] = temp
    return out


# ----------------------------------------------------------------------------------------------- core laws
def stoner_wohlfarth(h_field: np.ndarray, hk: np.ndarray, psi: np.ndarray, rng) -> np.ndarray:
    """Mean cos(theta) along the field of 2-D Stoner-Wohlfarth particles (easy axis at psi, field hk each),
    from a demagnetised start (half the moments along each end of their axis), relaxed at every step."""
    theta = psi + np.pi * (rng.random(psi.size) < 0.5)
    out = np.empty(h_field.size)
    for i, hf in enumerate(h_field):
        h = hf / hk
        eta = 0.4 / (1.0 + np.abs(h))
        for _ in range(400):
            theta = theta - eta * (0.5 * np.sin(2.0 * (theta - psi)) + h * np.sin(theta))
        out[i] = np.mean(np.cos(theta))
    return out


def preisach(h_field: np.ndarray, density, h_span: float, n: int = 160) -> np.ndarray:
    """Normalised output (-1..1) of a Preisach grid of n x n hysterons (up at alpha, down at beta, alpha >= beta)
    over [-h_span, h_span] with weight density(alpha, beta), from the demagnetised (alpha + beta = 0) state."""
    g = np.linspace(-h_span, h_span, n)
    alpha, beta = np.meshgrid(g, g, indexing="ij")
    keep = alpha >= beta
    w = np.where(keep, density(alpha, beta), 0.0)
    w /= w.sum()
    s = np.where(alpha + beta < 0, 1.0, -1.0)
    s[np.isclose(alpha + beta, 0.0)] = 0.0
    out = np.empty(h_field.size)
    for i, hf in enumerate(h_field):
        s[alpha <= hf] = 1.0
        s[beta >= hf] = -1.0
        out[i] = float((w * s).sum())
    return out


def jiles_atherton(h_field: np.ndarray, ms, a, alpha, c, k, sub: int = 400) -> np.ndarray:
    """Our own classic J-A (Langevin anhysteretic, dMirr/dHe = (Man - Mirr)/(delta k), clamped >= 0 after a
    reversal), midpoint-integrated with `sub` steps per sample; used only as the base core of sensor mechanisms."""
    def langevin(x):
        x = np.where(np.abs(x) < 1e-4, 1e-4, x)
        return 1.0 / np.tanh(x) - 1.0 / x

    def slope(h, m, delta):
        he = h + alpha * m
        man = ms * langevin(he / a)
        x = he / a if abs(he / a) > 1e-4 else 1e-4
        dman = ms / a * (1.0 / x ** 2 - 1.0 / np.sinh(x) ** 2)
        mirr = (m - c * man) / (1.0 - c)
        dirr = max((man - mirr) / (delta * k), 0.0)
        tot = (1.0 - c) * dirr + c * dman
        return tot / (1.0 - alpha * tot)

    m, h_prev, out = 0.0, 0.0, np.empty(h_field.size)
    for i, hf in enumerate(h_field):
        dh = (hf - h_prev) / sub
        delta = 1.0 if dh >= 0 else -1.0
        for j in range(sub if dh != 0 else 0):
            h0 = h_prev + j * dh
            k1 = slope(h0, m, delta)
            m = m + dh * slope(h0 + 0.5 * dh, m + 0.5 * dh * k1, delta)
        h_prev, out[i] = hf, m
    return out


def frohlich_kennelly(h, b_sat, mu_r):
    """Soft steel B(H): mu0 H + b_sat H / (h_k + |H|), initial relative permeability mu_r."""
    hk = b_sat / (MU0 * mu_r)
    return MU0 * h + b_sat * h / (hk + np.abs(h))


def leakage_network(h_app, b_sat, mu_r, area_ratio, gap, mu_fluid, leak):
    """Hall-gap flux density of a reluctance network: coil leg (steel, half the path) carries all the flux; it
    splits into the gap branch (return steel + MR-fluid gap of fraction `gap` of the path, area ratio
    steel/gap `area_ratio`) and a leakage permeance mu0 * leak across the coil window. Solved exactly on a
    dense B_gap grid (every term rises with B_gap), then read at the applied field."""
    def h_of_b(b):  # inverse of frohlich_kennelly for B >= 0
        hk = b_sat / (MU0 * mu_r)
        p = MU0 * hk + b_sat - b
        return (-p + np.sqrt(p * p + 4.0 * MU0 * b * hk)) / (2.0 * MU0)

    l1, l2 = 0.5, 0.5 - gap
    bg = np.linspace(0.0, 0.6, 6001)
    hg = bg / (MU0 * mu_fluid)
    mmf_gap_branch = h_of_b(bg / area_ratio) * l2 + hg * gap
    b1 = (bg + MU0 * leak * mmf_gap_branch) / area_ratio
    h_total = h_of_b(np.minimum(b1, 50.0)) * l1 + mmf_gap_branch
    return np.sign(h_app) * np.interp(np.abs(h_app), h_total, bg)


# ----------------------------------------------------------------------------------------------- mechanisms
def _ctx(rng, drive: str, dwell=(0.05, 0.5), bipolar_p=1 / 3) -> dict:
    """Sweep settings of one case: coil N/Le (paper 2500-4000 /m, or hard 1e4-1e5 /m log-uniform, redrawn while
    mu0 H alone would exceed 0.16 T at 2 A), path, dwell, white noise 0.075-0.3 mT."""
    while True:
        n_per_m = rng.uniform(2500, 4000) if drive == "paper" else 10 ** rng.uniform(4, 5)
        if MU0 * n_per_m * I_MAX < 0.16:
            break
    bip = bool(rng.random() < bipolar_p)
    cur = current_path(bip)
    dw = rng.uniform(*dwell)
    return {"current": cur, "h": n_per_m * cur, "hmax": n_per_m * I_MAX, "n_per_m": n_per_m, "bipolar": bip,
            "dwell": dw, "time": dw * np.arange(1, cur.size + 1), "noise_T": rng.uniform(0.075e-3, 0.3e-3)}


def _scaled(ctx, m_norm, rng, lo=0.04, hi=0.25):
    """B = mu0 (H + M), M = m_norm scaled so the peak |B| is drawn in [max(lo, 1.3 mu0 Hmax), hi]."""
    b_peak = rng.uniform(max(lo, 1.3 * MU0 * ctx["hmax"]), hi)
    m_scale = (b_peak / MU0 - ctx["hmax"]) / np.max(np.abs(m_norm))
    return MU0 * (ctx["h"] + m_scale * m_norm), {"b_peak_T": b_peak, "M_scale_A_per_m": m_scale}


def mech_stoner_wohlfarth(rng):
    """MR-fluid particles (and their chains) switch as single-domain-like units with shape anisotropy: a
    Stoner-Wohlfarth ensemble, log-normal anisotropy fields, random axes partly aligned along the field."""
    ctx = _ctx(rng, "paper" if rng.random() < 0.6 else "hard")
    n = 1500
    hk_med, s_ln, f_al = ctx["hmax"] * rng.uniform(0.4, 1.5), rng.uniform(0.2, 0.6), rng.uniform(0.0, 0.6)
    hk = hk_med * np.exp(s_ln * rng.standard_normal(n))
    psi = np.where(rng.random(n) < f_al, np.abs(0.2 * rng.standard_normal(n)), np.arccos(rng.random(n)))
    rev = rng.uniform(0.2, 1.5)
    m = stoner_wohlfarth(ctx["h"], hk, psi, rng) + rev * ctx["h"] / ctx["hmax"]
    b, p = _scaled(ctx, m, rng)
    return ctx, b, dict(p, hk_median_over_hmax=hk_med / ctx["hmax"], hk_sigma_ln=s_ln, aligned_frac=f_al,
                        reversible_over_sw=rev)


def mech_preisach_lorentz(rng):
    """The steel and particle domains as a Preisach population with a factorised Lorentzian switching-field
    density (Della Torre's heavy-tailed form) plus a reversible part; not the log-normal x normal density."""
    ctx = _ctx(rng, "paper" if rng.random() < 0.6 else "hard")
    hc, sig, rev = ctx["hmax"] * rng.uniform(0.2, 0.9), ctx["hmax"] * rng.uniform(0.08, 0.4), rng.uniform(0.2, 1.5)
    dens = lambda a, b: 1.0 / ((1 + ((a - hc) / sig) ** 2) * (1 + ((b + hc) / sig) ** 2))  # noqa: E731
    m = preisach(ctx["h"], dens, 3.0 * ctx["hmax"]) + rev * ctx["h"] / ctx["hmax"]
    b, p = _scaled(ctx, m, rng)
    return ctx, b, dict(p, hc_over_hmax=hc / ctx["hmax"], sigma_over_hmax=sig / ctx["hmax"], reversible=rev)


def mech_rayleigh(rng):
    """At the paper's 2 A the damper steel stays far below its coercive field: the Rayleigh law (uniform
    Preisach density, parabolic branches, remanence eta Hm^2 / 2), its hysteretic share drawn."""
    ctx = _ctx(rng, "paper")
    span, q = ctx["hmax"] * rng.uniform(1.3, 3.0), rng.uniform(0.15, 0.6)
    m_h = preisach(ctx["h"], lambda a, b: np.ones_like(a), span)
    m = q * m_h / np.max(np.abs(m_h)) + (1 - q) * ctx["h"] / ctx["hmax"]
    b, p = _scaled(ctx, m, rng)
    return ctx, b, dict(p, span_over_hmax=span / ctx["hmax"], hysteretic_share=q)


def mech_thermal_permeability(rng):
    """The coil heats with I^2 and the MR fluid (carrier expansion lowers the particle fraction) and steel lose
    permeability: an ideal soft Frohlich-Kennelly core whose M scales by (1 - kappa dT(t)) - field- and time-bound."""
    ctx = _ctx(rng, "paper" if rng.random() < 0.6 else "hard", dwell=(0.2, 0.5))
    knee, kappa = ctx["hmax"] * rng.uniform(0.3, 3.0), rng.uniform(1e-3, 4e-3)
    rate, tau = rng.uniform(0.5, 3.0), rng.uniform(20.0, 120.0)
    temp = coil_temperature(ctx["current"], ctx["dwell"], rate * tau, tau)
    m = ctx["h"] / ctx["hmax"] / (1 + np.abs(ctx["h"]) / knee) * (1 - kappa * temp)
    b, p = _scaled(ctx, m, rng)
    return ctx, b, dict(p, knee_over_hmax=knee / ctx["hmax"], kappa_per_K=kappa, heat_rate_K_per_s=rate,
                        tau_s=tau, dT_max_K=float(temp.max()))


def _ja_core(rng, ctx, lo, hi):
    """Our own J-A core (parameters relative to the peak field), redrawn until its peak |B| is in [lo, hi]."""
    for _ in range(200):
        hm = ctx["hmax"]
        a, k, c = hm * rng.uniform(1.0, 3.0), hm * rng.uniform(0.4, 1.5), rng.uniform(0.3, 0.7)
        ms = 10 ** rng.uniform(4.5, 6)
        alpha = rng.uniform(0.1, 0.6) * 3 * a / ms
        b = MU0 * (ctx["h"] + jiles_atherton(ctx["h"], ms, a, alpha, c, k, sub=100))
        if lo <= np.max(np.abs(b)) <= hi:
            return b, {"Ms": ms, "a": a, "alpha": alpha, "c": c, "k": k, "b_peak_T": float(np.max(np.abs(b)))}
    raise RuntimeError("no J-A core in range")


def mech_hall_selfheat(rng):
    """An uncompensated Hall element next to the coil (GaAs about -0.06 %/K, InSb up to -2 %/K at constant-voltage
    drive) loses sensitivity as the coil's I^2 heats it with a lag: a multiplicative, field- and time-bound gain
    error (tempco -0.1 to -0.5 %/K) on a J-A core."""
    ctx = _ctx(rng, "paper", dwell=(0.2, 0.5))
    b, p = _ja_core(rng, ctx, 0.04, 0.25)
    tc = -rng.uniform(1e-3, 5e-3)
    rate, tau = rng.uniform(1.0, 4.0), rng.uniform(10.0, 60.0)  # K/s at 2 A: the element sits on the coil's pole
    temp = coil_temperature(ctx["current"], ctx["dwell"], rate * tau, tau)
    return ctx, b * (1 + tc * temp), dict(p, tempco_per_K=tc, heat_rate_K_per_s=rate, tau_s=tau,
                                          dT_max_K=float(temp.max()))


def mech_hall_cubic(rng):
    """A Hall element's static nonlinearity at the high fields of a hard drive: V = Vq + S B (1 + c3 (B/0.25 T)^2),
    |c3| 5-20 % (odd, smooth; not a |B|-dependent gain), on a J-A core."""
    ctx = _ctx(rng, "hard")
    b, p = _ja_core(rng, ctx, 0.12, 0.24)
    c3 = rng.choice([-1.0, 1.0]) * rng.uniform(0.05, 0.20)
    return ctx, b * (1 + c3 * (b / 0.25) ** 2), dict(p, c3=c3)


def mech_leakage(rng):
    """Driven hard, the steel saturates and flux leaks across the coil window instead of crossing the MR gap where
    the Hall sits: a reluctance network whose leakage share depends on the steel's permeability."""
    for _ in range(1000):
        ctx = _ctx(rng, "paper" if rng.random() < 0.3 else "hard")
        mu_f = rng.uniform(2.5, 7.0)
        mu_eff = rng.uniform(max(4.0, 2.0 * mu_f), 20.0)  # gap-branch permeability seen by N I / Le
        knee, b_sat = rng.uniform(0.3, 0.7), rng.uniform(1.5, 2.1)  # steel saturates at knee x the peak field
        par = {"b_sat": b_sat, "mu_r": rng.uniform(300, 3000), "area_ratio": MU0 * mu_eff * knee * ctx["hmax"] / b_sat,
               "gap": mu_f / mu_eff, "mu_fluid": mu_f, "leak": rng.uniform(0.1, 1.0) * mu_eff}
        b = leakage_network(ctx["h"], **par)
        peak = np.max(np.abs(b))
        if max(0.04, 1.3 * MU0 * ctx["hmax"]) <= peak <= B_CEIL:
            return ctx, b, dict(par, knee_over_hmax=knee, b_peak_T=float(peak))
    raise RuntimeError("no leakage case in range")


MECHANISMS = {"stoner_wohlfarth": mech_stoner_wohlfarth, "preisach_lorentz": mech_preisach_lorentz,
              "rayleigh": mech_rayleigh, "thermal_permeability": mech_thermal_permeability,
              "hall_selfheat": mech_hall_selfheat, "hall_cubic": mech_hall_cubic, "leakage": mech_leakage}


def control_case(rng, effect: str):
    """In-vocabulary control: one of our non-J-A cores (Stoner-Wohlfarth, Lorentzian Preisach, Rayleigh) plus a
    Hall offset of +-5-20 mT, or a drift growing linearly in time to +-3-10 mT at the sweep's end. Returns the
    core alone too (its twin: same core, same noise), which tells how big the core's own gap is."""
    core = (mech_stoner_wohlfarth, mech_preisach_lorentz, mech_rayleigh)[int(rng.integers(3))]
    ctx, b, p = core(rng)
    if effect == "hall_offset":
        size = rng.choice([-1.0, 1.0]) * rng.uniform(5e-3, 20e-3)
        added = np.full_like(b, size)
    else:
        size = rng.choice([-1.0, 1.0]) * rng.uniform(3e-3, 10e-3)
        added = size * ctx["time"] / ctx["time"][-1]
    return ctx, b, b + added, dict(p, core=core.__name__[5:], size_T=size)


# ----------------------------------------------------------------------------------------------- Hall chain
def hall_volts(b_sensed: np.ndarray, noise_t: float, rng) -> np.ndarray:
    """A1304-like ratiometric Hall (5 V/T, 1.65 V quiescent) plus white noise, clipped at its output limits
    0.2 / 3.1 V, read by a 12-bit ADC on the 3.3 V supply."""
    v = QUIESCENT_V + SENS_V_PER_T * (b_sensed + noise_t * rng.standard_normal(b_sensed.size))
    v = np.clip(v, OUT_MIN_V, OUT_MAX_V)
    lsb = SUPPLY_V / 2 ** ADC_BITS
    return np.clip(np.round(v / lsb), 0, 2 ** ADC_BITS - 1) * lsb


def write_case(folder: Path, name: str, ctx: dict, volts: np.ndarray) -> Path:
    path = folder / f"{name}.csv"
    with path.open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["step", "time_s", "current_A", "hall1_V"])
        for i, (t, cur, v) in enumerate(zip(ctx["time"], ctx["current"], volts)):
            w.writerow([i, f"{t:.6g}", f"{cur:.10g}", f"{v:.10g}"])
    side = {"supply_V": SUPPLY_V, "coil_turns_per_m": round(float(ctx["n_per_m"]), 3),
            "dwell_s": round(ctx["dwell"], 6),
            "provenance": "SYNTHETIC - bench/heldout_openworld.py, an independent held-out generator",
            "sensors": {"hall1": {"sensitivity_V_per_T": SENS_V_PER_T, "quiescent_V": QUIESCENT_V,
                                  "output_min_V": OUT_MIN_V, "output_max_V": OUT_MAX_V}}}
    path.with_suffix(".json").write_text(json.dumps(side, indent=1, sort_keys=True) + "\n")
    return path


def _plain(d: dict) -> dict:
    return {k: (round(float(v), 6) if isinstance(v, (float, np.floating)) else v) for k, v in d.items()}


def _row(folder, name, kind, truth, ctx, b, volts, par) -> dict:
    return {"case": name, "kind": kind, "truth": truth, "path": "bipolar" if ctx["bipolar"] else "unipolar",
            "n_per_m": round(ctx["n_per_m"], 1), "dwell_s": round(ctx["dwell"], 4), "noise_T": round(ctx["noise_T"], 7),
            "peak_B_T": round(float(np.max(np.abs(b))), 5),
            "saturated_samples": int(np.sum((volts <= OUT_MIN_V + 1e-3) | (volts >= OUT_MAX_V - 1e-3))),
            "params": json.dumps(_plain(par), sort_keys=True), "file": str(write_case(folder, name, ctx, volts))}


def generate(folder: Path, seed: int, per_mech: int, per_control: int, only=None) -> list[dict]:
    """All cases, each from its own child generator of `seed` (same seed, same files). A control case comes with
    its core-only twin (kind control_core, same noise draw)."""
    jobs = [("oov", m, i) for m in MECHANISMS if not only or m in only for i in range(per_mech)]
    jobs += [("control", e, i) for e in ("hall_offset", "thermal_drift") for i in range(per_control)]
    rows = []
    keys = list(MECHANISMS) + ["hall_offset", "thermal_drift"]
    for kind, what, i in jobs:  # a case's draws depend on (seed, its class, its index) only: subsets agree
        key = [seed, keys.index(what), i]
        rng, noise_rng = np.random.default_rng(key), np.random.default_rng(key + [1])
        name = f"{kind}_{what}_{i:02d}"
        if kind == "oov":
            ctx, b, par = MECHANISMS[what](rng)
            rows.append(_row(folder, name, kind, what, ctx, b, hall_volts(b, ctx["noise_T"], noise_rng), par))
            continue
        ctx, b_core, b, par = control_case(rng, what)
        state = noise_rng.bit_generator.state
        rows.append(_row(folder, name, kind, what, ctx, b, hall_volts(b, ctx["noise_T"], noise_rng), par))
        noise_rng.bit_generator.state = state
        rows.append(_row(folder, name + "_core", "control_core", par["core"], ctx, b_core,
                         hall_volts(b_core, ctx["noise_T"], noise_rng), par))
    return rows


# ----------------------------------------------------------------------------------------------- diagnosis
def diagnose(row: dict, workflow: str, extra: list[str], timeout: float) -> dict:
    """One `python -m mrhyst diagnose` subprocess; the verdict's fields, or the error line."""
    out = Path(row["file"]).with_suffix(".diag.json")
    env = dict(os.environ, PYTHONPATH=workflow, NUMBA_NUM_THREADS="1", MPLBACKEND="agg")
    cmd = [sys.executable, "-m", "mrhyst", "diagnose", row["file"], "--sensor", "hall1", "--out", str(out), *extra]
    t0 = time.perf_counter()
    try:
        res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
        rc, err = res.returncode, (res.stderr.strip().splitlines() or [""])[-1]
    except subprocess.TimeoutExpired:
        rc, err = -1, f"timeout after {timeout} s"
    row = dict(row, elapsed_s=round(time.perf_counter() - t0, 2), rc=rc)
    if rc != 0 or not out.exists():
        return dict(row, outcome="error", error=err[:300])
    d = json.loads(out.read_text())
    mf, part, sec = d.get("model_form") or {}, d.get("partial") or {}, d.get("secondary") or {}
    eff = d.get("effect")
    second = sec.get("effect", "") if sec.get("accepted", True) else ""
    # a measurement effect named as the verdict or as its accepted second effect (a layered verdict's material base
    # plus a measurement effect on top): either tells a lab to hunt a fault
    attributed = next((e for e in (eff, second) if e in MEASUREMENT), "")
    outcome = "false_attribution" if attributed else eff
    if outcome not in ("false_attribution", "model_form", "unexplained", "none"):
        outcome = "other"
    floor = d.get("noise_floor_T") or float("nan")
    nm = d.get("next_measurement") or {}
    nxt = "|".join([nm.get("protocol") or ""] + [a.get("protocol", "") for a in nm.get("also") or []]).strip("|")
    return dict(row, effect=eff, outcome=outcome, ambiguous_with="|".join(d.get("ambiguous_with") or []), next=nxt,
                secondary=second, attributed=attributed,
                partial_effect=part.get("effect", "") or "", partial_failed="|".join(part.get("failed") or []),
                partial_rms_after_T=part.get("rms_after_T"),
                model_form_best=mf.get("best", "") or "", model_form_named=mf.get("named", ""),
                rms_before_T=d.get("rms_before_T"), rms_after_T=d.get("rms_after_T"), noise_floor_T=floor,
                model_form_rms_T=mf.get("rms_after_T"), gap_ratio=round(d.get("rms_before_T", 0) / floor, 2),
                verdict=d.get("verdict", ""))


def tree_commit(workflow: str) -> str:
    def git(*a):
        return subprocess.run(["git", "-C", workflow, *a], capture_output=True, text=True).stdout.strip()
    head = git("rev-parse", "--short", "HEAD") or "unknown"
    return head + (" (+ uncommitted changes)" if git("status", "--porcelain", "--", ".") else "")


# ----------------------------------------------------------------------------------------------- summary
def _count(rows, key="effect") -> str:
    out = {}
    for r in rows:
        out[r.get(key) or "error"] = out.get(r.get(key) or "error", 0) + 1
    return ", ".join(f"{k} {v}" for k, v in sorted(out.items(), key=lambda kv: -kv[1]))


def _pct(k, n):
    return f"{k:>3d} ({100.0 * k / n:4.0f} %)" if n else "  -"


def summarise(rows: list[dict], visible_factor: float) -> str:
    lines = [f"{'mechanism':<22}{'n':>4}{'visible':>8}  {'false attr.':>12}{'model_form':>13}{'unexplained':>13}"
             f"{'none':>11}{'err':>5}  {'on visible':>12}  {'without kin':>12}  measurement effects named"]
    oov = [r for r in rows if r["kind"] == "oov"]
    for mech in list(MECHANISMS) + ["ALL"]:
        rs = [r for r in oov if mech in ("ALL", r["truth"])]
        if not rs:
            continue
        vis = [r for r in rs if r["outcome"] != "error" and (r.get("gap_ratio") or 0) >= visible_factor]
        cnt = lambda o, sub=rs: sum(r["outcome"] == o for r in sub)  # noqa: E731
        strict = [r for r in rs if r["outcome"] == "false_attribution"
                  and (r.get("attributed") or r["effect"]) not in KIN.get(r["truth"], ())]
        lines.append(f"{mech:<22}{len(rs):>4}{len(vis):>8}  {_pct(cnt('false_attribution'), len(rs)):>12}"
                     f"{_pct(cnt('model_form'), len(rs)):>13}{_pct(cnt('unexplained'), len(rs)):>13}"
                     f"{_pct(cnt('none'), len(rs)):>11}{cnt('error'):>5}  "
                     f"{_pct(cnt('false_attribution', vis), len(vis)):>12}  {_pct(len(strict), len(rs)):>12}  "
                     + _count([r for r in rs if r["outcome"] == "false_attribution"], "attributed"))
    lines.append("")
    for eff in ("hall_offset", "thermal_drift"):
        rs = [r for r in rows if r["kind"] == "control" and r["truth"] == eff]
        if rs:
            hit = sum(r.get("effect") == eff for r in rs)
            anywhere = sum(eff in (r.get("effect"), r.get("secondary"), r.get("partial_effect")) for r in rs)
            amb = sum(r.get("effect") == eff or eff in str(r.get("ambiguous_with") or "").split("|") for r in rs)
            lines.append(f"control {eff:<14} n {len(rs):>3}  named {_pct(hit, len(rs))}  named or ambiguous_with "
                         f"{_pct(amb, len(rs))}  named, secondary or partial {_pct(anywhere, len(rs))}  "
                         f"verdicts: {_count(rs)}")
    twins = [r for r in rows if r["kind"] == "control_core"]
    if twins:
        gap = np.nanmedian([r.get("gap_ratio") or np.nan for r in twins])
        lines.append(f"control cores alone    n {len(twins):>3}  median gap {gap:.1f} x floor  "
                     f"verdicts: {_count(twins)}")
    return "\n".join(lines)


FIELDS = ["case", "kind", "truth", "path", "n_per_m", "dwell_s", "noise_T", "peak_B_T", "saturated_samples", "outcome",
          "effect", "ambiguous_with", "next", "secondary", "attributed", "partial_effect", "partial_failed",
          "partial_rms_after_T", "model_form_best",
          "model_form_named", "rms_before_T", "rms_after_T", "noise_floor_T", "model_form_rms_T", "gap_ratio",
          "elapsed_s", "rc", "error", "verdict", "params", "file"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="/tmp/heldout_openworld.csv", help="per-case CSV")
    ap.add_argument("--cases-dir", default=None, help="where the raw sweeps go (default: a fresh temp folder)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cases-per-mechanism", type=int, default=12)
    ap.add_argument("--controls-per-effect", type=int, default=6)
    ap.add_argument("--mechanisms", default="", help="comma-separated subset of " + ",".join(MECHANISMS))
    ap.add_argument("--workflow", default="/work/main/workflow", help="the mrhyst tree to test (PYTHONPATH)")
    ap.add_argument("--config", default=None, help="passed to mrhyst diagnose --config")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=180.0)
    ap.add_argument("--visible-factor", type=float, default=2.0,
                    help="a gap is 'visible' when the diagnosis's rms_before_T >= this x its noise floor")
    ap.add_argument("--repeated", action="store_true", help="every sweep runs its cycle twice (module docstring)")
    ap.add_argument("--generate-only", action="store_true")
    ap.add_argument("--from-csv", default=None, help="only print the tables of an earlier run's per-case CSV")
    a = ap.parse_args(argv)
    only = [m for m in a.mechanisms.split(",") if m]
    bad = [m for m in only if m not in MECHANISMS]
    if bad:
        sys.stderr.write(f"heldout_openworld: error: --mechanisms: unknown {','.join(bad)}\n")
        return 2
    if a.from_csv:
        with open(a.from_csv) as f:
            # a CSV written before the column `attributed` (the verdict was the only effect scored): the verdict's
            rows = [dict(r, gap_ratio=float(r["gap_ratio"] or "nan"),
                         attributed=r.get("attributed", r["effect"] if r["outcome"] == "false_attribution" else ""))
                    for r in csv.DictReader(f)]
        print(summarise(rows, a.visible_factor))
        return 0
    REPEAT["cycles"] = 2 if a.repeated else 1
    folder = Path(a.cases_dir or tempfile.mkdtemp(prefix="heldout_cases_"))
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    rows = generate(folder, a.seed, a.cases_per_mechanism, a.controls_per_effect, only)
    print(f"{len(rows)} cases in {folder} (seed {a.seed}), generated in {time.perf_counter() - t0:.1f} s")
    if a.generate_only:
        return 0
    extra = ["--config", a.config] if a.config else []
    print(f"diagnosing with {a.workflow} at commit {tree_commit(a.workflow)}, {a.jobs} jobs ...", flush=True)
    t0 = time.perf_counter()
    with ThreadPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(lambda r: diagnose(r, a.workflow, extra, a.timeout), rows))
    wall = time.perf_counter() - t0
    with open(a.out, "w", newline="") as f:
        w = csv.DictWriter(f, FIELDS, extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    el = [r["elapsed_s"] for r in rows]
    print(f"diagnosed in {wall:.0f} s wall (per sweep median {np.median(el):.1f} s, max {max(el):.1f} s; "
          "shared machine)")
    print(f"false attribution = a measurement-chain effect ({', '.join(sorted(MEASUREMENT))}) named (the verdict or "
          f"its accepted second effect) for an out-of-vocabulary gap; visible = rms_before >= {a.visible_factor} x "
          "noise floor\n")
    print(summarise(rows, a.visible_factor))
    bad = [r for r in rows if r["kind"] == "oov" and r["outcome"] == "false_attribution"]
    if bad:
        print("\nfalse attributions (case, gap before / floor, verdict):")
        for r in sorted(bad, key=lambda r: -(r.get("gap_ratio") or 0)):
            print(f"  {r['case']:<28} {r['path']:<9} {r.get('gap_ratio')!s:>6}x  {r.get('verdict', '')[:150]}")
    print(f"\nper-case rows: {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
