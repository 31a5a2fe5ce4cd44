"""The search box of a fit: per-coordinate bounds and scale, the paper's +-100 % boxes, the J-A variants' boxes,
and the fit JSON's box record (ARCHITECTURE 4)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mrhyst.data.io import InputError
from mrhyst.fit.settings import JA_NAMES, M0_NAME, resolve_config
from mrhyst.model import ja


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


def table_box(centre, cfg=None) -> Box:
    """:func:`paper_box` around ``centre`` with config pso.box's half_width_rel, floor_rel, c_max (None: the
    schema's defaults)."""
    bc = resolve_config(cfg)["pso"]["box"]
    return paper_box(centre, float(bc["half_width_rel"]), float(bc["floor_rel"]), float(bc["c_max"]))


def paper_box(centre, half_width_rel: float, floor_rel: float, c_max: float) -> Box:
    """The paper's box: each parameter within +-half_width_rel of ``centre`` (Ms, a, alpha, c, k).

    +-100 % puts the lower end at 0; it is raised to ``floor_rel * centre`` (Ms, a, k > 0 strictly;
    alpha, c are kept off 0 the same way so that every coordinate is treated alike). The upper end
    of c is capped at ``c_max`` < 1 (physical limit 0 <= c < 1; c -> 1 makes Eq. 6 singular).
    """
    p = ja.as_param_array(centre) if isinstance(centre, Mapping) else np.asarray(centre, dtype=float)
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
        around = bcfg["around"]
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
    t = tuple(b[name]) if isinstance(b, Mapping) else tuple(b[i])
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
