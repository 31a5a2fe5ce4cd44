"""Identification of the J-A parameters (Li & Gong 2019, section "Parameters Identification").

Two methods, one objective:

* the objective is J of Eq. (15), the RMS of B_m - B_d over the measured samples
  (samples flagged ``saturated`` are left out: they are not valid B);
* **PSO** (Eq. 14) with pyswarms 1.3.0 ``GlobalBestPSO``; the paper's setting is 100 particles,
  100 iterations, w = 1, c1 = c2 = 2, a box of +-100 % around a centre;
* **LSM** with ``scipy.optimize.least_squares`` (trust-region reflective) from the box centre,
  bounded by the same box as PSO: with a group, one box per group shared by both methods
  (config ``pso.box.around``, :func:`box_for`); the paper's per-method boxes are a stated variant.
* the CLI's default PSO (config ``pso.cli_setting: converge``) is Clerc's constriction setting on the
  log-scaled default box followed by a least-squares polish from the swarm's best (:func:`polish_pso`);
  the paper's setting (w = 1, c1 = c2 = 2, no polish) stays ``--pso-setting paper`` and makes Tables 1-3.

Both work in *normalised coordinates* u in [0, 1]^D: x = lo + u (hi - lo) (or the same on log x
for a log-scaled box). PSO is invariant under this per-dimension affine map (Eq. 14 acts
coordinate-wise), so the swarm moves exactly as it would in physical units with a per-parameter
v_max = v_max_frac * (hi - lo); it makes one v_max meaningful for parameters that differ by ten
orders of magnitude (alpha ~ 1e-4, Ms ~ 1e6) and gives least_squares a well-scaled problem.

What an "iteration" is (Figs. 9-10, Table 3):

* PSO: one evaluation of the whole swarm followed by one velocity/position update (Eq. 14);
  ``history[t-1]`` is the best J found after iteration t (pyswarms' ``cost_history``), so
  ``history[0]`` is the best of the random initial swarm.
* LSM: one outer iteration of scipy's TRF: a Jacobian (finite differences, D extra residual
  evaluations) and one or more trial steps until one lowers the cost (or the solver stops).
  ``history[t-1]`` is J at the accepted point after iteration t (scipy's ``callback``). When the
  solver converges before iteration t, J "after t iterations" is its final value
  (:func:`mrhyst.paper.tables.j_at_iteration` says so with a flag).

Start of the path: the paper starts demagnetised at 0 A (M0 = 0). A third-party B(H) loop may start
elsewhere on a branch (e.g. shared/data/real/hiperco50-pyjam starts at B = -0.096 T, H ~ 0); then the
initial magnetisation can be fitted as a sixth coordinate m0 = M0 / Ms in [-1, 1] (``start="fit"``),
taken from the first sample (``"first_sample"``), or the path run ``cyclic_passes`` times from the first
sample's state and compared on the last pass (cyclic steady state, ``"cyclic"``).

A candidate whose integration fails (``ja.simulate`` ok = False: pole of Eq. 8, overflow) gets the
large *finite* cost ``fail_cost_T`` (never NaN/inf); in LSM its residual vector is that constant.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mrhyst.data import loopfigures
from mrhyst.data.io import InputError, check_fittable, read_loop
from mrhyst.fit import accuracy
from mrhyst.fit.box import Box, box_for, box_record, model_spec, variant_box
from mrhyst.fit.joint import JointProblem
from mrhyst.fit.lsq import run_lsm
from mrhyst.fit.problem import _read_n_over_le, estimate_start, problem_from_loop
from mrhyst.fit.pso import polish_pso, run_pso
from mrhyst.fit.settings import JA_NAMES, M0_NAME, METHODS, MU0, resolve_config
from mrhyst.model import ja
from mrhyst.paper import tables as metrics


def _problems(loops, *, n_over_le, form, dman, substeps, start, cfg, variant):
    """One Problem per loop (each with its own start state) and the info of each."""
    out = [problem_from_loop(lp, n_over_le=n_over_le, form=form, dman=dman, substeps=substeps, start=start,
                             cfg=cfg, variant=variant) for lp in loops]
    return [p for p, _ in out], [i for _, i in out]


def _fit_box(prob, cfg, group, method, variant, joint: bool, loop_kind: str) -> tuple[Box, str]:
    """The search box (classic names from config, a variant's own from ja.MODELS) [+ m0 per loop],
    its centre estimated from the data for a B(H) loop without a group (config lsm.start_bh)."""
    box, src = box_for(cfg, group, method)
    box = variant_box(box, variant)
    m0r = tuple(cfg["pso"]["m0_range"])
    subs = prob.probs if joint else [prob]
    if prob.start == "fit":
        box = Box(prob.names, np.append(box.lo, [m0r[0]] * len(subs)), np.append(box.hi, [m0r[1]] * len(subs)),
                  tuple(box.scale) + ("linear",) * len(subs), np.append(box.centre, [0.0] * len(subs)))
    if group is None and loop_kind == "bh" and cfg["lsm"].get("start_bh") == "data":
        box.centre = _data_centre(prob, box, subs)
        src += "; start estimated from the data" + (" (largest loop)" if joint else "")
    return box, src


def _data_centre(prob, box: Box, subs: list) -> np.ndarray:
    """estimate_start of the loop with the largest B amplitude (joint: its shared parameters, and each
    loop's own m0 from its first sample)."""
    big = int(np.argmax([np.ptp(p.Bv) for p in subs]))
    npar = subs[0].npar
    one = Box(subs[big].names, box.lo[: len(subs[big].names)], box.hi[: len(subs[big].names)],
              box.scale[: len(subs[big].names)], box.centre[: len(subs[big].names)])
    x = estimate_start(subs[big], one)[:npar]
    if prob.start == "fit":
        m0 = [float(np.clip((p.B[0] / MU0 - p.H[0]) / x[0], -1.0, 1.0)) for p in subs]
        x = np.append(x, m0)
    eps = 1e-9 * (box.hi - box.lo)
    return np.clip(x, box.lo + eps, box.hi - eps)


def _accuracy_target(subs: list, jc: dict) -> tuple[float, float]:
    """(noise floor of the data: smallest over the loops, tolerance on the step error)."""
    floors = [accuracy.noise_floor(p.H, p.B, p.valid, p.shape, float(jc["noise_clip"])) for p in subs]
    pos = [f for f in floors if f > 0]
    noise = min(pos) if pos else 0.0
    return noise, accuracy.tolerance(noise, float(jc["integration_tol_frac"]), float(jc["integration_tol_T"]))


def _search(prob, box: Box, method: str, cfg: dict, *, seed, setting, pso_overrides, tol: float,
            starts=None, centre: bool = True) -> tuple:
    """Run PSO or LSM with the substep count settled by accuracy.accurate; (result, extras for the JSON).
    LSM starts at the box centre (unless ``centre`` is False and there are ``starts``) and at each of ``starts``
    [(name, x)]; the lowest J wins."""
    pc, lc = cfg["pso"], cfg["lsm"]
    n_max = int(cfg["ja"]["max_substeps"])
    if method == "pso":
        setting = setting or pc["setting"]
        if setting not in pc["settings"]:
            raise InputError(f"PSO setting {setting!r} not in config pso.settings ({', '.join(pc['settings'])})")
        s = dict(pc["settings"][setting])
        kw = {"n_particles": int(pc["n_particles"]), "iterations": int(pc["iterations"]),
              "w": float(s["w"]), "c1": float(s["c1"]), "c2": float(s["c2"]),
              "v_max_frac": float(s.get("v_max_frac", pc["v_max_frac"])),
              "bh_strategy": s.get("bh_strategy", pc["bh_strategy"]),
              "oh_strategy": s.get("oh_strategy")}
        kw.update(pso_overrides or {})
        r, acc = accuracy.accurate(lambda x0: run_pso(prob, box, seed=int(seed), **kw), prob, box.centre, tol, n_max)
        extra = {"seed": int(seed), "setting": setting, "settings": kw, **acc}
        if s.get("polish"):  # a convergent swarm + least-squares polish (the CLI's default, issue 14)
            r = polish_pso(prob, box, r, lc, extra)
        return r, extra
    lkw = {"max_iterations": int(lc["max_iterations"]), "method": lc["method"], "ftol": float(lc["ftol"]),
           "xtol": float(lc["xtol"]), "gtol": float(lc["gtol"]), "diff_step": lc.get("diff_step")}
    best = None
    tried = []
    todo = ([("box centre", box.centre)] if centre or not starts else []) + list(starts or [])
    while todo:
        name, x0 = todo.pop(0)
        x0 = np.clip(np.asarray(x0, dtype=float), box.lo, box.hi)
        n_before = prob.substeps
        if name != "box centre" and prob.cost(x0[None, :])[0] >= prob.fail_cost_T:
            # a coarse step may overshoot into the pole of Eq. 8 where a finer one does not: allow a finer count
            # (at most 4x, so that one start next to the pole does not set the count of the whole fit)
            accuracy.settle(prob, x0, tol, min(n_max, 4 * n_before))
            if prob.cost(x0[None, :])[0] >= prob.fail_cost_T:
                # e.g. one loop's own fit hits the pole on another loop: LSM would sit on the flat fail cost
                prob.substeps = n_before  # a start not taken does not set the count
                tried.append({"start": name, "J_T": None})
                if not todo and best is None and not centre:  # the warm start alone could not be taken
                    todo.append(("box centre", box.centre))
                continue
        # a start ending above the best so far by more than its own step error loses at any count: not refined
        J_best = math.inf if best is None else best[0]["J"]
        r, acc = accuracy.accurate(lambda xs: run_lsm(prob, box, xs, **lkw), prob, x0, tol, n_max,
                                   beaten=lambda res, err, J_best=J_best: res["J"] - err > J_best)
        tried.append({"start": name, "J_T": r["J"]})
        if best is None or r["J"] < best[0]["J"]:
            best = (r, acc, name, x0)
        else:
            # nor does a start that does not win: the count its own solution needed is not the best one's, and
            # every later start would run at it (measured: M130-27s, amplitude, joint: a start ending 5x above
            # the optimum raised 21 -> 512 substeps and the next start found the same optimum at 24x the cost)
            prob.substeps = n_before
    r, acc, name, x0 = best
    acc["integration_error_T"] = accuracy.step_error(prob, r["x"])  # at the final count (may have risen)
    acc["substeps"] = int(prob.substeps)
    return r, {"seed": None, "setting": "lsm",
               "settings": {k: lc[k] for k in ("method", "max_iterations", "ftol", "xtol", "gtol", "diff_step")},
               "J_start_T": r["J_start"], "lsm_status": r["status"], "lsm_message": r["message"],
               "start_params": {n: float(v) for n, v in zip(box.names, x0)}, "lsm_start": name,
               **({"lsm_starts": tried} if len(tried) > 1 else {}), **acc}


def _per_loop(prob, x, loops, infos, joint: bool) -> list[dict]:
    """Each loop's RMS (T, and relative to its peak |B|), start, model B and loop figures side by side."""
    subs = prob.probs if joint else [prob]
    out = []
    for i, (p, lp, info) in enumerate(zip(subs, loops, infos)):
        xi = prob.sub_x(x, i)[0] if joint else x
        B, ok = p.model(xi[None, :])
        peak = float(np.max(np.abs(p.Bv)))
        e = {"loop_index": None if lp.loop_index is None else int(lp.loop_index[0]), "start": info["start"],
             "n_samples": info["n_samples"], "n_valid": info["n_valid"], "B_peak_T": peak}
        if p.start == "fit":
            e["m0"] = float(xi[p.npar])
        e["M0_A_per_m"] = float(p.split(xi[None, :])[1][0])
        if ok[0]:
            d = B[0][p.valid] - p.Bv
            e["rms_T"] = float(np.sqrt(np.mean(d**2)))
            e["rms_rel"] = e["rms_T"] / peak
            e["B_model_T"] = [float(v) for v in B[0]]
        else:
            e["rms_T"], e["rms_rel"], e["B_model_T"] = float(p.fail_cost_T), None, None
        e["loop_figures"] = loopfigures.side_by_side(p.H, p.B, e["B_model_T"], p.valid, p.shape)
        out.append(e)
    return out


def _own_fits(loops, box: Box, prob, **kw) -> list:
    """Starts of a joint LSM: each loop's own LSM fit (its parameters; every loop's m0 at the box centre).
    The joint optimum of one material is usually near the fit of one of its loops (measured on M130-27s:
    from the largest loop's fit), which random starts of the wide box rarely find."""
    out = []
    for lp in loops:
        f = fit_loop(lp, "lsm", form=kw["form"], n_over_le=kw["n_over_le"], config=kw["config"],
                     group=kw["group"], start=kw["start"], substeps=kw["substeps"], model=kw["variant"])
        x = np.array(box.centre, dtype=float)
        x[:5] = [f["params"][n] for n in JA_NAMES]
        li = "" if lp.loop_index is None else f" {int(lp.loop_index[0])}"
        out.append((f"own fit of loop{li}", x))
    return out


def fit_loop(loop, method: str, *, form=None, seed: int | None = None, n_over_le=None, config=None,
             group: str | None = None, setting: str | None = None, start: str | None = None,
             substeps: int | None = None, pso_overrides: dict | None = None, model: str | None = None,
             starts: list | None = None, joint_weight: str | None = None, loop_rms=None,
             centre: bool = True) -> dict:
    """Fit one loop, or one parameter set to several (a list of Loops: a joint fit, each loop with its own
    start state, objective summed over the loops, see mrhyst.fit.joint); returns the fit JSON as a dict.
    starts: extra LSM starts [(name, model parameters)]; a joint LSM fit without them starts from each
    loop's own fit; ``centre=False``: LSM from ``starts`` only, not also from the box centre (a fit warm-started
    from a nearby optimum). joint_weight: None = config ja.joint_weight; "own" needs loop_rms (T, one per loop). form,
    model, substeps: None = config ja's; seed: None = the first of config pso.seeds."""
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    joint = isinstance(loop, (list, tuple))
    loops = list(loop) if joint else [loop]
    cfg = resolve_config(config)
    jc = cfg["ja"]
    form = form or jc["form"]
    if form not in ja.FORMS:
        raise InputError(f"form must be one of {', '.join(ja.FORMS)}, got {form!r}")
    variant = model or jc["model"]
    model_spec(variant)
    floor = int(substeps or jc["substeps"])
    seed = int(cfg["pso"]["seeds"][0]) if seed is None else int(seed)
    subs, infos = _problems(loops, n_over_le=_read_n_over_le(n_over_le), form=form, dman=jc["dman"],
                            substeps=floor, start=start, cfg=cfg, variant=variant)
    prob = (JointProblem(subs, weight=joint_weight or jc["joint_weight"], m0_name=M0_NAME, loop_rms=loop_rms)
            if joint else subs[0])
    box, box_source = _fit_box(prob, cfg, group, method, variant, joint, loops[0].kind)
    noise, tol = _accuracy_target(subs, jc)
    if starts is not None:  # given values first, the rest (a variant's own parameters, m0s) at the box centre
        starts = [(nm, np.concatenate([np.asarray(p, dtype=float)[: prob.npar], box.centre[min(len(p), prob.npar):]]))
                  for nm, p in starts]
    elif joint and method == "lsm" and prob.par_names == JA_NAMES:
        # (a variant with parameters of its own, e.g. anisotropic, is slow per evaluation and found its joint
        # optimum from the box centre alone on M130-27s: 1.33 / 2.24 / 3.01 % of peak, the same as from the
        # loops' own fits at 4x the time)
        starts = _own_fits(loops, box, prob, form=form, n_over_le=n_over_le, config=cfg, group=group,
                           start=start, substeps=floor, variant=variant)
    r, extra = _search(prob, box, method, cfg, seed=seed, setting=setting, pso_overrides=pso_overrides, tol=tol,
                       starts=starts, centre=centre)
    x = r["x"]
    out = {"method": method, "form": form, "dman": jc["dman"], "model": variant, "substeps_floor": floor,
           "noise_floor_T": noise, "loop": Path(loops[0].path).name, "loop_kind": loops[0].kind, "group": group,
           **box_record(box), "box_source": box_source, **(infos[0] if not joint else {"start": infos[0]["start"]}),
           **extra}
    out["params"] = {n: float(v) for n, v in zip(subs[0].par_names, x[: subs[0].npar])}
    if prob.start == "fit" and not joint:
        out["m0"] = float(x[prob.npar])
        out["M0_A_per_m"] = float(x[prob.npar] * x[0])
    out["history"] = r["history"]
    out["n_iterations"] = len(r["history"])
    out["n_model_evaluations"] = int(r["n_evals"])
    out["per_loop"] = _per_loop(prob, x, loops, infos, joint)
    ok = all(e["B_model_T"] is not None for e in out["per_loop"])
    # a step error at the fail cost (B at twice the steps fails) or infinite: no model to trust (issue 25)
    err = float(out["integration_error_T"])
    out["model_ok"] = ok and err < subs[0].fail_cost_T  # (inf < fail cost is False)
    out["rms_T"] = prob.rms_all(x) if joint else r["J"]
    if joint:
        out["joint_objective_T"] = r["J"]
        out["joint_weight"] = prob.weight
        out["loop_index"] = [e["loop_index"] for e in out["per_loop"]]
        out["n_samples"] = int(sum(i["n_samples"] for i in infos))
        out["n_valid"] = int(prob.nv)
    elif ok:
        Bd = np.asarray(out["per_loop"][0]["B_model_T"])
        out["B_model_T"] = out["per_loop"][0]["B_model_T"]
        mc = cfg["metrics"]
        out["metrics"] = metrics.error_measures(prob.B, Bd, prob.valid, relative=mc["relative"],
                                                floor_frac=float(mc["pointwise_floor_frac"]))
        out["loop_figures"] = out["per_loop"][0]["loop_figures"]
    out["at_box_edge"] = [n for n, u in zip(box.names, box.to_u(x)) if u <= 1e-6 or u >= 1 - 1e-6]
    mf = cfg["pso"].get("min_fitness_T")
    if mf is not None:
        hit = [i + 1 for i, v in enumerate(out["history"]) if v <= float(mf)]
        out["min_fitness_reached_at"] = hit[0] if hit else None
    out["warnings"] = _warnings(out, tol)
    return out


def _warnings(out: dict, tol: float) -> list[str]:
    warn = []
    if not out["model_ok"]:
        warn.append("the J-A integration fails at the returned parameters (J = fail_cost_T, or at twice the steps: "
                    "integration_error_T)")
    if out["integration_error_T"] > tol:
        warn.append(f"integration error {out['integration_error_T']:.2g} T exceeds its tolerance {tol:.2g} T "
                    f"at the largest substep count ({out['substeps']}; config ja.max_substeps)")
    if out["at_box_edge"]:
        warn.append(f"at the box edge: {', '.join(out['at_box_edge'])} (the optimum may lie outside the box)")
    return warn


def parse_loop_selection(text: str | None, available: list) -> list | int | None:
    """--loop-index: None, one index N, 'all', or a comma list '0,2' (a joint fit of those loops)."""
    if text is None:
        return None
    t = str(text).strip()
    if t == "all":
        return list(available)
    try:
        vals = [int(v) for v in t.split(",")]
    except ValueError:
        raise InputError(f"--loop-index: expected a whole number, 'all' or a list like 0,2; got {text!r}") from None
    if len(vals) != len(set(vals)):
        raise InputError(f"--loop-index: a loop is listed twice in {text!r}")
    return vals[0] if len(vals) == 1 and "," not in t else vals


def fit_joint_own(loops: list, starts: list, own, rounds: int | None = None, **kw) -> dict:
    """Joint weight "own" (LSM), reweighted towards the smallest worst ratio (joint RMS / own RMS) over the loops.

    Round 1 scales each loop by its own fit's RMS s_i (``own``, T; a least-squares sum of squared ratios); each
    next round multiplies loop i's weight by r_i / mean(r) (r_i its ratio in the round before) and refits from
    there, so the loops furthest from their own fit gain weight: iteratively reweighted least squares towards
    min max r_i (Lawson's algorithm in its multiplicative form). ``rounds``: None = config ja.joint_rounds. The
    round with the smallest max r_i is returned, with every round's weights and ratios (``joint_rounds``).
    kw: fit_loop's keywords (form, config, start, model, ...)."""
    cfg = resolve_config(kw.get("config"))
    rounds = int(rounds or cfg["ja"]["joint_rounds"])
    # rounds after the first start at the round before's optimum: they stop at config ja.joint_round_ftol
    later = dict(kw, config=cfg.replace(lsm={"ftol": float(cfg["ja"]["joint_round_ftol"])}))
    own = np.asarray(own, dtype=float)
    w = np.ones(own.size)
    best, log = None, []
    for i in range(rounds):
        # round 1 from the starts and the box centre; each next round from the round before only (it changes the
        # weights a little: measured on the ferrite, anisotropic, the box centre never won a round after the first)
        r = fit_loop(list(loops), "lsm", starts=starts, joint_weight="own", loop_rms=own / w, centre=i == 0,
                     **(later if i else kw))
        ratio = np.array([e["rms_T"] for e in r["per_loop"]]) / own
        log.append({"weights": w.tolist(), "ratios": ratio.tolist()})
        if best is None or ratio.max() < best[0]:
            best = (float(ratio.max()), r)
        starts = [(f"round {i + 1}", np.asarray(list(r["params"].values()), dtype=float))]
        w = w * ratio / ratio.mean()
    r = best[1]
    r["joint_loop_rms_T"] = own.tolist()  # the scale of each loop (its own fit's RMS), before the reweighting
    r["joint_rounds"] = log
    r["joint_round_ftol"] = float(later["config"]["lsm"]["ftol"])  # rounds 2..'s stop, as run
    return r


def fit_file(loop_path, method: str, form: str | None = None, seed: int | None = None, out=None, n_over_le=None,
             config=None, group: str | None = None, setting: str | None = None, start: str | None = None,
             substeps: int | None = None, loop_index=None, model: str | None = None,
             joint_weight: str | None = None) -> dict:
    """`mrhyst fit LOOP.csv --method pso|lsm [--form paper|physical] [--seed N] [--loop-index N|all|0,2]
    [--model NAME] [--joint-weight none|amplitude|own] --out FIT.json`.

    loop_path: a loop file (step,current_A,H_A_per_m,B_T,branch[,saturated]) or a third-party B(H)
    loop (H_A_per_m,B_T or H,B). method: 'pso' or 'lsm'. form: None = config ja.form (the schema's without a
    config). seed: None = the first of config pso.seeds. n_over_le: turns per metre (number, or the path of
    results/sim/n_over_le.json); used for a loop file (H = N/Le I, Eq. 12); None = the loop's H column. config:
    None (the schema defaults), a mapping, a config.yaml path or FitSettings. group: with a config, selects the
    paper's +-100 % box around that group's Table 1 value of ``method``; None = the default box. setting: PSO
    setting name in config pso.settings ('paper' default, 'clerc'). start: how the path starts
    ('demagnetised' | 'first_sample' | 'fit' | 'cyclic'; None = config pso.start by loop kind).
    substeps: the floor of the RK4 steps per sample interval (None = config ja.substeps); the count
    used is raised until the step error is within tolerance (mrhyst.fit.accuracy). loop_index: None (a
    file with one loop), one index, or a list of indices / 'all' (one parameter set for those loops).
    model: J-A variant (None = config ja.model). joint_weight: of a joint fit (None = config ja.joint_weight);
    "own" first fits each loop alone (LSM), then jointly with each loop scaled by its own fit's RMS, in
    ja.joint_rounds reweighting rounds (:func:`fit_joint_own`; LSM only).

    Returns the fit dict: {"params": {...}, "rms_T": J (Eq. 15), "history": [J after each
    iteration], "per_loop": [...], ...extras}; writes it (deterministic JSON) to ``out`` if given.
    Same seed -> same bytes.
    """
    loop, loop_index = read_selection(loop_path, loop_index)
    kw = dict(form=form, config=config, start=start, substeps=substeps, model=model, seed=seed, n_over_le=n_over_le,
              group=group, setting=setting, joint_weight=joint_weight)
    if (model or resolve_config(config)["ja"]["model"]) == "auto":
        from mrhyst.fit.select import fit_auto  # every variant fitted and compared (issue 26)

        res = fit_auto(loop, method, loop_index, **kw)
    else:
        res = fit_loops(loop, method, loop_index, **kw)
    if out is not None:
        from mrhyst.data.curves import write_with_curves

        write_with_curves(res, out)  # the per-sample model curves in OUT.curve.csv beside it (issue 26)
    return res


def read_selection(loop_path, loop_index) -> tuple:
    """(the Loop, or the list of Loops of a joint fit; the loop selection with 'all' spelled out), checked."""
    from mrhyst.data.io import loop_indices, read_loops

    if loop_index is None or isinstance(loop_index, (int, np.integer)):
        loop = read_loop(loop_path, loop_index)
    else:
        loops = read_loops(loop_path)
        idx = loop_indices(loops)
        if idx == [None]:
            raise InputError(f"{loop_path}: no loop_index column; a joint fit needs a file with several loops")
        if loop_index == "all":
            loop_index = idx
        missing = [i for i in loop_index if i not in idx]
        if missing:
            raise InputError(f"{loop_path}: no loop_index {missing[0]} (have {', '.join(map(str, idx))})")
        loop = [loops[idx.index(i)] for i in loop_index]
    for lp in (loop if isinstance(loop, list) else [loop]):
        check_fittable(lp)
    return loop, loop_index


def fit_loops(loop, method: str, loop_index, *, seed=0, n_over_le=None, group=None, setting=None,
              joint_weight=None, **kw) -> dict:
    """fit_file's fit of the Loop(s) ``loop`` read by :func:`read_selection` (kw: form, config, start, substeps,
    model); a joint fit with weight "own" first fits each loop alone (its RMS is the loop's scale)."""
    config = kw["config"]
    weight = joint_weight or resolve_config(config)["ja"]["joint_weight"]
    if isinstance(loop, list) and weight == "own":
        if method != "lsm":
            raise InputError(f"joint weight 'own' is a least-squares fit (--method lsm), got --method {method}")
        alone = [fit_loop(lp, "lsm", **kw) for lp in loop]  # each loop's own fit: the scale of its residual
        starts = [(f"own fit of loop {i}", list(a["params"].values())) for i, a in zip(loop_index, alone)]
        res = fit_joint_own(loop, starts, [a["rms_T"] for a in alone], **kw)
    else:
        res = fit_loop(loop, method, seed=seed, n_over_le=n_over_le, group=group, setting=setting,
                       joint_weight=joint_weight, **kw)
    if isinstance(loop_index, (int, np.integer)):
        res["loop_index"] = int(loop_index)
    return res


# --------------------------------------------------------------------------------------------
# synthetic loops (tests, bench)
# --------------------------------------------------------------------------------------------
def synthetic_loop(params, *, n_over_le: float = 3000.0, sigma_T: float = 0.0, seed: int = 0,
                   form: str = "paper", dman: str = "total", substeps: int = 2, current=None, path=None):
    """A loop in the loop format made from known parameters on the paper's 53-sample path
    (plus Gaussian noise sigma_T); returns a pandas DataFrame, written as CSV if ``path``."""
    import pandas as pd

    from mrhyst.data.io import branches, write_csv

    I = ja.paper_current_path() if current is None else np.asarray(current, dtype=float)
    p = ja.as_param_array(params) if hasattr(params, "keys") else np.asarray(params, dtype=float)
    B, ok = ja.simulate(p, I, n_over_le, form=form, dman=dman, substeps=substeps)
    if not ok:
        raise ValueError("the J-A integration failed for these parameters")
    rng = np.random.default_rng(seed)
    B = B + sigma_T * rng.standard_normal(B.size)
    df = pd.DataFrame({"step": np.arange(I.size), "current_A": I, "H_A_per_m": n_over_le * I, "B_T": B,
                       "branch": branches(I)})
    if path is not None:
        write_csv(df, path)
    return df

# The identification's building blocks, each in its own module of the fitting stack (mrhyst.fit): re-exported
# here because the workflow's scripts, the materials stage and the tests reach them as identify.NAME.
from mrhyst.fit.box import (  # noqa: E402,F401
    box_from_record,
    default_box,
    model_choices,
    model_names,
    paper_box,
    table_box,
)
from mrhyst.fit.problem import Problem, integration_error, problem_kw  # noqa: E402,F401
from mrhyst.fit.profile import profile, profile_file  # noqa: E402,F401
from mrhyst.fit.pso import _global_best_pso, _quiet_pyswarms  # noqa: E402,F401
from mrhyst.fit.settings import SECTIONS, START_STATES  # noqa: E402,F401
