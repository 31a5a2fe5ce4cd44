"""The start state of a raw sweep (issue 23, item 4): how the core was conditioned before the lab recorded.

A lab often cycles a core before it records a stepped sweep. The sidecar may say so (optional fields,
workflow/mrhyst/schemas/sidecar.schema.json; docs/signatures.md):

* ``"start_state": "demagnetised"`` - the core was demagnetised: the model starts from M = 0;
* ``"preconditioning": {"cycles": N, "i_peak_A": X, "bipolar": true|false}`` (``start_state`` then
  ``"cycled"`` or absent) - the core was cycled N times between +X and -X (``bipolar``) or 0 and +X, ending
  at the sweep's first current: the model runs that history first, at the sweep's own current step, before
  the first recorded sample (as a third-party B(H) loop's conditioning passes, :func:`.sweep.sweep_from_bh`);
  the history is not fitted (its samples are not valid) and no time passes in it (a drift starts at the
  first reading). A remanent start is then not a free effect: the history sets it;
* ``"start_state": "unknown"`` or nothing - the model starts demagnetised, and the verdict says that this
  start state is **assumed** (a remanent start stays a candidate effect).
"""

from __future__ import annotations

import numpy as np

from mrhyst.data import loops
from mrhyst.data.io import InputError

# The history the model runs is bounded (a lab's sidecar may say 1000 cycles, or mA in the A field): a J-A core's
# cyclic state is reached within a few cycles (the third-party loops' conditioning passes: pass 2 vs 3 differ by
# <= 4e-6 T, config external.cyclic_passes), so more are declared but not run; a peak more than MAX_PEAK_RATIO x
# the sweep's own largest current is refused as a unit mistake (each cycle is run at the sweep's own current step:
# 2000 "A" on the paper's 0.077 A step is 10^5 steps a cycle).
MAX_CYCLES_RUN = 5
MAX_PEAK_RATIO = 10.0
# ... and each leg of the history at most LEG_STEPS steps (a coarser step than the sweep's where the peak is far
# beyond the sweep's own current: 20 A on a 0.005 A step was 4000 steps a leg, 7 minutes and 5.6 GB; the state a
# saturating history leaves does not depend on how finely the way there is resolved)
LEG_STEPS = 200
ASSUMED = ("the sidecar does not say how the core was conditioned: the model starts demagnetised (M = 0); "
           "add start_state or preconditioning to the sidecar when it is known")


def declared(sidecar: dict, source: str = "sidecar") -> dict:
    """{"state": "demagnetised"|"cycled", "source": "sidecar"|"assumed", "preconditioning": {...}|None,
    "note": str} from a sidecar (already checked against its schema); InputError on a contradiction."""
    state, pre = sidecar.get("start_state"), sidecar.get("preconditioning")
    if pre is not None and state not in (None, "cycled"):
        raise InputError(f"{source}: preconditioning is given but start_state is {state!r} (expected 'cycled' "
                         f"or no start_state)")
    if state == "cycled" and pre is None:
        raise InputError(f"{source}: start_state 'cycled' needs preconditioning {{cycles, i_peak_A, bipolar}} "
                         f"(how the core was cycled, so the model can run that history first)")
    if pre is not None:
        how = f"{int(pre['cycles'])} {'bipolar' if pre['bipolar'] else 'unipolar'} cycle(s) to {pre['i_peak_A']:g} A"
        return {"state": "cycled", "source": "sidecar", "preconditioning": dict(pre),
                "note": f"the sidecar says the core was cycled ({how}); the model runs that history first"}
    if state == "demagnetised":
        return {"state": "demagnetised", "source": "sidecar", "preconditioning": None,
                "note": "the sidecar says the core was demagnetised; the model starts from M = 0"}
    return {"state": "demagnetised", "source": "assumed", "preconditioning": None, "note": ASSUMED}


def _ramp(a: float, b: float, di: float) -> np.ndarray:
    n = min(max(int(round(abs(b - a) / di)), 1), LEG_STEPS)
    return np.linspace(a, b, n + 1)[1:]


def conditioning_path(pre: dict, step_A: float, end_A: float) -> np.ndarray:
    """The currents of the conditioning history: ``cycles`` x (0 -> +X -> -X -> 0) (bipolar) or (0 -> +X -> 0),
    at ``step_A``, then to ``end_A`` (the sweep's first current), starting and ending at the currents' own
    steps (the first recorded sample is not repeated)."""
    x, n = float(pre["i_peak_A"]), int(pre["cycles"])
    legs = [(0.0, x), (x, -x), (-x, 0.0)] if pre["bipolar"] else [(0.0, x), (x, 0.0)]
    path = [np.zeros(1)]
    for _ in range(n):
        path += [_ramp(a, b, step_A) for a, b in legs]
    out = np.concatenate(path)
    if end_A != out[-1]:
        out = np.concatenate([out, _ramp(float(out[-1]), float(end_A), step_A)])
    return out[:-1] if out[-1] == end_A else out


def apply(sw, sidecar: dict, regions_cfg: dict | None = None, source: str = "sidecar"):
    """The Sweep ``sw`` with its declared start state (``sw.start_state``) and, for a cycled core, its
    conditioning history prepended (not valid, no time passing; ``start`` moves to the first recorded
    sample; the history's region labels come from the whole path, the recorded samples keep theirs)."""
    st = declared(sidecar, source)
    sw.start_state = st
    if st["state"] != "cycled":
        return sw
    d = np.abs(np.diff(sw.current))
    step = float(np.median(d[d > 0]))
    pc, top = st["preconditioning"], float(np.max(np.abs(sw.current)))
    if not float(pc["i_peak_A"]) <= MAX_PEAK_RATIO * top:  # NaN too
        raise InputError(f"{source}: preconditioning i_peak_A {pc['i_peak_A']:g} A is more than {MAX_PEAK_RATIO:g}x "
                         f"the sweep's largest current ({top:g} A); expected amperes (a value in mA?)")
    if int(pc["cycles"]) > MAX_CYCLES_RUN:
        n = int(pc["cycles"])
        st["note"] += (f" ({MAX_CYCLES_RUN} of the {n if n < 10**6 else f'{n:.3g}'} cycles are run: a J-A core's "
                       f"cyclic state is reached within them)")
    pre = conditioning_path(dict(pc, cycles=min(int(pc["cycles"]), MAX_CYCLES_RUN)), step, float(sw.current[0]))
    k = pre.size
    sw.current = np.concatenate([pre, sw.current])
    sw.time = np.concatenate([np.full(k, sw.time[0]), sw.time])
    sw.B = np.concatenate([np.zeros(k), sw.B])
    sw.valid = np.concatenate([np.zeros(k, dtype=bool), sw.valid])
    sw.start, sw.peak_first, sw.peak_last = k, sw.peak_first + k, sw.peak_last + k
    sw.measured = sw.shape  # the recorded samples' path (the signatures read it)
    sw.shape = loops.path_shape(sw.current)  # the path simulated: the history, then the sweep
    full = sw.shape.regions(sw.B, regions_cfg)
    sw.region = full if sw.region is None else np.concatenate([full[:k], np.asarray(sw.region)])
    return sw


def text(st: dict, base_start: str | None = None) -> str:
    """'' or the verdict's note that the start state is assumed, with what the flexible base read of it
    (``base_start``: the start the layers' base fits best from, :data:`mrhyst.diagnose.everett.STARTS`) where that
    is a remanence: the model's assumption and the data then disagree, and the lab should know which way."""
    if not st or st.get("source") == "assumed":
        read = "" if base_start in (None, "demagnetised") else (
            f"; the flexible base fits the sweep best from the core's {base_start} remanence: a core left "
            f"magnetised before the sweep (physics, not a fault) or a constant offset (at the first 0 A reading "
            f"the two look alike)")
        return "; start state assumed " + (st or {}).get("state", "demagnetised") + " (" + (
            (st or {}).get("note") or ASSUMED) + ")" + read
    return ""
