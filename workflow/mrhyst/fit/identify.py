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

import atexit
import contextlib
import copy
import logging
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from mrhyst.config import load_config
from mrhyst.config import resolve as config_resolve
from mrhyst.data.io import InputError, Loop, check_fittable, read_json, read_loop, write_json
from mrhyst.fit import accuracy
from mrhyst.materials import loopfigures
from mrhyst.materials.joint import JointProblem
from mrhyst.model import ja
from mrhyst.paper import tables as metrics

MU0 = ja.MU0
JA_NAMES = ja.PARAM_NAMES  # ("Ms", "a", "alpha", "c", "k")
M0_NAME = "m0"  # fitted initial magnetisation M0 / Ms (start="fit")
METHODS = ("pso", "lsm")
START_STATES = ("demagnetised", "first_sample", "fit", "cyclic")
BH_STRATEGIES = ("nearest", "reflective")  # pyswarms' default "periodic" would wrap c ~ 1 to c ~ 0

SECTIONS = ("ja", "pso", "lsm", "identifiability", "metrics")  # the config sections identify reads


def resolve_config(config=None) -> dict:
    """The sections ja, pso, lsm, identifiability, metrics: their defaults (the config schema's, the one
    place they live: mrhyst.config.defaults) overridden by a config mapping or a config.yaml path (a path
    is checked: a bad file is one ConfigError line); with a config, also its ``paper`` section."""
    if isinstance(config, (str, Path)):
        config = load_config(config)
    out = config_resolve(config, SECTIONS)
    if config is not None:
        out["paper"] = copy.deepcopy(config.get("paper", {}))
    return out


# --------------------------------------------------------------------------------------------
# pyswarms, quietly
# --------------------------------------------------------------------------------------------
_LOG_CFG_PATH: str | None = None
# Incremental dictConfig: touches only the 'pyswarms' logger. A non-incremental config (pyswarms'
# default, or any config with a handlers section) would close every handler of the process
# (logging.config._clearExistingHandlers) each time pyswarms builds a Reporter (4 per optimizer).
_LOG_CFG_TEXT = (
    '{"version": 1, "incremental": true,'
    ' "loggers": {"pyswarms": {"level": "WARNING", "propagate": false}}}\n'
)


def _log_cfg_path() -> str:
    global _LOG_CFG_PATH
    if _LOG_CFG_PATH is None or not os.path.isfile(_LOG_CFG_PATH):
        fd, path = tempfile.mkstemp(prefix="mrhyst-pyswarms-log-", suffix=".yaml")
        with os.fdopen(fd, "w") as f:
            f.write(_LOG_CFG_TEXT)
        atexit.register(lambda p=path: os.path.exists(p) and os.unlink(p))
        _LOG_CFG_PATH = path
    return _LOG_CFG_PATH


@contextlib.contextmanager
def _quiet_pyswarms():
    """LOG_CFG -> our config while pyswarms is imported/constructed: no ./report.log, root untouched.

    pyswarms' Reporter reads LOG_CFG at import (module-level reporters) and at every optimizer
    construction; without it, it writes ./report.log and puts a StreamHandler on the root logger.
    Its messages go to a NullHandler on the 'pyswarms' logger (level WARNING, no propagation).
    """
    lg = logging.getLogger("pyswarms")
    if not any(isinstance(h, logging.NullHandler) for h in lg.handlers):
        lg.addHandler(logging.NullHandler())
    lg.propagate = False
    lg.setLevel(logging.WARNING)
    old = os.environ.get("LOG_CFG")
    os.environ["LOG_CFG"] = _log_cfg_path()
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("LOG_CFG", None)
        else:
            os.environ["LOG_CFG"] = old


def _global_best_pso():
    with _quiet_pyswarms():
        from pyswarms.single.global_best import GlobalBestPSO
    return GlobalBestPSO


# --------------------------------------------------------------------------------------------
# search box
# --------------------------------------------------------------------------------------------
@dataclass
class Box:
    """Search box in physical units with a per-coordinate scale ('linear' or 'log').

    ``centre`` is where LSM starts (for the paper's +-100 % box: the Table 1 value it was built
    around, not the midpoint once the c < 1 limit has clipped the upper end).
    """

    names: tuple
    lo: np.ndarray
    hi: np.ndarray
    scale: tuple
    centre: np.ndarray

    def __post_init__(self):
        self.lo = np.asarray(self.lo, dtype=float)
        self.hi = np.asarray(self.hi, dtype=float)
        self.centre = np.asarray(self.centre, dtype=float)
        self._log = np.array([s == "log" for s in self.scale])
        if not np.all(self.hi > self.lo):
            raise InputError(f"search box: every upper bound must exceed its lower bound ({self.as_dict()})")
        if np.any(self._log & (self.lo <= 0)):
            raise InputError("search box: a log-scaled coordinate needs a positive lower bound")
        self.centre = np.clip(self.centre, self.lo, self.hi)

    @property
    def dim(self) -> int:
        return len(self.names)

    def to_x(self, u):
        u = np.asarray(u, dtype=float)
        lin = self.lo + u * (self.hi - self.lo)
        if not self._log.any():
            return np.clip(lin, self.lo, self.hi)
        llo = np.log(np.where(self._log, self.lo, 1.0))
        lhi = np.log(np.where(self._log, self.hi, 1.0))
        lg = np.exp(llo + u * (lhi - llo))
        # exp(log(x)) may differ from x in the last bit: keep inside the box exactly
        return np.clip(np.where(self._log, lg, lin), self.lo, self.hi)

    def to_u(self, x):
        x = np.asarray(x, dtype=float)
        lin = (x - self.lo) / (self.hi - self.lo)
        if not self._log.any():
            return lin
        llo = np.log(np.where(self._log, self.lo, 1.0))
        lhi = np.log(np.where(self._log, self.hi, 1.0))
        with np.errstate(divide="ignore", invalid="ignore"):
            lg = (np.log(np.where(self._log, np.maximum(x, 1e-300), 1.0)) - llo) / (lhi - llo)
        return np.where(self._log, lg, lin)

    def as_dict(self) -> dict:
        return {
            "lo": {n: float(v) for n, v in zip(self.names, self.lo)},
            "hi": {n: float(v) for n, v in zip(self.names, self.hi)},
            "centre": {n: float(v) for n, v in zip(self.names, self.centre)},
            "scale": {n: s for n, s in zip(self.names, self.scale)},
        }

    def with_m0(self, m0_range=(-1.0, 1.0), m0_centre=0.0) -> Box:
        return Box(
            self.names + (M0_NAME,),
            np.append(self.lo, m0_range[0]),
            np.append(self.hi, m0_range[1]),
            tuple(self.scale) + ("linear",),
            np.append(self.centre, m0_centre),
        )


def paper_box(centre, half_width_rel: float = 1.0, floor_rel: float = 1e-3, c_max: float = 0.999) -> Box:
    """The paper's box: each parameter within +-half_width_rel of ``centre`` (Ms, a, alpha, c, k).

    +-100 % puts the lower end at 0; it is raised to ``floor_rel * centre`` (Ms, a, k > 0 strictly;
    alpha, c are kept off 0 the same way so that every coordinate is treated alike). The upper end
    of c is capped at ``c_max`` < 1 (physical limit 0 <= c < 1; c -> 1 makes Eq. 6 singular).
    """
    p = ja.as_param_array(centre) if isinstance(centre, dict) else np.asarray(centre, dtype=float)
    if np.any(p <= 0):
        raise InputError(f"box centre must be positive in every parameter, got {ja.as_param_dict(p)}")
    lo = np.maximum(p * (1.0 - half_width_rel), p * floor_rel)
    hi = p * (1.0 + half_width_rel)
    ic = JA_NAMES.index("c")
    hi[ic] = min(hi[ic], c_max)
    lo[ic] = min(lo[ic], 0.5 * hi[ic])
    return Box(JA_NAMES, lo, hi, ("linear",) * 5, p)


def box_from_spec(spec: dict) -> Box:
    """Box from a mapping with lo/hi/scale/centre dicts keyed by parameter name."""
    try:
        lo = [float(spec["lo"][n]) for n in JA_NAMES]
        hi = [float(spec["hi"][n]) for n in JA_NAMES]
    except KeyError as e:
        raise InputError(f"box spec lacks {e.args[0]!r}") from None
    scale = tuple(spec.get("scale", {}).get(n, "linear") for n in JA_NAMES)
    cen = spec.get("centre")
    if cen is None:
        lo_a, hi_a = np.array(lo), np.array(hi)
        cen = np.where(np.array(scale) == "log", np.sqrt(np.abs(lo_a * hi_a)), 0.5 * (lo_a + hi_a))
    else:
        cen = [float(cen[n]) for n in JA_NAMES]
    return Box(JA_NAMES, lo, hi, scale, cen)


def default_box(cfg=None) -> Box:
    """The box without a group (CLI on any loop); see config pso.default_box (schema defaults)."""
    cfg = resolve_config(cfg) if not (isinstance(cfg, dict) and "pso" in cfg and "ja" in cfg) else cfg
    return box_from_spec(cfg["pso"]["default_box"])


BOX_AROUND = ("pso", "lsm", "per_method")


def box_for(cfg: dict, group: str | None, method: str) -> tuple[Box, str]:
    """(box, where it comes from). With a group and ``pso.box.centre: table1``: the paper's +-100 %
    box around one Table 1 set of that group, chosen by ``pso.box.around``:

    * ``pso`` (default) or ``lsm``: the group's Table 1 set of that method, ONE box for both methods, so
      that PSO and LSM are compared inside the same search space (issue 14); LSM starts at its centre;
    * ``per_method``: the paper's literal reading, each method's box around its own Table 1 set (a stated
      variant: the methods then search different boxes, and a comparison between them is not like for like).

    Without a group (or another centre): the default box."""
    bcfg = cfg["pso"]["box"]
    if group is not None and bcfg.get("centre") == "table1":
        around = bcfg.get("around", "pso")
        if around not in BOX_AROUND:
            raise InputError(f"pso.box.around must be one of {', '.join(BOX_AROUND)}, got {around!r}")
        which = method if around == "per_method" else around
        t1 = (cfg.get("paper") or {}).get("table1") or {}
        if group not in t1:
            raise InputError(f"group {group!r} has no Table 1 entry in config paper.table1 (have {', '.join(t1)})")
        if which not in t1[group]:
            raise InputError(f"config paper.table1.{group} has no {which!r} set")
        box = paper_box(t1[group][which], bcfg["half_width_rel"], bcfg["floor_rel"], bcfg["c_max"])
        shared = "per method" if around == "per_method" else "shared by PSO and LSM"
        return box, f"paper.table1.{group}.{which} +-{100 * bcfg['half_width_rel']:g} % ({shared})"
    return default_box(cfg), "pso.default_box"


def box_record(box: Box) -> dict:
    """The fit JSON's box fields (ARCHITECTURE 4): ``box`` = {name: [lo, hi]}, plus its scale and centre."""
    return {"box": {n: [float(lo), float(hi)] for n, lo, hi in zip(box.names, box.lo, box.hi)},
            "box_scale": {n: s for n, s in zip(box.names, box.scale)},
            "box_centre": {n: float(v) for n, v in zip(box.names, box.centre)}}


def box_from_record(fit: dict, names) -> Box | None:
    """The Box a fit JSON searched (the contract's {name: [lo, hi]}, or the older lo/hi/centre/scale form)."""
    b = fit.get("box")
    if not b:
        return None
    if "lo" in b and "hi" in b:
        return Box(names, [b["lo"][n] for n in names], [b["hi"][n] for n in names],
                   tuple(b["scale"][n] for n in names), [b["centre"][n] for n in names])
    sc, ce = fit.get("box_scale") or {}, fit.get("box_centre") or {}
    return Box(names, [b[n][0] for n in names], [b[n][1] for n in names],
               tuple(sc.get(n, "linear") for n in names),
               [ce.get(n, 0.5 * (b[n][0] + b[n][1])) for n in names])


# --------------------------------------------------------------------------------------------
# J-A model variants (ja.MODELS: name -> names, bounds, citation); "ja" = the classic five parameters
# --------------------------------------------------------------------------------------------
def model_choices() -> tuple:
    """Names accepted by --model / config ja.model (only "ja" until ja.MODELS exists)."""
    return tuple(getattr(ja, "MODELS", None) or ("ja",))


def model_spec(variant: str):
    """ja.MODELS[variant], or None for "ja" in a build without ja.MODELS; InputError if unknown."""
    models = getattr(ja, "MODELS", None)
    if variant not in model_choices():
        raise InputError(f"model must be one of {', '.join(model_choices())}, got {variant!r}")
    return None if models is None else models[variant]


def model_names(variant: str = "ja") -> tuple:
    spec = model_spec(variant)
    return JA_NAMES if spec is None else tuple(spec.names)


def _spec_bound(spec, name: str, i: int):
    """(lo, hi, scale) of one parameter from spec.bounds: a mapping name -> (lo, hi[, scale]) or a
    sequence in the order of spec.names. Scale: as given, else log for a positive range over 2 decades."""
    b = spec.bounds
    t = tuple(b[name]) if isinstance(b, dict) else tuple(b[i])
    lo, hi = float(t[0]), float(t[1])
    scale = t[2] if len(t) > 2 else ("log" if lo > 0 and hi > 100 * lo else "linear")
    return lo, hi, scale


def variant_box(box: Box, variant: str) -> Box:
    """The classic box extended to a variant's parameters: the classic names keep ``box`` (config),
    the variant's own parameters take ja.MODELS[variant].bounds (centre: the middle, geometric if log)."""
    names = model_names(variant)
    if names == JA_NAMES:
        return box
    spec = model_spec(variant)
    lo, hi, scale, cen = [], [], [], []
    for i, n in enumerate(names):
        if n in box.names:
            j = box.names.index(n)
            lo.append(box.lo[j]), hi.append(box.hi[j]), scale.append(box.scale[j]), cen.append(box.centre[j])
        else:
            a, b, sc = _spec_bound(spec, n, i)
            lo.append(a), hi.append(b), scale.append(sc)
            cen.append(math.sqrt(a * b) if sc == "log" else 0.5 * (a + b))
    return Box(names, lo, hi, tuple(scale), cen)


# --------------------------------------------------------------------------------------------
# the fitting problem: model path, measured samples, objective Eq. (15)
# --------------------------------------------------------------------------------------------
@dataclass
class Problem:
    """What is compared with what: the model path H, the measured B at the samples, the start."""

    H: np.ndarray  # field at the samples, A/m
    B: np.ndarray  # measured B at the samples, T
    valid: np.ndarray  # samples used in J (not saturated)
    form: str = "paper"
    dman: str = "total"
    substeps: int = 2
    start: str = "demagnetised"
    cyclic_passes: int = 2
    fail_cost_T: float = 100.0
    M0_fixed: float | None = None  # None: 0 (demagnetised), or the first sample's state (first_sample, cyclic)
    variant: str = "ja"  # J-A model variant (ja.MODELS; "ja" = the classic five parameters); --model
    n_evals: int = field(default=0, repr=False)

    def __post_init__(self):
        self.H = np.ascontiguousarray(self.H, dtype=float)
        self.B = np.asarray(self.B, dtype=float)
        self.valid = np.asarray(self.valid, dtype=bool)
        if self.start not in START_STATES:
            raise InputError(f"start state must be one of {START_STATES}, got {self.start!r}")
        if self.valid.sum() < 6:
            raise InputError(f"only {int(self.valid.sum())} valid (unsaturated) samples; at least 6 are needed")
        m = self.H.size
        if self.start == "cyclic":
            # passes joined by a straight segment H[-1] -> H[0], split into steps no larger than the
            # largest step of the data (J-A is rate independent: extra points on a monotone segment
            # change only the integration accuracy, not the path)
            dmax = max(float(np.max(np.abs(np.diff(self.H)))), 1e-12) if m > 1 else 1.0
            gap = float(self.H[0] - self.H[-1])
            nseg = max(int(math.ceil(abs(gap) / dmax)), 1)
            bridge = self.H[-1] + gap * np.arange(1, nseg) / nseg
            one = np.concatenate([self.H, bridge])
            passes = max(int(self.cyclic_passes), 2)
            self.path = np.ascontiguousarray(np.concatenate([one] * (passes - 1) + [self.H]))
            self.sel = np.arange(self.path.size - m, self.path.size)
        else:
            self.path = self.H
            self.sel = np.arange(m)
        if self.M0_fixed is None:
            # cyclic: the first pass starts from the first sample's state (a tip of a closed loop), so that
            # cyclic_passes passes reach the steady state sooner than from M = 0
            first = self.start in ("first_sample", "cyclic")
            self.M0_fixed = float(self.B[0] / MU0 - self.H[0]) if first else 0.0
        self.idx = self.sel[self.valid]
        self.Bv = self.B[self.valid]
        self.nv = int(self.valid.sum())
        self.par_names = model_names(self.variant)
        self.npar = len(self.par_names)

    @property
    def names(self) -> tuple:
        return self.par_names + ((M0_NAME,) if self.start == "fit" else ())

    def split(self, X):
        """(model params (n, npar), M0 (n,)) from fitted coordinates X (n, D)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        P = X[:, : self.npar]
        if self.start == "fit":
            M0 = X[:, self.npar] * X[:, 0]
        else:
            M0 = np.full(X.shape[0], self.M0_fixed)
        return P, M0

    def simulate(self, P, M0, substeps: int | None = None):
        """ja.simulate_h along this problem's path (every pass); the variant only when it is not "ja"."""
        kw = {} if self.variant == "ja" else {"model": self.variant}
        return ja.simulate_h(P, self.path, form=self.form, substeps=int(substeps or self.substeps),
                             dman=self.dman, M0=M0, **kw)

    def model(self, X, substeps: int | None = None):
        """Model B at the samples, shape (n, m), and ok (n,)."""
        P, M0 = self.split(X)
        Bs, ok = self.simulate(P, M0, substeps)
        self.n_evals += P.shape[0]
        return Bs[:, self.sel], ok

    def cost(self, X) -> np.ndarray:
        """J of Eq. (15) for every row of X (one batched ja call); failed rows get fail_cost_T."""
        P, M0 = self.split(X)
        Bs, ok = self.simulate(P, M0)
        self.n_evals += P.shape[0]
        d = Bs[:, self.idx] - self.Bv
        with np.errstate(invalid="ignore", over="ignore"):
            J = np.sqrt(np.einsum("ij,ij->i", d, d) / self.nv)
        bad = ~ok | ~np.isfinite(J)
        J[bad] = self.fail_cost_T
        return J

    def residuals(self, x) -> np.ndarray:
        """B_d - B_m at the valid samples for one parameter vector; the constant fail_cost_T if it fails
        (so that J = sqrt(mean r^2) = fail_cost_T, as in :meth:`cost`)."""
        P, M0 = self.split(x)
        Bs, ok = self.simulate(P, M0)
        self.n_evals += 1
        r = Bs[0, self.idx] - self.Bv
        if not ok[0] or not np.all(np.isfinite(r)):
            return np.full(self.nv, self.fail_cost_T)
        return r


def problem_from_loop(loop: Loop, *, n_over_le=None, form="paper", dman="total", substeps=2,
                      start=None, cfg=None, variant: str = "ja") -> tuple[Problem, dict]:
    """Build the Problem of a loop; returns (problem, info for the fit JSON).

    H: for a loop file with ``n_over_le`` given, H = (N/Le) I (Eq. 12) with the inferred N/Le;
    without it, the loop's own H column; a third-party B(H) loop is fitted in H directly.
    """
    cfg = cfg or resolve_config(None)
    pc = cfg["pso"]
    info = {}
    if loop.kind == "loop" and n_over_le is not None:
        nle = float(n_over_le)
        if not (math.isfinite(nle) and nle > 0):
            raise InputError(f"N/Le must be a positive number, got {n_over_le!r}")
        H = nle * np.asarray(loop.current_A, dtype=float)
        info["n_over_le"] = nle
        info["h_source"] = "n_over_le * current_A (Eq. 12)"
    else:
        H = np.asarray(loop.H_A_per_m, dtype=float)
        info["n_over_le"] = None
        info["h_source"] = "H_A_per_m column"
    if start is None:
        start = pc["start"]["bh" if loop.kind == "bh" else "loop"]
    prob = Problem(H, loop.B_T, loop.valid, form=form, dman=dman, substeps=int(substeps), start=start,
                   cyclic_passes=int(pc.get("cyclic_passes", 3)), fail_cost_T=float(pc["fail_cost_T"]),
                   variant=variant)
    info["start"] = start
    info["n_samples"] = int(H.size)
    info["n_valid"] = prob.nv
    if start == "first_sample":
        info["M0_A_per_m"] = prob.M0_fixed
    return prob, info


def estimate_start(prob: Problem, box: Box) -> np.ndarray:
    """A data-informed start for a loop of unknown material (LSM on a third-party loop).

    Ms from the largest |B/mu0 - H|; a and k from the coercive field Hc (|H| where B changes sign;
    else 5 % of max |H|); c = 0.2; alpha = a/Ms (a third of the value 3a/Ms at which the
    anhysteretic susceptibility diverges); m0 from the first sample. Clipped into the box.
    """
    H, B = prob.H[prob.valid], prob.B[prob.valid]
    M = B / MU0 - H
    Ms = 1.1 * float(np.max(np.abs(M)))
    sc = np.where(np.diff(np.sign(B)) != 0)[0]
    if sc.size:
        Hc = float(np.median(np.abs(0.5 * (H[sc] + H[sc + 1]))))
    else:
        Hc = 0.05 * float(np.max(np.abs(H)))
    Hc = max(Hc, 1e-6 * max(float(np.max(np.abs(H))), 1.0))
    est = dict(zip(JA_NAMES, (Ms, Hc, Hc / Ms, 0.2, Hc)))
    # a variant's own parameters start at the box centre
    x = [est[n] if n in est else float(box.centre[i]) for i, n in enumerate(box.names) if n != M0_NAME]
    if prob.start == "fit":
        x.append(float(np.clip((prob.B[0] / MU0 - prob.H[0]) / Ms, -1.0, 1.0)))
    x = np.asarray(x)
    eps = 1e-9 * (box.hi - box.lo)
    return np.clip(x, box.lo + eps, box.hi - eps)


# --------------------------------------------------------------------------------------------
# PSO (Eq. 14)
# --------------------------------------------------------------------------------------------
def run_pso(prob: Problem, box: Box, *, seed: int = 0, n_particles: int = 100, iterations: int = 100,
            w: float = 1.0, c1: float = 2.0, c2: float = 2.0, v_max_frac: float = 0.02,
            bh_strategy: str = "reflective", oh_strategy: dict | None = None) -> dict:
    """GlobalBestPSO on the normalised box. Returns x (physical), J, history, n_evals.

    Seeding: pyswarms 1.3.0 has no seed argument; it draws the start positions and velocities in
    the constructor and r1, r2 of Eq. (14) every iteration from numpy's global RNG. We seed it right
    before construction and restore the caller's global RNG state afterwards.
    v_max (the paper's clamp after Eq. 14) = v_max_frac * box width, per coordinate.
    """
    if bh_strategy not in BH_STRATEGIES:
        raise InputError(f"bh_strategy must be one of {BH_STRATEGIES} (keeps particles physical), got {bh_strategy!r}")
    if not (0 < v_max_frac <= 1):
        raise InputError(f"v_max_frac must be in (0, 1], got {v_max_frac}")
    GlobalBestPSO = _global_best_pso()
    D = box.dim
    bounds = (np.zeros(D), np.ones(D))
    vmax = float(v_max_frac)
    n0 = prob.n_evals

    def objective(U):
        return prob.cost(box.to_x(U))

    state = np.random.get_state()
    try:
        np.random.seed(int(seed))
        with _quiet_pyswarms():
            opt = GlobalBestPSO(n_particles=int(n_particles), dimensions=D,
                                options={"c1": float(c1), "c2": float(c2), "w": float(w)},
                                bounds=bounds, bh_strategy=bh_strategy, velocity_clamp=(-vmax, vmax),
                                oh_strategy=dict(oh_strategy) if oh_strategy else None)
        best_cost, best_u = opt.optimize(objective, iters=int(iterations), verbose=False)
    finally:
        np.random.set_state(state)
    x = box.to_x(best_u)
    J = float(prob.cost(x[None, :])[0])
    hist = [float(v) for v in opt.cost_history]
    return {"x": x, "J": J, "history": hist, "best_cost": float(best_cost), "n_evals": prob.n_evals - n0}


# --------------------------------------------------------------------------------------------
# LSM
# --------------------------------------------------------------------------------------------
def run_lsm(prob: Problem, box: Box, x0=None, *, max_iterations: int = 100, method: str = "trf",
            ftol: float = 1e-12, xtol: float = 1e-12, gtol: float = 1e-12, diff_step=None,
            fixed: dict | None = None) -> dict:
    """scipy least_squares on the normalised box from x0 (default: the box centre).

    ``fixed`` = {coordinate index: physical value} holds coordinates fixed (profiles). Returns x,
    J, J_start, history (J after each TRF iteration), n_iterations, status, message, n_evals
    (every residual evaluation, finite-difference ones included), jac_u (Jacobian of the residuals
    in u at the solution, from scipy).
    """
    if method not in ("trf", "dogbox"):
        raise InputError("lsm method must be 'trf' or 'dogbox' (the ones with a per-iteration callback)")
    fixed = fixed or {}
    D = box.dim
    free = np.array([i for i in range(D) if i not in fixed], dtype=int)
    x0 = np.array(box.centre if x0 is None else x0, dtype=float)
    for i, v in fixed.items():
        x0[i] = v
    u0 = np.clip(box.to_u(x0), 0.0, 1.0)
    ufull = u0.copy()
    n0 = prob.n_evals

    def to_x(uf):
        ufull[free] = uf
        x = box.to_x(ufull)
        for i, v in fixed.items():
            x[i] = v
        return x

    def fun(uf):
        return prob.residuals(to_x(uf))

    r0 = fun(u0[free])
    J0 = float(np.sqrt(np.mean(r0**2)))
    hist: list[float] = []

    def callback(intermediate_result):
        hist.append(float(np.sqrt(2.0 * intermediate_result.cost / prob.nv)))
        if len(hist) >= max_iterations:
            raise StopIteration

    res = least_squares(fun, u0[free], bounds=(np.zeros(free.size), np.ones(free.size)), method=method,
                        ftol=ftol, xtol=xtol, gtol=gtol, diff_step=diff_step, max_nfev=50 * max_iterations * D,
                        callback=callback)
    x = to_x(res.x)
    J = float(np.sqrt(2.0 * res.cost / prob.nv))
    if not hist or hist[-1] != J:
        # the solver may stop inside an iteration (termination test on the trial step) before the
        # callback; the accepted point is res.x
        if not hist or J < hist[-1]:
            hist.append(J)
    return {"x": x, "J": J, "J_start": J0, "history": hist, "n_iterations": len(hist),
            "status": int(res.status), "message": str(res.message), "n_evals": prob.n_evals - n0,
            "jac_u": np.asarray(res.jac), "free": free}


def polish_pso(prob: Problem, box: Box, r: dict, lc: dict, out: dict) -> dict:
    """Local polish of a PSO result: least_squares (config lsm: method, tolerances, max_iterations)
    from the swarm's best point, in the same box. The polish's iterations are appended to the PSO
    history (so history[-1] is the returned J); ``out["polish"]`` records where the swarm stopped and
    what the polish added. The polished point is kept only if it is not worse."""
    p = run_lsm(prob, box, r["x"], max_iterations=int(lc["max_iterations"]), method=lc["method"],
                ftol=float(lc["ftol"]), xtol=float(lc["xtol"]), gtol=float(lc["gtol"]),
                diff_step=lc.get("diff_step"))
    better = p["J"] <= r["J"]
    hist = list(r["history"]) + [min(v, r["J"]) for v in p["history"]]
    out["polish"] = {"method": "least_squares " + lc["method"], "J_swarm_T": float(r["J"]),
                     "J_polished_T": float(p["J"]), "kept": bool(better), "n_pso_iterations": len(r["history"]),
                     "n_polish_iterations": len(p["history"]), "n_polish_evaluations": int(p["n_evals"])}
    return {"x": p["x"] if better else r["x"], "J": min(p["J"], r["J"]), "history": hist,
            "best_cost": r["best_cost"], "n_evals": r["n_evals"] + p["n_evals"]}


# --------------------------------------------------------------------------------------------
# one fit -> the fit JSON
# --------------------------------------------------------------------------------------------
def _read_n_over_le(n_over_le):
    if n_over_le is None or isinstance(n_over_le, (int, float, np.floating)):
        return n_over_le
    d = read_json(n_over_le)
    if not isinstance(d, dict) or "n_over_le" not in d:
        raise InputError(f"{n_over_le}: expected a JSON object with key 'n_over_le'")
    return float(d["n_over_le"])


def integration_error(prob: Problem, x, factor: int = 8) -> float:
    """max |B(substeps) - B(factor * substeps)| over the samples at x (T)."""
    B1, ok1 = prob.model(x[None, :])
    B2, ok2 = prob.model(x[None, :], substeps=factor * prob.substeps)
    if not (ok1[0] and ok2[0]):
        return float(prob.fail_cost_T)
    return float(np.max(np.abs(B1[0] - B2[0])))


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
    floors = [accuracy.noise_floor(p.H, p.B, p.valid) for p in subs]
    pos = [f for f in floors if f > 0]
    noise = min(pos) if pos else 0.0
    return noise, accuracy.tolerance(noise, float(jc["integration_tol_frac"]), float(jc["integration_tol_T"]))


def _search(prob, box: Box, method: str, cfg: dict, *, seed, setting, pso_overrides, tol: float,
            starts=None) -> tuple:
    """Run PSO or LSM with the substep count settled by accuracy.accurate; (result, extras for the JSON).
    LSM starts at the box centre and at each of ``starts`` [(name, x)]; the lowest J wins."""
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
    for name, x0 in [("box centre", box.centre)] + list(starts or []):
        x0 = np.clip(np.asarray(x0, dtype=float), box.lo, box.hi)
        if name != "box centre" and prob.cost(x0[None, :])[0] >= prob.fail_cost_T:
            # a coarse step may overshoot into the pole of Eq. 8 where a finer one does not: allow a finer count
            # (at most 4x, so that one start next to the pole does not set the count of the whole fit)
            n_before = prob.substeps
            accuracy.settle(prob, x0, tol, min(n_max, 4 * n_before))
            if prob.cost(x0[None, :])[0] >= prob.fail_cost_T:
                # e.g. one loop's own fit hits the pole on another loop: LSM would sit on the flat fail cost
                prob.substeps = n_before  # a start not taken does not set the count
                tried.append({"start": name, "J_T": None})
                continue
        r, acc = accuracy.accurate(lambda xs: run_lsm(prob, box, xs, **lkw), prob, x0, tol, n_max)
        tried.append({"start": name, "J_T": r["J"]})
        if best is None or r["J"] < best[0]["J"]:
            best = (r, acc, name, x0)
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
        e["loop_figures"] = loopfigures.side_by_side(p.H, p.B, e["B_model_T"], p.valid)
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


def fit_loop(loop, method: str, *, form=None, seed: int = 0, n_over_le=None, config=None,
             group: str | None = None, setting: str | None = None, start: str | None = None,
             substeps: int | None = None, pso_overrides: dict | None = None, model: str | None = None,
             starts: list | None = None) -> dict:
    """Fit one loop, or one parameter set to several (a list of Loops: a joint fit, each loop with its own
    start state, objective summed over the loops, see mrhyst.materials.joint); returns the fit JSON as a dict.
    starts: extra LSM starts [(name, model parameters)]; a joint LSM fit without them starts from each
    loop's own fit."""
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
    subs, infos = _problems(loops, n_over_le=_read_n_over_le(n_over_le), form=form, dman=jc["dman"],
                            substeps=floor, start=start, cfg=cfg, variant=variant)
    prob = JointProblem(subs, weight=jc["joint_weight"], m0_name=M0_NAME) if joint else subs[0]
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
                       starts=starts)
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
    out["model_ok"] = ok
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
        warn.append("the J-A integration fails at the returned parameters (J = fail_cost_T)")
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


def fit_file(loop_path, method: str, form: str | None = None, seed: int = 0, out=None, n_over_le=None,
             config=None, group: str | None = None, setting: str | None = None, start: str | None = None,
             substeps: int | None = None, loop_index=None, model: str | None = None) -> dict:
    """`mrhyst fit LOOP.csv --method pso|lsm [--form paper|physical] [--seed N] [--loop-index N|all|0,2]
    [--model NAME] --out FIT.json`.

    loop_path: a loop file (step,current_A,H_A_per_m,B_T,branch[,saturated]) or a third-party B(H)
    loop (H_A_per_m,B_T or H,B). method: 'pso' or 'lsm'. form: None = config ja.form, or 'physical'
    without a config. n_over_le: turns per metre (number, or the path of results/sim/n_over_le.json);
    used for a loop file (H = N/Le I, Eq. 12); None = the loop's H column. config: None (the schema defaults),
    a mapping, or a config.yaml path. group: with a config, selects the paper's +-100 % box around
    that group's Table 1 value of ``method``; None = the default box. setting: PSO setting name in
    config pso.settings ('paper' default, 'clerc'). start: how the path starts
    ('demagnetised' | 'first_sample' | 'fit' | 'cyclic'; None = config pso.start by loop kind).
    substeps: the floor of the RK4 steps per sample interval (None = config ja.substeps); the count
    used is raised until the step error is within tolerance (mrhyst.fit.accuracy). loop_index: None (a
    file with one loop), one index, or a list of indices / 'all' (one parameter set for those loops).
    model: J-A variant (None = config ja.model).

    Returns the fit dict: {"params": {...}, "rms_T": J (Eq. 15), "history": [J after each
    iteration], "per_loop": [...], ...extras}; writes it (deterministic JSON) to ``out`` if given.
    Same seed -> same bytes.
    """
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
    res = fit_loop(loop, method, form=form, seed=seed, n_over_le=n_over_le, config=config, group=group,
                   setting=setting, start=start, substeps=substeps, model=model)
    if isinstance(loop_index, (int, np.integer)):
        res["loop_index"] = int(loop_index)
    if out is not None:
        write_json(res, out)
    return res


# --------------------------------------------------------------------------------------------
# identifiability: profile of J along each parameter + curvature-based standard errors
# --------------------------------------------------------------------------------------------
def _profile_grid(box: Box, i: int, xi: float, n_grid: int, refine_rel) -> np.ndarray:
    u = np.linspace(0.0, 1.0, int(n_grid))
    g = list(box.to_x(np.outer(u, np.ones(box.dim)))[:, i])
    for r in refine_rel:
        for s in (-1.0, 1.0):
            g.append(xi * (1.0 + s * r))
    g.append(xi)
    g = np.array(g)
    g = g[(g >= box.lo[i]) & (g <= box.hi[i])]
    return np.unique(g)


def _crossing(xs, Js, i_min, level):
    """Interpolated x where the profile first rises above ``level`` going left/right from i_min;
    None if it stays below to the end of the grid (the box edge)."""
    out = []
    for step in (-1, 1):
        j = i_min
        found = None
        while 0 <= j + step < len(xs):
            if Js[j + step] > level:
                x0, x1, J0, J1 = xs[j], xs[j + step], Js[j], Js[j + step]
                found = float(x0 + (level - J0) / (J1 - J0) * (x1 - x0)) if J1 != J0 else float(x1)
                break
            j += step
        out.append(found)
    return out


def profile(prob: Problem, box: Box, x_opt, *, threshold: float = 1.1, n_grid: int = 21,
            refine_rel=(0.01, 0.02, 0.05, 0.1, 0.2, 0.5), max_iterations: int = 60, polish: bool = True) -> dict:
    """Profile J along each J-A parameter: fix it at a grid of values, re-minimise the others with
    least_squares (continuation from the optimum outwards), and report the range where
    J <= threshold * J_min, plus the linearised relative standard error sqrt(diag(s^2 (J^T J)^-1)) / x
    with s^2 = RSS / (N - D), from the Jacobian at the (polished) optimum.
    """
    x_opt = np.asarray(x_opt, dtype=float)
    if polish:
        pr = run_lsm(prob, box, x_opt, max_iterations=200)
        x_star, J_star = (pr["x"], pr["J"]) if pr["J"] <= float(prob.cost(x_opt[None])[0]) else (x_opt, None)
    else:
        x_star = x_opt
    J_star = float(prob.cost(x_star[None])[0])
    # curvature: Jacobian in physical units by central differences in log x (relative steps)
    D = box.dim
    r0 = prob.residuals(x_star)
    Jac = np.empty((r0.size, D))
    for i in range(D):
        h = 1e-5 * max(abs(x_star[i]), 1e-12)
        xp, xm = x_star.copy(), x_star.copy()
        xp[i] += h
        xm[i] -= h
        Jac[:, i] = (prob.residuals(xp) - prob.residuals(xm)) / (2 * h) * max(abs(x_star[i]), 1e-12)
    dof = max(r0.size - D, 1)
    s2 = float(r0 @ r0) / dof
    with np.errstate(all="ignore"):
        try:
            cov_rel = s2 * np.linalg.pinv(Jac.T @ Jac)
            rse = np.sqrt(np.clip(np.diag(cov_rel), 0.0, None))
        except np.linalg.LinAlgError:
            rse = np.full(D, np.inf)
        corr = cov_rel / np.sqrt(np.outer(np.diag(cov_rel), np.diag(cov_rel)))
    sv = np.linalg.svd(Jac, compute_uv=False)
    level = threshold * J_star
    params = {}
    for i, name in enumerate(JA_NAMES):
        grid = _profile_grid(box, i, x_star[i], n_grid, refine_rel)
        Js = np.full(grid.size, np.nan)
        xs_at = [None] * grid.size
        k0 = int(np.argmin(np.abs(grid - x_star[i])))
        for direction in (range(k0, grid.size), range(k0 - 1, -1, -1)):
            xs = x_star.copy()
            for k in direction:
                r = run_lsm(prob, box, xs, max_iterations=max_iterations, fixed={i: float(grid[k])})
                Js[k] = r["J"]
                xs_at[k] = r["x"]
                xs = r["x"]
        im = int(np.nanargmin(Js))
        lo, hi = _crossing(grid, Js, im, level)
        params[name] = {
            "grid": [float(v) for v in grid],
            "J_T": [float(v) for v in Js],
            "others": [[float(v) for v in xx] for xx in xs_at],
            "J_min_T": float(Js[im]),
            "x_at_min": float(grid[im]),
            "range_lo": lo,
            "range_hi": hi,
            "range_open_lo": lo is None,
            "range_open_hi": hi is None,
            "rel_width": (None if lo is None or hi is None else float((hi - lo) / abs(x_star[i]))),
            "rel_se_curvature": float(rse[i]) if np.isfinite(rse[i]) else None,
        }
    return {
        "x_opt": {n: float(v) for n, v in zip(box.names, x_star)},
        "J_opt_T": J_star,
        "threshold": float(threshold),
        "level_T": level,
        "singular_values_rel": [float(v) for v in sv],
        "condition_rel": float(sv[0] / sv[-1]) if sv[-1] > 0 else None,
        "correlation": [[float(v) if np.isfinite(v) else None for v in row] for row in corr],
        "box": box.as_dict(),
        "params": params,
    }


def profile_file(loop_path, fit_path, out=None, n_over_le=None, config=None, group=None) -> dict:
    """Identifiability profile of a fit JSON on its loop (same form/box/start as the fit)."""
    cfg = resolve_config(config)
    fit = read_json(fit_path)
    loop = read_loop(loop_path)
    jc = cfg["ja"]
    prob, _ = problem_from_loop(loop, n_over_le=_read_n_over_le(n_over_le), form=fit.get("form", jc["form"]),
                                dman=fit.get("dman", jc["dman"]), substeps=int(fit.get("substeps", jc["substeps"])),
                                start=fit.get("start"), cfg=cfg)
    box = box_from_record(fit, JA_NAMES + ((M0_NAME,) if prob.start == "fit" else ()))
    if box is None:
        box, _ = box_for(cfg, group or fit.get("group"), fit.get("method", "pso"))
        if prob.start == "fit":
            box = box.with_m0(tuple(cfg["pso"]["m0_range"]))
    x = ja.as_param_array(fit["params"])
    if prob.start == "fit":
        x = np.append(x, fit.get("m0", 0.0))
    ic = cfg["identifiability"]
    res = profile(prob, box, x, threshold=float(ic["threshold"]), n_grid=int(ic["n_grid"]),
                  refine_rel=tuple(ic["refine_rel"]), max_iterations=int(ic["max_iterations"]))
    res.update({"group": fit.get("group"), "method": fit.get("method"), "setting": fit.get("setting"),
                "seed": fit.get("seed"), "fit_rms_T": fit.get("rms_T"), "form": prob.form})
    if out is not None:
        write_json(res, out)
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
    p = ja.as_param_array(params) if isinstance(params, dict) else np.asarray(params, dtype=float)
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
