"""Physical sanity of a sweep, its sidecar and a loop (issue 25): what no instrument can give is refused, one
line each, before any work. The bounds live in the sidecar schema's ``x-limits`` (with the reason of each):

* the sidecar: no unknown key (the closest known one is suggested), quiescent_V and the output limits within
  the supply;
* the readings: within the supply (a Hall IC's output cannot leave it), coil_turns_per_m x current_A a
  finite H, a channel that moves (not one or two constant values: a stuck output), |B| within what a Hall
  sensor at a core can read (``max_abs_B_T``);
* a loop (raw or B(H)): max|B| / (mu0 max|H|) within the permeabilities a material can have (H in kA/m, B in
  mT or a 1e-9 T loop fall outside), and at least one reversal of H (one branch is no loop to fit).
"""

from __future__ import annotations

import difflib
import functools
import json
import math
from pathlib import Path

import numpy as np

from mrhyst.data import shape as shp
from mrhyst.data.errors import InputError

SCHEMA_PATH = Path(__file__).resolve().parents[1] / "schemas" / "sidecar.schema.json"
MU0 = 4e-7 * math.pi


@functools.lru_cache(maxsize=1)
def limits() -> dict:
    return json.loads(SCHEMA_PATH.read_text())["x-limits"]


def unknown_key(e) -> str | None:
    """The message of a schema error for a key the sidecar does not know, with the closest known key."""
    if e.validator != "additionalProperties" or not isinstance(e.instance, dict):
        return None
    known = sorted(e.schema.get("properties", {}))
    bad = sorted(k for k in e.instance if k not in known)[0]
    close = difflib.get_close_matches(bad.lower(), [k.lower() for k in known], n=1, cutoff=0.6)
    hint = f"; did you mean {known[[k.lower() for k in known].index(close[0])]!r}?" if close else ""
    where = ".".join(str(p) for p in e.absolute_path)
    return f"{where + ': ' if where else ''}unknown key {bad!r} (known: {', '.join(known)}){hint}"


def _rails(supply: float, rail: float) -> str:
    return f"0 .. supply_V {supply:g} V" if not rail else f"supply_min_V {rail:g} .. supply_V {supply:g} V"


def _bipolar_hint(v: float, rail: float) -> str:
    """A value below 0 V with no lower rail declared: say how to declare a bipolar supply."""
    return "; a sensor on a bipolar supply: declare supply_min_V in the sidecar" if v < 0 and not rail else ""


def check_sensor(name: str, s, supply: float, jpath, rail: float = 0.0) -> None:
    """quiescent_V and the declared output limits of one sensor within the supply (``rail`` .. ``supply``: the
    sidecar's supply_min_V, 0 by default, and supply_V)."""
    if not rail < supply:
        raise InputError(f"{jpath}: supply_min_V {rail:g} V must be below supply_V {supply:g} V")
    tol = float(limits()["supply_tolerance_frac"]) * (supply - rail)
    for key in ("quiescent_V", "output_min_V", "output_max_V"):
        v = getattr(s, key)
        if v is None:
            continue
        if not ((rail < v < supply) if key == "quiescent_V" else (rail - tol <= v <= supply + tol)):
            raise InputError(f"{jpath}: sensors.{name}: {key} {v:g} V is outside the supply ({_rails(supply, rail)})"
                             f"; a Hall output cannot leave its supply{_bipolar_hint(v, rail)}")


def check_readings(v: np.ndarray, col: str, supply: float, path, row_of, rail: float = 0.0) -> None:
    """Every reading of a Hall channel within ``rail`` .. supply_V (give or take the tolerance)."""
    tol = float(limits()["supply_tolerance_frac"]) * (supply - rail)
    bad = (v < rail - tol) | (v > supply + tol)
    if bad.any():
        i = int(np.argmax(bad))
        where = f"0 .. {supply:g} V, sidecar supply_V" if not rail else _rails(supply, rail)
        raise InputError(f"{path}: row {row_of(i)}, column {col}: {v[i]:g} V is outside the sensor's supply "
                         f"({where}); expected volts of a Hall output{_bipolar_hint(float(v[i]), rail)}")


def check_field(turns: float, current: np.ndarray, path, row_of) -> None:
    """H = coil_turns_per_m x current_A finite at every reading."""
    with np.errstate(over="ignore", invalid="ignore"):
        bad = ~np.isfinite(turns * current)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"{path}: row {row_of(i)}: coil_turns_per_m {turns:g} x current_A {current[i]:g} gives an "
                         f"infinite H; expected turns per metre (N/Le) and amperes")


def check_channel(V: np.ndarray, B: np.ndarray, valid: np.ndarray, col: str, sens: float, path, row_of) -> None:
    """A channel that moves (more than two distinct usable readings) and reads |B| <= max_abs_B_T."""
    vals = np.unique(V[valid])
    if vals.size == 0:  # every reading at an output limit: data, flagged (a fit or diagnosis refuses it)
        return
    if vals.size <= 2:
        what = f"{vals[0]:g} V" if vals.size == 1 else f"{vals[0]:g} or {vals[-1]:g} V"
        raise InputError(f"{path}: column {col}: every usable reading is {what} (a stuck output); expected a Hall "
                         f"voltage that follows the field")
    bmax = float(limits()["max_abs_B_T"])
    bad = valid & (np.abs(B) > bmax)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"{path}: row {row_of(i)}, column {col}: {V[i]:g} V gives |B| = {abs(B[i]):.3g} T with "
                         f"sensitivity_V_per_T {sens:g}; a Hall sensor at a core reads |B| <= {bmax:g} T "
                         f"(sensitivity in V/mT? expected V/T)")


def check_time_scale(t: np.ndarray, dwell_s: float | None, path) -> None:
    """The readings' median time step within ``max_time_step_per_dwell`` dwells of the sidecar's dwell_s (else
    time_s in another unit than s: ms gives 1000x)."""
    steps = np.diff(np.asarray(t, dtype=float))
    steps = steps[steps > 0]
    if dwell_s is None or not dwell_s > 0 or steps.size == 0:
        return
    med, k = float(np.median(steps)), float(limits()["max_time_step_per_dwell"])
    if med > k * dwell_s:
        raise InputError(f"{path}: column time_s: the readings are {med:g} apart (median) where the sidecar's "
                         f"dwell_s is {dwell_s:g} s per current step, {_times(med / dwell_s)}; is time_s in ms? "
                         f"expected seconds")


def _times(r: float) -> str:
    """'1000x', or '1e+299x' for a ratio no one reads digit by digit."""
    return f"{r:.0f}x" if r < 1e6 else f"{r:.3g}x"


def check_permeability(H: np.ndarray, B: np.ndarray, valid: np.ndarray, where, raw: bool = False) -> None:
    """max|B| / (mu0 max|H|) within [min, max]_relative_permeability of x-limits: else B or H in another unit."""
    lim = limits()
    hmax, bmax = float(np.max(np.abs(H))), float(np.max(np.abs(B[valid]), initial=0.0))
    if not hmax > 0:
        return
    mu = bmax / (MU0 * hmax) if MU0 * hmax > 0 else math.inf  # a subnormal H underflows: beyond any material
    lo, hi = float(lim["min_relative_permeability"]), float(lim["max_relative_permeability"])
    if mu > hi:
        raise InputError(f"{where}: max|B| {bmax:.3g} T at max|H| {hmax:.3g} A/m is a relative permeability of "
                         f"{mu:.3g}, above any material's ({hi:.0e}); "
                         + ("is current_A in kA, or the sensitivity in V/mT? expected A and V/T" if raw else
                            "is H in kA/m or B in mT? expected A/m and T"))
    if mu < lo:
        raise InputError(f"{where}: max|B| {bmax:.3g} T is below mu0 max|H| ({MU0 * hmax:.3g} T at {hmax:.3g} A/m), "
                         f"which even vacuum reaches; "
                         + ("is current_A in mA, or coil_turns_per_m per mm (H = coil_turns_per_m x current_A)? "
                            "expected A and turns per m" if raw else
                            "is B in another unit than tesla? expected T and A/m"))


def check_sign(H: np.ndarray, B: np.ndarray, valid: np.ndarray, where) -> None:
    """B that falls as H rises over whole rising and falling branches (:func:`mrhyst.data.shape.reversed_branches`):
    no material's loop; a fit of it would be meaningless (the diagnosis names it instead: signature reversed_sign)."""
    against = shp.reversed_branches(shp.branch_nets(H, B, valid), 0.0)
    if against:
        net = float(np.mean([n[1] for n in against]))
        raise InputError(f"{where}: B falls as H rises over whole rising and falling branches (net "
                         f"{net * 1e3:+.3g} mT per branch): the sign of B or of H is reversed (a Hall sensor facing "
                         f"the other way, a coil connected the other way round); expected B rising with H (a raw "
                         f"sweep's sensor mounted reversed: a negative sensitivity_V_per_T in its sidecar)")


def check_orientation(H: np.ndarray, B: np.ndarray, valid: np.ndarray, where) -> None:
    """A loop that runs clockwise (:func:`mrhyst.data.shape.closed_loss` negative by ``clockwise_min_sigma`` standard
    errors, the noise from B's own second differences): no material's loop at a fixed temperature; a fit of it would
    be meaningless (the diagnosis names it instead: signature clockwise)."""
    got = shp.closed_loss(H, B, valid)
    if got is None:
        return
    sigma = shp.noise_floor(B, shp.path_shape(H), valid, float(limits()["clockwise_noise_clip"]))
    if not sigma:
        return
    w, se, _, _, span = got
    z = -w / (sigma * se)
    if z >= float(limits()["clockwise_min_sigma"]):
        raise InputError(f"{where}: the loop runs clockwise (the integral of H dB is negative, a mean opening of "
                         f"{w / span * 1e3:+.3g} mT, {z:.0f} sigma): no material at a fixed temperature does this; "
                         f"are the samples in reverse order, or B and H out of step? expected a loop that runs "
                         f"anticlockwise in (H, B) (mrhyst diagnose names it: signature clockwise)")


def check_reversal(H: np.ndarray, where, what: str = "H") -> None:
    """At least one reversal of H (a loop): one branch alone fixes neither k nor c of J-A."""
    d = np.sign(np.diff(np.asarray(H, dtype=float)))
    d = d[d != 0]
    if d.size and np.all(d == d[0]):
        raise InputError(f"{where}: {what} only {'rises' if d[0] > 0 else 'falls'} (one branch, no reversal); a "
                         f"loop to fit needs at least one reversal (e.g. 0 -> max -> 0)")
