"""Measured loops from other laboratories (data/external/, MIT): J-A fits on data nobody here produced.

The files (see data/external/README.md for source, licence and checksums):

* ``mnzn-ferrite-jamodel/loops.csv`` — Mn-Zn ferrite, four closed quasi-static major loops (129 samples
  each, +Hmax -> -Hmax -> +Hmax, no virgin curve), one ``loop_index`` per loop; each loop is fitted on its
  own, never as one path through all four;
* ``hiperco50-pyjam/loop.csv`` — Hiperco 50, one 804-sample path starting at H ~ 0 with B = -0.096 T
  (not demagnetised), up to +545, down to -544, up to +545 A/m.

How the model starts (chosen per loop by :func:`choose_start`, overridable per source in config):

* a **closed** loop (last sample = first sample in H and B, to a tolerance) was measured in its cyclic
  steady state, so the model is brought to *its* steady state before comparing: the path is repeated
  ``cyclic_passes`` times and only the last pass is compared (``start = "cyclic"``). The first pass starts
  from the magnetisation of the first measured sample, M0 = B[0]/mu0 - H[0] (not from M = 0, which is not
  a state at +Hmax): measured on the ferrite fits, the second pass is then within 1e-5 T of the third,
  whereas from M0 = 0 two passes leave up to 3.5e-4 T of transient (as large as the fit's RMS);
  ``cyclic_drift_T`` (last pass vs one more) is reported for every fit;
* an **open** path (ends elsewhere than it starts) has an unknown history before its first sample:
  repeating it would invent a jump from its end back to its start. The J-A state is the single number M,
  so fitting M0 = m0 Ms as a sixth coordinate fits the whole unknown starting state (``start = "fit"``).

Fitting (physical J-A form: a measured loop follows physics; ARCHITECTURE 5): in a box around a
data estimate (:func:`mrhyst.fit.identify.estimate_start`; each of Ms, a, alpha, k within a factor
``box_factor`` of it, log-scaled; c in [0, c_max]; m0 in [-1, 1]), clipped to the default box:

1. LSM (trust-region reflective) from the data estimate, and from the ``lsm_starts`` best of
   ``lsm_screen`` seeded random points of the box (screened in one batched call: most random points of a
   wide box hit the pole of Eq. 8, where LSM would sit on the flat fail cost; the ferrite's J has local
   minima, e.g. c -> 0 at 80 A/m);
2. PSO (``pso_setting`` of config pso.settings, ``n_particles`` x ``iterations``, seed ``seed``),
   then LSM from the PSO best (polish);
3. for a file with several loops of one material (``warm_start_across_loops``): LSM from each other
   loop's best fit;

and the lowest J wins. Every candidate's J is kept in the result, so the report can say which method
found what. Everything is seeded: the same config gives the same bytes.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from mrhyst.config import ConfigError
from mrhyst.data import loopfigures
from mrhyst.data.io import InputError, Loop, check_fittable, loop_indices, read_loops
from mrhyst.data.shape import path_shape
from mrhyst.fit import accuracy, identify
from mrhyst.fit.lsq import run_lsms
from mrhyst.fit.settings import FitSettings
from mrhyst.materials.extsettings import (  # noqa: F401  (re-exported: external.external_config etc.)
    ExternalSettings,
    LoopFitSettings,
    external_config,
    loop_fit_settings,
)
from mrhyst.materials.exttable import (  # noqa: F401  (re-exported: external.summary_table etc.)
    model_rows,
    peer_rows,
    summary_table,
    write_summary,
)
from mrhyst.model import ja

MU0 = ja.MU0
STARTS = ("auto", "cyclic", "fit", "first_sample", "demagnetised")
TIE_REL = 1e-6  # J values this close (relative) are the same minimum: the simpler method is named
# how far a loop's search goes (:meth:`_LoopFit.search`): its first stage, the first two, all three (the fit's)
SEARCH_DEPTHS = ("data_start", "multistart", "pso")


def sha256(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


# --------------------------------------------------------------------------------------------
# start state
# --------------------------------------------------------------------------------------------
def closure(H, B) -> tuple[float, float]:
    """(|H_end - H_start| / max|H|, |B_end - B_start| / B amplitude) of a measured path."""
    H, B = np.asarray(H, float), np.asarray(B, float)
    return (float(abs(H[-1] - H[0]) / max(np.max(np.abs(H)), 1e-300)),
            float(abs(B[-1] - B[0]) / max(0.5 * np.ptp(B), 1e-300)))


def choose_start(H, B, requested: str, tol_rel: float) -> tuple[str, str]:
    """(start, reason): 'cyclic' for a closed loop, 'fit' for an open path (see the module doc)."""
    ch, cb = closure(H, B)
    closed = ch <= tol_rel and cb <= tol_rel
    desc = (f"path {'closed' if closed else 'open'}: end - start = {ch:.2g} of max|H| in H, "
            f"{cb:.2g} of the B amplitude in B")
    if requested != "auto":
        return requested, f"set in config ({desc})"
    if closed:
        return "cyclic", (f"{desc}: a closed loop measured in steady state; model repeated, compared on its "
                          f"last pass (cyclic steady state), first pass from M0 = B[0]/mu0 - H[0]")
    return "fit", (f"{desc}: unknown history before the first sample, repeating the path would invent a jump; "
                   f"initial magnetisation m0 = M0/Ms fitted (the J-A state is M alone)")


# --------------------------------------------------------------------------------------------
# one loop
# --------------------------------------------------------------------------------------------
def _problem(H, B, valid, start: str, ext: dict, idc: dict) -> identify.Problem:
    jc = idc["ja"]
    # cyclic: first pass from the first sample's state (a tip of the loop), not from M = 0
    M0 = float(B[0] / MU0 - H[0]) if start == "cyclic" else 0.0
    return identify.Problem(H, B, valid, form=ext["form"], dman=jc["dman"], substeps=int(jc["substeps"]),
                            start=start, cyclic_passes=int(ext["cyclic_passes"]),
                            fail_cost_T=float(idc["pso"]["fail_cost_T"]), M0_fixed=M0, variant=ext["model"])


def data_box(prob: identify.Problem, ext: dict, idc: dict) -> identify.Box:
    """Box around the data estimate: Ms, a, alpha, k within a factor box_factor either way (log), c in
    [0, c_max], m0 in pso.m0_range; clipped to the default box. A variant's own parameters
    (ja.MODELS bounds) keep their full range."""
    base = identify.variant_box(identify.default_box(idc), prob.variant)
    if prob.start == "fit":
        base = base.with_m0(tuple(idc["pso"]["m0_range"]))
    x0 = identify.estimate_start(prob, base)
    f = float(ext["box_factor"])
    lo, hi, scale = np.array(base.lo), np.array(base.hi), list(base.scale)
    for i, n in enumerate(base.names):
        if n in ("Ms", "a", "alpha", "k"):
            lo[i], hi[i], scale[i] = x0[i] / f, x0[i] * f, "log"
        elif n == "c":
            lo[i], hi[i], scale[i] = 0.0, float(ext["c_max"]), "linear"
    lo, hi = np.maximum(lo, base.lo), np.minimum(hi, base.hi)
    return identify.Box(prob.names, lo, hi, tuple(scale), x0)


def cyclic_drift(prob: identify.Problem, x) -> float:
    """max |B(one more pass) - B(last compared pass)| at x: how far the model is from its steady state.

    Built as the same Problem with one more pass, so it follows identify's own cyclic path (including
    its bridge from the last sample back to the first)."""
    if prob.start != "cyclic":
        return 0.0
    more = identify.Problem(prob.H, prob.B, prob.valid, form=prob.form, dman=prob.dman, substeps=prob.substeps,
                            start="cyclic", cyclic_passes=int(prob.cyclic_passes) + 1,
                            fail_cost_T=prob.fail_cost_T, M0_fixed=prob.M0_fixed, variant=prob.variant)
    x = np.asarray(x, dtype=float)[None, :]
    B1, ok1 = prob.model(x)
    B2, ok2 = more.model(x)
    if not (ok1[0] and ok2[0]):
        return float(prob.fail_cost_T)
    return float(np.max(np.abs(B2[0] - B1[0])))


class _LoopFit:
    """The search for one loop: problem, box, and every candidate run (name -> {"J_T", "run", ...})."""

    def __init__(self, H, B, valid, start: str, ext: dict, idc: dict, shape=None):
        self.H = np.asarray(H, dtype=float)
        self.shape = shape if shape is not None else _shape_or_none(self.H)  # the loop's shape, derived once
        self.B = np.asarray(B, dtype=float)
        self.valid = np.ones(self.H.size, bool) if valid is None else np.asarray(valid, bool)
        self.ext, self.idc = ext, idc
        self.start, self.reason = choose_start(self.H, self.B, start, float(ext["closed_tol_rel"]))
        self.prob = _problem(self.H, self.B, self.valid, self.start, ext, idc)
        self.noise = accuracy.noise_floor(self.H, self.B, self.valid, self.shape, float(idc["ja"]["noise_clip"]))
        self.box = data_box(self.prob, ext, idc)
        lc = idc["lsm"]
        self.lsm_kw = {"max_iterations": int(ext["lsm_max_iterations"]), "method": lc["method"],
                       "ftol": float(lc["ftol"]), "xtol": float(lc["xtol"]), "gtol": float(lc["gtol"])}
        pc = idc["pso"]
        setting = ext["pso_setting"]
        if setting not in pc["settings"]:
            raise ConfigError(f"config.yaml: external.pso_setting: {setting!r} not in pso.settings "
                              f"({', '.join(pc['settings'])})")
        st = dict(pc["settings"][setting])
        self.pso_kw = {"n_particles": int(ext["n_particles"]), "iterations": int(ext["iterations"]),
                       "w": float(st["w"]), "c1": float(st["c1"]), "c2": float(st["c2"]),
                       "v_max_frac": float(st.get("v_max_frac", pc["v_max_frac"])),
                       "bh_strategy": st.get("bh_strategy", pc["bh_strategy"]), "oh_strategy": st.get("oh_strategy")}
        self.setting = setting
        self.cands: dict = {}
        self.n_lsm_starts = 0

    def settle_substeps(self) -> dict:
        """The substep count made good at the best fit (mrhyst.fit.accuracy, tolerance from config ja); after a
        raise every candidate's J is re-evaluated at the new count and LSM is run again from each of them."""
        jc = self.idc["ja"]
        noise = self.noise
        tol = accuracy.tolerance(noise, float(jc["integration_tol_frac"]), float(jc["integration_tol_T"]))
        n_max, rounds = int(jc["max_substeps"]), 0
        while True:
            err, raised = accuracy.settle(self.prob, self.best_x(), tol, n_max)
            if not raised or rounds >= 4:
                break
            rounds += 1
            for c in self.cands.values():
                c["J_T"] = float(self.prob.cost(np.asarray(c["run"]["x"], dtype=float)[None, :])[0])
            # the coarse search may have preferred a basin that only the step error made look good: LSM again
            # from every candidate (measured: M130-27s 217 A/m, 1.52 % from the coarse best, 1.2 % from another)
            runs = self.lsms([np.asarray(c["run"]["x"], dtype=float) for c in self.cands.values()])
            r = runs[int(np.argmin([q["J"] for q in runs]))]
            self.cands["lsm_finer_steps"] = {"J_T": r["J"], "run": r}
        self.accuracy = {"substeps": int(self.prob.substeps), "noise_floor_T": noise, "integration_tol_T": tol,
                         "integration_error_T": err, "substep_rounds": rounds}
        return self.accuracy

    def lsm(self, x0) -> dict:
        self.n_lsm_starts += 1
        return identify.run_lsm(self.prob, self.box, np.asarray(x0, dtype=float), **self.lsm_kw)

    def lsms(self, x0s: list) -> list:
        """[self.lsm(x0) for x0 in x0s], in lockstep (:func:`mrhyst.fit.lsq.run_lsms`: the same bytes)."""
        self.n_lsm_starts += len(x0s)
        return run_lsms(self.prob, self.box, x0s, **self.lsm_kw)

    def search(self, depth: str, substeps: int | None = None) -> None:
        """1. LSM from the data estimate; 2. LSM from the lsm_starts best of lsm_screen random points of the
        box (screened in one batched call: most random points of a wide box hit the pole of Eq. 8 and would
        leave LSM stuck on the flat fail cost); 3. PSO, then LSM from its best. ``depth`` (SEARCH_DEPTHS): the
        last stage run ("pso": all three, the fit table's search). ``substeps``: the step count (a caller that
        refits at its own); None: the count made good at the box centre."""
        if depth not in SEARCH_DEPTHS:
            raise ConfigError(f"material search depth must be one of {', '.join(SEARCH_DEPTHS)}, got {depth!r}")
        ext = self.ext
        jc = self.idc["ja"]
        tol = accuracy.tolerance(self.noise, float(jc["integration_tol_frac"]), float(jc["integration_tol_T"]))
        if substeps is None:
            accuracy.settle(self.prob, self.box.centre, tol, int(jc["max_substeps"]))
        self.prob.substeps = int(substeps or self.prob.substeps)
        r0 = self.lsm(self.box.centre)
        self.cands["lsm_data_start"] = {"J_T": r0["J"], "run": r0}
        if depth == "data_start":
            return
        rng = np.random.default_rng(int(ext["seed"]))
        X = self.box.to_x(rng.random((int(ext["lsm_screen"]), self.box.dim)))
        order = np.argsort(self.prob.cost(X), kind="stable")[: int(ext["lsm_starts"])]
        runs = [r0] + self.lsms([X[i] for i in order])
        Js = [r["J"] for r in runs]
        ib = int(np.argmin(Js))
        self.cands["lsm_multistart"] = {"J_T": Js[ib], "run": runs[ib], "best_start": ib, "J_per_start_T": Js}
        if depth == "multistart":
            return
        rp = identify.run_pso(self.prob, self.box, seed=int(ext["seed"]), **self.pso_kw)
        self.cands["pso"] = {"J_T": rp["J"], "run": rp}
        rpl = self.lsm(rp["x"])
        self.cands["pso+lsm"] = {"J_T": rpl["J"], "run": rpl}

    def best_x(self) -> np.ndarray:
        return np.asarray(self.cands[self.method()]["run"]["x"], dtype=float)

    def from_other_loops(self, others: list) -> None:
        """LSM from the other loops' fitted J-A parameters (same material, neighbouring amplitudes):
        a start the random ones may miss (ferrite at 80 A/m: c ~ 0.88 like the other loops, vs c -> 0)."""
        starts = []
        for x in others:
            x0 = np.array(x[: self.prob.npar], dtype=float)
            if self.start == "fit":
                x0 = np.append(x0, self.box.centre[5])
            starts.append(np.clip(x0, self.box.lo, self.box.hi))
        runs = self.lsms(starts)
        if runs:
            Js = [r["J"] for r in runs]
            ib = int(np.argmin(Js))
            self.cands["lsm_from_other_loops"] = {"J_T": Js[ib], "run": runs[ib], "J_per_start_T": Js}

    def method(self) -> str:
        """Lowest J wins; candidates within TIE_REL of it are ties, won by the simpler method (dict order)."""
        J_best = min(c["J_T"] for c in self.cands.values())
        return next(k for k, c in self.cands.items() if c["J_T"] <= J_best * (1.0 + TIE_REL))

    def result(self) -> dict:
        method = self.method()
        r = self.cands[method]["run"]
        x = np.asarray(r["x"], dtype=float)
        prob, box, ext = self.prob, self.box, self.ext
        Bm, ok = prob.model(x[None, :])
        amp = 0.5 * float(np.ptp(self.B[self.valid]))
        return {
            "start": self.start,
            "start_reason": self.reason,
            "cyclic_passes": int(ext["cyclic_passes"]) if self.start == "cyclic" else None,
            "form": prob.form,
            "dman": prob.dman,
            "method": method,
            "model": prob.variant,
            "params": {n: float(v) for n, v in zip(prob.par_names, x[: prob.npar])},
            "m0": float(x[5]) if self.start == "fit" else None,
            "M0_A_per_m": float(prob.split(x[None, :])[1][0]),
            "rms_T": float(r["J"]),
            "B_amplitude_T": amp,
            "H_amplitude_A_per_m": 0.5 * float(np.ptp(self.H)),
            "rms_rel": float(r["J"]) / amp,
            "history": [float(v) for v in r["history"]],
            "candidates": {k: {kk: vv for kk, vv in v.items() if kk != "run"}
                           | {"params": dict(zip(prob.par_names, map(float, v["run"]["x"][: prob.npar])))}
                           for k, v in self.cands.items()},
            "pso_settings": {k: v for k, v in self.pso_kw.items() if v is not None}
                            | {"setting": self.setting, "seed": int(ext["seed"])},
            "lsm_settings": self.lsm_kw | {"n_starts": self.n_lsm_starts, "screened_from": int(ext["lsm_screen"])},
            **identify.box_record(box),
            "at_box_edge": [n for n, u in zip(box.names, box.to_u(x)) if u <= 1e-6 or u >= 1 - 1e-6],
            "cyclic_drift_T": cyclic_drift(prob, x),
            **self.accuracy,
            "rms_rel_peak": float(r["J"]) / float(np.max(np.abs(self.B[self.valid]))),
            "loop_figures": loopfigures.side_by_side(self.H, self.B, Bm[0] if ok[0] else None, self.valid,
                                                     self.shape),
            "model_ok": bool(ok[0]),
            "n_samples": int(self.H.size),
            "n_valid": int(self.valid.sum()),
            "H_A_per_m": self.H.tolist(),
            "B_T": self.B.tolist(),
            "valid": self.valid.astype(int).tolist(),
            "B_model_T": Bm[0].tolist() if ok[0] else None,
        }


def _shape_or_none(H):
    try:
        return path_shape(H)
    except ValueError:  # H never changes: no shape (the noise floor is then 0)
        return None


def _loop_settings(config) -> LoopFitSettings:
    """The settings of one loop's fit, all from ``config``: a whole-config mapping or config.yaml path (its ja,
    pso, lsm and external sections over the schema's), or :class:`LoopFitSettings`. The fit's sections alone
    (:class:`FitSettings`) lack the external one: refused, not silently run with the schema's external section."""
    if isinstance(config, FitSettings):
        raise TypeError("a loop fit needs the external section too: pass the whole config or LoopFitSettings")
    return loop_fit_settings(config)


def fit_path(H, B, valid=None, *, start: str = "auto", config=None, shape=None) -> dict:
    """Fit one measured B(H) path (LSM from the data estimate and screened random starts, PSO -> LSM;
    lowest J wins). Returns a dict with params, rms_T, rms_rel (RMS / B amplitude), method, start and
    its reason, every candidate's J, the measured and fitted B, the box, the cyclic drift and the
    integration error. ``config``: see :func:`_loop_settings`. ``shape``: H's :class:`mrhyst.data.shape.PathShape`,
    when known."""
    s = _loop_settings(config)
    f = _LoopFit(H, B, valid, start, s.external, s.fit, shape)
    f.search("pso")
    f.settle_substeps()
    return f.result()


def search_path(H, B, valid=None, *, depth: str, start: str = "auto", config=None, shape=None,
                substeps: int | None = None) -> dict:
    """The search of :func:`fit_path` alone, for a start that another fit refines at its own step count (the
    diagnosis of a B(H) loop): {"params", "rms_T", "method", "substeps"} of its lowest J, at ``substeps`` (the
    refit's own count) or, when None, at the count made good at the box centre. Settling the count at the best
    fit (LSM again from every candidate after a raise) costs a third of a fit_path and moves a start by less
    than the refit that follows it (M130-27s loop 2: J 14.446 against 14.450 mT). ``depth``: the search's last
    stage (SEARCH_DEPTHS; "pso" is fit_path's whole search)."""
    s = _loop_settings(config)
    f = _LoopFit(H, B, valid, start, s.external, s.fit, shape)
    f.search(depth, substeps)
    x = f.best_x()
    method = f.method()
    return {"params": {n: float(v) for n, v in zip(f.prob.par_names, x[: f.prob.npar])},
            "rms_T": float(f.cands[method]["J_T"]), "method": method, "substeps": int(f.prob.substeps)}


# --------------------------------------------------------------------------------------------
# one source file
# --------------------------------------------------------------------------------------------
def fit_source(path, name: str | None = None, *, config=None, start: str | None = None, out=None,
               loop_index: int | None = None) -> dict:
    """Fit every loop of a third-party B(H) file (one per loop_index, or the one path) and return
    {"source", "file", "sha256", "loops": [per-loop fit]}; written to ``out`` (JSON) if given.

    Each loop is searched on its own (:func:`fit_path`); with several loops (one material), each is then
    also started from the others' fits (``warm_start_across_loops``). ``start``: None = the source's
    config entry (or auto); ``loop_index``: fit only that loop.
    """
    path = Path(path)
    ext = external_config(config)
    idc = identify.resolve_config(config)
    src_cfg = ext["sources"].get(name, {}) if name else {}
    start = start or src_cfg.get("start", "auto")
    if start not in STARTS:
        raise InputError(f"start must be one of {', '.join(STARTS)}, got {start!r}")
    loops: list[Loop] = read_loops(path)
    idx = loop_indices(loops)
    if loop_index is not None:
        if int(loop_index) not in idx:
            raise InputError(f"{path}: no loop_index {loop_index} (have {', '.join(map(str, idx))})")
        loops = [loops[idx.index(int(loop_index))]]
        idx = [int(loop_index)]
    for lp in loops:
        check_fittable(lp)
    fits = [_LoopFit(lp.H_A_per_m, lp.B_T, lp.valid, start, ext, idc) for lp in loops]
    for f in fits:
        f.search("pso")
    if ext["warm_start_across_loops"] and len(fits) > 1:
        best = [f.best_x() for f in fits]  # from the independent searches only (order does not matter)
        for i, f in enumerate(fits):
            f.from_other_loops([x for j, x in enumerate(best) if j != i])
    for f in fits:
        f.settle_substeps()
    results = [{"loop_index": li, **f.result()} for li, f in zip(idx, fits)]
    res = {"source": name or path.stem, "file": str(path), "sha256": sha256(path), "loops": results}
    if ext["joint"] and len(fits) > 1:
        own = [r["rms_T"] for r in results]  # each loop's own fit: the scale of joint weight "own"
        jkw = {"weight": src_cfg.get("joint_weight"), "loop_rms": own}
        res["joint"] = fit_joint(loops, fits, idx, ext, config, model=src_cfg.get("joint_model"), **jkw)
        # the same joint fit with other J-A variants (config external.sources.NAME.joint_models)
        variants = {m: fit_joint(loops, fits, idx, ext, config, model=m, **jkw)
                    for m in src_cfg.get("joint_models", [])}
        if variants:
            res["joint_variants"] = variants
    if ext["model_selection"]:
        done = {**(res.get("joint_variants") or {})}
        if res.get("joint"):
            done[res["joint"]["model"]] = res["joint"]  # the same call as auto's for that variant: not fitted twice
        auto = select_variant(loops, fits, idx, ext, config, src_cfg, [r["rms_T"] for r in results], done)
        if auto is not None:
            res["auto"] = auto
    if out is not None:  # the per-sample arrays (measured H, B, valid; each fit's B) in OUT.curve.csv (issue 26)
        from mrhyst.data.curves import write_result

        write_result(res, out)
    return res


def select_variant(loops: list, fits: list, idx: list, ext: dict, config, src_cfg: dict, own: list,
                   done: dict | None = None) -> dict | None:
    """`--model auto` for one file (issue 26): every variant of ja.auto.variants as one parameter set for all its
    loops (:func:`fit_joint`, the file's joint weight, started from every loop's optima), chosen by BIC with a
    held-out check on the split of ``ja.auto.heldout`` (default ``blocks``: ``heldout_folds`` contiguous blocks
    along each path; :mod:`mrhyst.fit.select`); the chosen fit is ``fit``. ``done``: joint
    fits of some variants already made with the same settings (the file's joint fit and joint_variants)."""
    done = done or {}
    from mrhyst.fit import select

    idc = identify.resolve_config(config)
    weight = src_cfg.get("joint_weight")
    if len({f.start for f in fits}) != 1:
        return None
    kw = {"form": ext["form"], "config": config, "start": fits[0].start, "joint_weight": weight}
    sel, vfits = select.compare(
        select.variants_for(list(loops) if len(loops) > 1 else loops[0], idc),
        lambda v: done[v] if v in done else fit_joint(loops, fits, idx, ext, config, model=v, weight=weight,
                                                      loop_rms=own),
        lambda v, full: select.heldout(list(loops), "lsm", dict(kw, model=v), full),
        lambda v, full, x: _joint_record(select.fit_from(list(loops), "lsm", dict(kw, model=v), full, x, False)),
        float(idc["ja"]["auto"]["heldout_tol"]))
    return {**sel, "fit": vfits[sel["model_choice"]["variant"]]}


def fit_joint(loops: list, fits: list, idx: list, ext: dict, config, model: str | None = None,
              weight: str | None = None, loop_rms=None) -> dict | None:
    """One parameter set for every loop of the file (mrhyst.fit.identify.fit_loop on the list, LSM), started
    from each distinct optimum of each loop's own search; None if the loops need different kinds of start.
    weight: the joint objective's (None: config ja.joint_weight); "own" scales each loop by loop_rms (T)."""
    kinds = sorted({f.start for f in fits})
    if len(kinds) != 1:
        return None
    npar = fits[0].prob.npar
    starts, seen = [], []
    for li, f in zip(idx, fits):
        # every distinct optimum a loop's search found (not only its best: the joint optimum of M130-27s lies
        # near the second-best basin of its 217 A/m loop); duplicates (same J to 1e-6) once
        for name, c in f.cands.items():
            J = c["J_T"]
            if J >= f.prob.fail_cost_T or any(abs(J - J0) <= 1e-6 * J0 for J0 in seen):
                continue
            seen.append(J)
            starts.append((f"loop {li} {name}", np.asarray(c["run"]["x"], dtype=float)[:npar]))
    if model == "anisotropic":
        # slow per evaluation (a quadrature per step): from the box centre alone (measured on M130-27s: the same
        # optimum as from the 8 starts of the loops' fits, in 1/4 of the time). Other variants start from the
        # loops' optima, their own parameters at the box centre (amplitude: exponents 0, the classic model).
        starts = []
    kw = dict(form=ext["form"], config=config, start=kinds[0], model=model or ext["model"])
    if weight == "own":
        r = identify.fit_joint_own(loops, starts, loop_rms, **kw)
    else:
        r = identify.fit_loop(list(loops), "lsm", starts=starts, joint_weight=weight, **kw)
    return _joint_record(r)


def _joint_record(r: dict) -> dict:
    """What a joint fit's result keeps of identify.fit_loop's dict."""
    keep = ("params", "model", "form", "start", "rms_T", "joint_objective_T", "joint_weight", "joint_loop_rms_T",
            "joint_rounds", "joint_round_ftol", "substeps", "substeps_floor", "noise_floor_T", "integration_tol_T",
            "integration_error_T", "lsm_start", "lsm_starts", "n_iterations", "n_model_evaluations", "at_box_edge",
            "warnings", "per_loop", "model_ok")
    return {k: r[k] for k in keep if k in r}
