"""Blind benchmark, step 1 (rule ``blind_generate``): draw the cases, write them anonymously, write the key.

Three kinds of class (config ``blind.classes``; ``blind.counts`` overrides ``n_per_class`` per class):

* **closed world**: one vocabulary effect or ``none``, made by the rig (:func:`mrhyst.rig.simulate_case`);
* **compound**: ``A+B``, two vocabulary effects at once (rig), scored on both;
* **open world**: an out-of-vocabulary mechanism of :mod:`mrhyst.blind.openworld` (its own magnetics and
  sensor physics; the rig's sensor chain).

Every case: a J-A truth from ``truth_box``, a drive N/Le, a noise level, a dwell, the protocol of
``blind.protocol`` (``paper``: 0 -> I_max -> 0; ``bipolar2``: a virgin rise then two bipolar cycles, issue
13; ``unipolar2``: 0 -> I_max -> 0 twice, issue 23). Files ``case_000.csv/.json`` ... are written in shuffled
order with the same columns and sidecar keys whatever the class. The key records, from the independent
reference fit of :mod:`.reference` (never the diagnosis), whether each case's gap is detectable, which single
vocabulary effect would explain its noise-free loop as well, and for a compound case whether each member is
needed.
"""

from __future__ import annotations

import math
from collections import deque
from pathlib import Path

import numpy as np

from mrhyst import rig
from mrhyst.blind import openworld
from mrhyst.blind import reference as ref
from mrhyst.blind.settings import blind_settings, recorded
from mrhyst.data import io
from mrhyst.model import effects as fx
from mrhyst.model import ja, streams
from mrhyst.settings import schema_or

CLOSED = tuple(e for e in fx.VOCABULARY if e not in ("unexplained", "model_form", *fx.REFERENCE_ONLY))
CLASSES = CLOSED  # the closed-world classes (kept for older callers)
EFFECTS = tuple(e for e in CLOSED if e != "none")
SENSOR = "hall1"
KEY_FILENAME = "key.json"  # results/blind/key.json: read by score() only
PROTOCOLS = ("paper", "bipolar2", "unipolar2")


def closed_classes() -> tuple:
    """``none`` and every registered effect (live: an effect registered later is a class too)."""
    return ("none", *fx.REGISTRY)


def class_kind(cls: str) -> str:
    """``closed``, ``compound`` or ``openworld``; a name that is none of these is a one-line InputError."""
    if cls in closed_classes():
        return "closed"
    if cls in openworld.MECHANISMS:
        return "openworld"
    parts = cls.split("+")
    if len(parts) == 2 and all(p in fx.REGISTRY for p in parts) and parts[0] != parts[1]:
        return "compound"
    raise io.InputError(f"blind.classes: {cls!r} is not a class (expected one of {closed_classes()}, an open-world "
                        f"mechanism {openworld.MECHANISMS}, or two different effects joined by '+')")


def members(cls: str) -> tuple[str, ...]:
    """The vocabulary effects injected in class ``cls`` (none for ``none`` and open-world classes)."""
    kind = class_kind(cls)
    return () if kind == "openworld" or cls == "none" else tuple(cls.split("+"))


def counts(cfg: dict) -> dict:
    """Cases per class, in config order: ``counts[cls]`` or ``n_per_class`` (a count for a class that is not
    in ``classes`` is unused: a study may drop classes without editing counts)."""
    over = cfg.get("counts") or {}
    return {cls: int(over.get(cls, cfg["n_per_class"])) for cls in cfg["classes"]}


def variant_config(cfg: dict, name: str | None = None) -> dict:
    """The blind config of benchmark ``name`` (None: the main one): config ``blind`` with the keys of
    ``blind.variants.NAME`` changed; the variants themselves are not part of any benchmark's config."""
    out = {k: v for k, v in cfg.items() if k != "variants"}
    if name is not None:
        over = (cfg.get("variants") or {}).get(name)
        if over is None:
            raise io.InputError(f"blind.variants: no variant {name!r} (have {', '.join(cfg.get('variants') or {})})")
        out.update(over)
    return out


def case_ids(cfg: dict) -> list[str]:
    """case_000 ... in the order the files are numbered (N = the sum of :func:`counts`)."""
    n = sum(counts(cfg).values())
    width = max(3, len(str(n - 1)))
    return [f"case_{i:0{width}d}" for i in range(n)]


def current_path(cfg: dict) -> np.ndarray:
    """The applied currents of every case: the paper's 0 -> I -> 0, ``bipolar2`` (issue 13), or ``unipolar2``
    (0 -> I -> 0 twice: the repeat the confound table names to tell a drift from a material shape, issue 23)."""
    i_max, n_up = float(cfg["i_max_A"]), int(cfg["n_up"])
    proto = schema_or("blind", protocol=cfg.get("protocol"))["protocol"]
    if proto == "paper":
        return ja.paper_current_path(i_max, n_up)
    if proto == "bipolar2":  # virgin 0 -> +I, then +I -> -I -> +I twice, n_up - 1 steps per quarter
        up = np.linspace(0.0, i_max, n_up)
        down = np.linspace(i_max, -i_max, 2 * n_up - 1)[1:]
        rise = np.linspace(-i_max, i_max, 2 * n_up - 1)[1:]
        return np.concatenate([up, down, rise, down, rise])
    if proto == "unipolar2":  # the paper's 0 -> +I -> 0 twice, the 0 A reading between them shared (issue 23)
        once = ja.paper_current_path(i_max, n_up)
        return np.concatenate([once, once[1:]])
    raise io.InputError(f"blind.protocol: {proto!r} is not a protocol (expected one of {PROTOCOLS})")


def _loguniform(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _truth(rng, cfg) -> dict:
    tb = cfg["truth_box"]
    return {name: _loguniform(rng, *tb[name]) for name in ja.PARAM_NAMES}


def _effect(cls: str, rng, cfg: dict, sigma: float, base_B: np.ndarray, truth: dict, duration_s: float):
    """(params, magnitude record) of vocabulary effect ``cls`` for one case: the effect's own draw
    (:class:`mrhyst.model.effects.Effect`, ``draw``) from config ``blind.magnitude``."""
    e = fx.REGISTRY[cls]
    if e.draw is None:
        raise io.InputError(f"blind.classes: effect {cls!r} has no blind draw (mrhyst.model.effects.Effect.draw)")
    case = {"sigma_T": sigma, "peak_T": float(np.max(base_B)), "truth": truth, "duration_s": duration_s,
            "sensitivity_V_per_T": sensitivity(cfg, base_B)}
    return e.draw(rng, cfg["magnitude"], case)


def sensitivity(cfg: dict, B) -> float:
    """The case's Hall sensitivity (V/T): the A1304's, or less so that the loop a lab expects stays within
    full_scale_V of the quiescent output (a lab picks its sensor for the loop, not for the effect)."""
    sens = min(float(cfg["sensitivity_V_per_T"]), float(cfg["full_scale_V"]) / float(np.max(np.abs(B))))
    return float(f"{sens:.2g}")


def effective_sigma(spec: dict) -> float:
    """Noise of the case as the data carry it: white noise plus ADC quantisation (LSB^2 / 12), in T."""
    q = rig.adc_lsb() / spec["sensitivity_V_per_T"]
    return math.sqrt(spec["noise_sigma_T"] ** 2 + q * q / 12.0)


def noise_free(spec: dict, cfg: dict):
    """(B the sensor reports without noise, time_s, current, ok) of one case."""
    current = current_path(cfg)
    time_s = rig.sample_times(current.size, spec["dwell_s"])
    sub = int(cfg["rig_substeps"])
    if spec["kind"] == "openworld":
        B, _, ok = openworld.field(spec["class"], spec["mechanism"], spec["truth"], current, time_s,
                                   spec["n_over_le"], substeps=sub)
    else:
        B, ok = rig.observe(ja.as_param_array(spec["truth"]), current, time_s, spec["n_over_le"], spec["effects"],
                            substeps=sub)
    return B, time_s, current, bool(ok and np.all(np.isfinite(B)))


def _draw_one(cls: str, kind: str, rng, cfg: dict, current: np.ndarray) -> dict | None:
    """One case's specification of class ``cls``, or None when its J-A truth does not integrate."""
    truth = _truth(rng, cfg)
    ranges = cfg["n_over_le_ranges"]
    nle = _loguniform(rng, *ranges[int(rng.integers(0, len(ranges)))])
    sigma = float(rng.choice(np.asarray(cfg["noise_sigma_T"], dtype=float)))
    dwell = _loguniform(rng, *cfg["dwell_s"])
    time_s = rig.sample_times(current.size, dwell)
    base_B, ok = rig.observe(ja.as_param_array(truth), current, time_s, nle, [], substeps=int(cfg["rig_substeps"]))
    if not ok or not np.all(np.isfinite(base_B)) or np.max(base_B) <= 0:
        return None
    spec = {"class": cls, "kind": kind, "effects": [], "truth": truth, "n_over_le": nle, "noise_sigma_T": sigma,
            "dwell_s": dwell, "magnitude": {}}
    if kind == "openworld":
        spec["mechanism"] = openworld.draw(cls, rng, truth, (cfg.get("openworld") or {}).get(cls))
        if not openworld.has_ja_truth(cls):
            spec["truth"] = None
    for name in members(cls):
        ep, mag = _effect(name, rng, cfg, sigma, base_B, truth, float(time_s[-1] - time_s[0]))
        spec["effects"].append((name, ep))
        spec["magnitude"][name] = mag
    B, _, _, ok = noise_free(spec, cfg)
    if not ok or np.max(B) <= 0:
        return None
    # the sensor's range is chosen for the loop a lab expects (the core's own; the reported one in the open
    # world, where there is no other), not for the effect
    seen = B if kind == "openworld" else base_B
    spec.update(sensitivity_V_per_T=sensitivity(cfg, seen), peak_T=float(np.max(base_B if kind != "openworld" else B)),
                noise_seed=int(rng.integers(0, 2**31 - 1)), ref_seed=int(rng.integers(0, 2**31 - 1)))
    return spec


def detectability(spec: dict, cfg: dict) -> dict:
    """The key's verdict on one case from the independent reference fit (ARCHITECTURE 6; issue 11 point 5).

    ``detectable``: plain J-A leaves >= detectable_factor x sigma_eff on the noise-free loop. Closed world:
    ``equivalent_to`` = other effects whose J-A refit leaves < equivalent_factor x sigma. Compound:
    ``needed`` per member = J-A + the *other* member alone still leaves >= detectable_factor x sigma.
    Open world and compound: ``vocab_closes`` = effects whose J-A refit leaves < detectable_factor x sigma
    (for a compound, any single effect, a member or not: then one effect explains it, :func:`_wanted`).

    With ``detectable_only`` a draw that will not be a case (:func:`_wanted`) is told so as soon as that is
    known: once the plain fit gets below detectable_factor x sigma (not detectable: the fit stops there), or
    after a compound's two member refits (a member not needed), and the other effects' refits are skipped (most
    of the key's time went into draws that were thrown away).
    A kept draw gets every refit, each from the plain fit alone: its verdict is the same either way."""
    B, time_s, current, _ = noise_free(spec, cfg)
    loop = ref.Loop(B, current, time_s, spec["n_over_le"], int(cfg["rig_substeps"]))
    kind, own = spec["kind"], members(spec["class"])
    effects = [] if spec["class"] == "none" else [e for e in fx.REGISTRY if kind != "closed" or e not in own]
    rc = cfg["reference"]
    sig, f = effective_sigma(spec), float(cfg["detectable_factor"])
    lazy = bool(schema_or("blind", detectable_only=cfg.get("detectable_only"))["detectable_only"]) \
        and spec["class"] != "none"
    if lazy and spec["truth"] is not None:
        # plain J-A starts at the truth and never ends above its start: a loop the truth itself already
        # reproduces to within detectable_factor x sigma cannot be detectable, whatever the fit would find
        at_truth = ref.start_rms(loop, ja.as_param_array(spec["truth"]), rc["box"])
        if at_truth < f * sig:
            return {"rms_left_T": at_truth, "reference_params": None, "alternatives_rms_T": {},
                    "sigma_eff_T": sig, "detectable": False, "equivalent_to": [],
                    "skipped": "the truth leaves < detectable_factor x sigma: no fit"}
    # a lazy draw is not detectable as soon as plain J-A gets below f x sigma: its fit may stop there (a draw
    # that stays detectable never gets there, so its fit, the one the key records, is the same)
    r = ref.plain_reference(loop, spec["truth"], rc, cfg["truth_box"], spec["ref_seed"],
                            multistart=kind == "openworld", stop_below=f * sig if lazy else None)
    left = r["rms_left_T"]
    r.update(sigma_eff_T=sig, detectable=bool(spec["class"] != "none" and left is not None and left >= f * sig))
    if lazy and not r["detectable"]:
        return dict(r, equivalent_to=[], skipped="not detectable: no effect refits")
    first = list(own) if kind == "compound" else []
    eq = float(cfg["equivalent_factor"])
    # the refits' decisions are "RMS < level" at these two levels: refitted loosely first, tightly near a level
    loose = (float(rc["effect_tol"]), (eq * sig, f * sig), float(rc["recheck_sigma"]) * sig)
    # a compound draw is thrown away as soon as one single effect gets below detectable_factor x sigma (a member:
    # the other is not needed; any other: it alone explains the loop), so those refits may stop there
    stop = f * sig if lazy and kind == "compound" else None
    ref.add_alternatives(r, loop, first, rc, stop_below=stop, loose=loose)
    if kind == "compound":
        a, b = own
        alt = r["alternatives_rms_T"]
        r["needed"] = {a: bool(alt.get(b) is not None and alt[b] >= f * sig),
                       b: bool(alt.get(a) is not None and alt[a] >= f * sig)}
        if lazy and not all(r["needed"].values()):
            return dict(r, equivalent_to=[], skipped="a member not needed: no further effect refits")
    ref.add_alternatives(r, loop, [e for e in effects if e not in first], rc, stop_below=stop, loose=loose)
    closers = [e for e, v in r["alternatives_rms_T"].items() if v is not None and stop is not None and v < stop]
    if closers:
        return dict(r, equivalent_to=[], vocab_closes=closers, skipped="a single effect closes the loop")
    alt = {e: r["alternatives_rms_T"][e] for e in effects}  # registry order, as one pass would write them
    r["alternatives_rms_T"] = alt
    r["equivalent_to"] = [e for e, v in alt.items() if v is not None and v < eq * sig and e not in own]
    if kind in ("openworld", "compound"):
        r["vocab_closes"] = [e for e, v in alt.items() if v is not None and v < f * sig]
    return r


def _wanted(spec: dict, det: dict, cfg: dict) -> bool:
    """With detectable_only: a case counts when its gap is detectable (and, compound, both members needed and no
    single effect closing the loop alone)."""
    if not schema_or("blind", detectable_only=cfg.get("detectable_only"))["detectable_only"] or spec["class"] == "none":
        return True
    # a compound is two effects only where no single vocabulary effect closes its loop: a remanent start plus a
    # slow drift that one constant offset reproduces to within the noise is, for any diagnosis, that offset
    single = spec["kind"] == "compound" and bool(det.get("vocab_closes"))
    return det["detectable"] and all((det.get("needed") or {}).values()) and not single


# draws in flight per worker process: most draws are thrown away after a plain fit of ~0.1 s, so with one in
# flight per worker the workers waited on the parent's drawing; the ones made ahead of a class's last case are
# discarded (each class draws from its own stream, which nothing reads after it), so this changes the time, never
# the cases
AHEAD = 4
STREAM_TAG = 20190611  # purpose tag of the classes' streams (mrhyst.model.streams.stream); + 1: the shuffle


def class_stream(cfg: dict, cls: str) -> np.random.Generator:
    """Class ``cls``'s own random stream: from config ``blind.seed`` and the class NAME, never its place in
    ``classes``, so that adding, dropping or reordering a class leaves every other class's cases as they were."""
    return streams.stream(int(cfg["seed"]), STREAM_TAG, cls)


def _attempts(cls: str, kind: str, rng, cfg: dict, current, pool, ahead: int):
    """The draws of class ``cls`` in order, each as (spec, reference verdict).

    With a pool, up to ``ahead`` draws are made before their verdicts are needed and their reference fits run
    in the pool meanwhile; a draw depends only on the rng, never on an earlier verdict, so the sequence is the
    one :func:`draw_cases` makes one by one. The caller stops reading once it has its cases (draws made ahead are
    discarded with the class's stream)."""
    queue = deque()
    while True:
        while len(queue) < ahead:
            spec = _draw_one(cls, kind, rng, cfg, current)
            job = None if spec is None else pool.apply_async(detectability, (spec, cfg))
            queue.append((spec, job))
        spec, job = queue.popleft()
        yield spec, (None if job is None else job.get())


def draw_cases(cfg: dict, workers: int = 1) -> list[dict]:
    """Every case's specification and reference verdict, shuffled and numbered; deterministic in cfg.

    Each class draws from its own stream (:func:`class_stream`); the shuffle from one of its own. With
    ``detectable_only`` a case is drawn again until :func:`_wanted`, so that magnitudes run from barely
    detectable to large and every scored case has something to name (ARCHITECTURE 6). ``workers`` > 1 runs
    the reference fits (most of the time) in that many processes, a few draws ahead (:func:`_attempts`);
    same cases, same bytes."""
    return number(cfg, draw_classes(cfg, list(counts(cfg)), workers))


def key_parts(cfg: dict, n_parts: int) -> list[list[str]]:
    """The classes of each of ``n_parts`` key jobs (rule blind_draw; at most one per class): every n-th class in
    config order, so that the costly compound classes (most draws thrown away) fall into different parts."""
    classes = list(counts(cfg))
    n = max(1, min(int(n_parts), len(classes)))
    return [classes[i::n] for i in range(n)]


def number(cfg: dict, specs: list[dict]) -> list[dict]:
    """The cases of every class (in config class order) shuffled and numbered case_000 ..."""
    order = streams.stream(int(cfg["seed"]), STREAM_TAG + 1, "shuffle").permutation(len(specs))
    return [dict(specs[k], id=cid) for cid, k in zip(case_ids(cfg), order)]


def write_part(cfg: dict, classes: list[str], path, workers: int = 1) -> list[dict]:
    """The cases of some classes with their reference verdicts (a part of the key's work), written to ``path``
    (JSON: every number as repr, so :func:`read_parts` gives back the same values)."""
    specs = draw_classes(blind_settings(cfg), classes, workers)
    io.write_json({"classes": list(classes), "specs": specs}, path)
    return specs


def read_parts(cfg: dict, paths) -> list[dict]:
    """The specs of :func:`write_part` files, in config class order (as :func:`draw_classes` of every class
    gives them); every class of the config exactly once."""
    by_class = {}
    for path in paths:
        part = io.read_json(path)
        for cls in part["classes"]:
            by_class[cls] = [dict(s, effects=[tuple(e) for e in s["effects"]]) for s in part["specs"]
                             if s["class"] == cls]
    missing = [c for c in counts(cfg) if c not in by_class]
    if missing:
        raise io.InputError(f"blind: no drawn part holds the class(es) {', '.join(missing)}")
    return [s for cls in counts(cfg) for s in by_class[cls]]


def draw_classes(cfg: dict, classes: list[str], workers: int = 1) -> list[dict]:
    """The cases of ``classes`` (each from its own stream, :func:`draw_cases`) with their reference verdicts,
    class by class, unshuffled."""
    current = current_path(cfg)
    specs = []
    pool = _pool(workers, current, int(cfg["rig_substeps"]))
    want = counts(cfg)
    try:
        for cls in classes:
            n = want[cls]
            kind, rng = class_kind(cls), class_stream(cfg, cls)
            made, tries, absorbed = 0, 0, 0
            draws = None if pool is None else _attempts(cls, kind, rng, cfg, current, pool, AHEAD * int(workers))
            while made < n:
                tries += 1
                if tries > 200 * n:
                    raise io.InputError(f"blind: could not draw {n} cases of class {cls!r} whose J-A truth "
                                        "integrates" + (" and whose gap is detectable" if cfg.get("detectable_only")
                                                        else "") + "; check blind.truth_box, "
                                        "blind.n_over_le_ranges, blind.magnitude and blind.openworld")
                if draws is None:
                    spec = _draw_one(cls, kind, rng, cfg, current)
                    det = None if spec is None else detectability(spec, cfg)
                else:
                    spec, det = next(draws)
                if spec is None:
                    continue
                if not _wanted(spec, det, cfg):
                    absorbed += 1
                    continue
                spec["reference"], spec["absorbed_before"], absorbed = det, absorbed, 0
                specs.append(spec)
                made += 1
            if draws is not None:
                draws.close()
    finally:
        if pool is not None:
            pool.terminate()
    return specs


def _pool(workers: int, current, substeps: int):
    """A process pool of ``workers``, or None for 1. The J-A kernel is compiled (or loaded from numba's cache)
    here first, so that the forked children share it instead of each compiling it."""
    if int(workers) <= 1:
        return None
    import multiprocessing

    rig.observe(np.array([1.0e6, 3.0e4, 1.0e-3, 0.3, 1.0e4]), current, rig.sample_times(current.size, 0.1), 3.0e3,
                [], substeps=substeps)
    return multiprocessing.get_context("fork").Pool(int(workers))


def simulate(spec: dict, cfg: dict):
    """The raw sweep of one case: (volts, time_s, current_A, sidecar)."""
    current = current_path(cfg)
    if spec["kind"] == "openworld":
        B, time_s, current, _ = noise_free(spec, cfg)
        return openworld.sense(B, time_s, current, noise_sigma_T=spec["noise_sigma_T"], seed=spec["noise_seed"],
                               n_over_le=spec["n_over_le"], dwell_s=spec["dwell_s"], sensor=SENSOR,
                               sensitivity_V_per_T=spec["sensitivity_V_per_T"])
    return rig.simulate_case(
        ja.as_param_array(spec["truth"]), spec["effects"], spec["noise_sigma_T"], spec["noise_seed"], current,
        n_over_le=spec["n_over_le"], sensor=SENSOR, dwell_s=spec["dwell_s"], substeps=int(cfg["rig_substeps"]),
        sensitivity_V_per_T=spec["sensitivity_V_per_T"], declare_limits=False)


def true_size(spec: dict) -> tuple[str, float] | tuple[None, None]:
    """(contract parameter, value) of a closed-world case's injected effect, as the diagnosis reports it."""
    if spec["kind"] != "closed" or not spec["effects"]:
        return None, None
    name, ep = spec["effects"][0]
    e = fx.REGISTRY[name]
    return e.param, float(e.reported(ep, spec["truth"]) if e.reported else ep[e.param])


def key_entry(s: dict) -> dict:
    det = s["reference"]
    pname, pval = true_size(s)
    entry = {"class": s["class"], "kind": s["kind"], "members": list(members(s["class"])),
             "effect_params": {name: dict(ep) for name, ep in s["effects"]}, "size_param": pname,
             "size_value": pval, "truth": s["truth"], "n_over_le": s["n_over_le"],
             "noise_sigma_T": s["noise_sigma_T"], "sigma_eff_T": det["sigma_eff_T"], "dwell_s": s["dwell_s"],
             "sensitivity_V_per_T": s["sensitivity_V_per_T"], "peak_T": s["peak_T"], "magnitude": s["magnitude"],
             "rms_left_T": det["rms_left_T"], "detectable": det["detectable"],
             "reference_params": det["reference_params"], "alternatives_rms_T": det["alternatives_rms_T"],
             "equivalent_to": det["equivalent_to"], "noise_seed": s["noise_seed"],
             "absorbed_draws_before": s["absorbed_before"]}
    if s["kind"] == "openworld":
        entry["mechanism_params"] = dict(s["mechanism"])
        entry["vocab_closes"] = det["vocab_closes"]
    if s["kind"] == "compound":
        entry["needed"] = det["needed"]
        entry["vocab_closes"] = det["vocab_closes"]
    return entry


def generate(cfg: dict, out_dir, key_path, workers: int = 1, parts=None) -> dict:
    """Write every case (raw sweep CSV + sidecar) into out_dir and the key to key_path; return the key.
    ``workers``: processes for the reference fits (:func:`draw_cases`; the same bytes for any number);
    ``parts``: :func:`write_part` files that hold every class already drawn (the same bytes again). ``cfg``:
    the ``blind`` section or :class:`~mrhyst.blind.settings.BlindSettings` (resolved here once; the key records
    them)."""
    cfg = blind_settings(cfg)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cases = {}
    drawn = draw_cases(cfg, workers) if parts is None else number(cfg, read_parts(cfg, parts))
    for s in drawn:
        volts, time_s, cur, side = simulate(s, cfg)
        rig.write_case(out_dir / f"{s['id']}.csv", volts, time_s, cur, side)
        cases[s["id"]] = key_entry(s)
    key = {"cases": cases, "settings": recorded(cfg),
           "detectable_rule": (f"scipy least_squares (TRF), plain J-A (physical form, alpha >= 0) started at the "
                               f"true parameters (open world: also at screened truth_box draws) on the noise-free "
                               f"loop, leaves RMS >= {cfg['detectable_factor']} x sigma_eff (white noise + ADC "
                               f"LSB^2/12); independent of mrhyst.diagnose")}
    io.write_json(key, key_path)
    return key
