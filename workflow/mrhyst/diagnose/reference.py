"""Reference mode (issue 24): a calibrated model held, and what changed since calibration.

``mrhyst diagnose RAW.csv --sensor hall1 --reference FIT.json`` (or a B(H) loop; or ``--reference
table1:group1_pso``). The reference's prediction on this sweep's own path is the simulation; the diagnosis asks
which ONE change, with the reference's material parameters held, explains the miss (:mod:`.refdiag`). This module
holds the reference (:class:`Reference`, :func:`load_reference`) and the fitting problem (:class:`RefProblem`): the
diagnosis's own :class:`mrhyst.diagnose.problem.Problem` (same coordinates, same forward model
:func:`mrhyst.model.effects.forward`, same batched LM), with the J-A coordinates *held at the reference* unless a
candidate frees them:

* a measurement or start effect of the registry (hall_offset, thermal_drift, eddy_lag, sensor_saturation,
  remanent_start) frees its own coordinate only;
* ``air_gap`` frees alpha: alpha' = (alpha - Nd) / (1 - Nd) (ARCHITECTURE 5), so Nd = (alpha - alpha') / (1 - alpha')
  relative to the reference's alpha;
* ``core_temperature`` frees ln Ms (the Ms ratio to the reference) and, as ``core_temperature_mak``, ln a and
  ln k too (taken where the data demand it: BIC); with temperature laws it frees the temperature (C) instead,
  every J-A parameter following the laws; where the data demand it (BIC), also c and k off their laws, as a
  nuisance: the temperature is read from the order-parameter laws (Ms, and a, alpha), while pinning k and
  reversibility c are what one loop does not pin down (the published Gd analysis's finding; measured on the Gd
  loop withheld at -10 C: T alone -10.9 C but 39.9 mT left against the laws' 21.4 mT floor; T, c, k: -10.2 C,
  16.0 mT; T, a, k: -6.0 C: a freed a takes the temperature's part);
* ``material_changed`` frees all five J-A coordinates: a refit from the reference.

With temperature laws the J-A coordinates are offsets from the laws at the temperature coordinate: a row at the
reference coordinates is the laws at its temperature exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mrhyst.data.io import InputError, json_number, read_json
from mrhyst.diagnose.problem import JA_NAMES, Problem
from mrhyst.model import ja

CORE = ("air_gap", "core_temperature", "material_changed")
MAK = "core_temperature_mak"  # the core_temperature candidate that also frees a and k
T_COL = "T_C"


@dataclass
class Reference:
    """A calibrated model: J-A parameters (or temperature laws), the form, where it came from."""

    source: str
    params: np.ndarray  # (Ms, a, alpha, c, k) at the reference temperature
    form: str
    calib_rms_T: float | None = None  # the reference's own RMS on its calibration data (None: unknown)
    laws: object = None  # mrhyst.materials.templaws.Laws, with coords
    coords: np.ndarray | None = None
    T_ref_C: float | None = None
    T_range_C: tuple | None = None
    start: str | None = None


def _params_of(d: dict, where: str) -> np.ndarray:
    if not isinstance(d, dict) or any(n not in d for n in JA_NAMES):
        raise InputError(f"{where}: expected parameters {', '.join(JA_NAMES)}")
    bad = next((n for n in JA_NAMES if not json_number(d[n])), None)
    if bad is not None:  # as `mrhyst simulate --params` refuses it: a number written as a string is a typo
        raise InputError(f"{where}: parameter {bad} must be a number, got {d[bad]!r}")
    p = np.array([float(d[n]) for n in JA_NAMES])
    if not (np.all(np.isfinite(p)) and p[0] > 0 and p[1] > 0 and p[4] > 0 and 0 <= p[3] < 1):
        raise InputError(f"{where}: parameters outside the physical range (Ms, a, k > 0; 0 <= c < 1)")
    return p


def table1_reference(name: str, paper: dict) -> Reference:
    """``table1:group1_pso``: a Table 1 set of the paper (config paper.table1), its Table 3 J after 50 iterations
    as its own RMS."""
    try:
        group, method = name.rsplit("_", 1)
        p = paper["table1"][group][method]
    except (ValueError, KeyError):
        sets = [f"{g}_{m}" for g, ms in paper.get("table1", {}).items() for m in ms]
        raise InputError(f"--reference table1:{name}: no such Table 1 set (have {', '.join(sets)})") from None
    j = ((paper.get("table3") or {}).get(group) or {}).get(method, {}).get("it50")
    return Reference(f"table1:{name}", _params_of(p, f"table1:{name}"), "physical",
                     None if j is None else float(j), start="demagnetised")


def fit_reference(path) -> Reference:
    """A FIT.json of ``mrhyst fit`` (params, form, start) or of ``mrhyst fit --temperature-laws``."""
    d = read_json(path)
    if not isinstance(d, dict):
        raise InputError(f"{path}: expected a fit JSON object")
    if d.get("model", "ja") != "ja":
        raise InputError(f"{path}: reference mode takes the classic J-A model (this fit is {d.get('model')!r})")
    if "form" not in d:  # a guess changed the verdict: a paper-form fit read as physical, none -> unexplained
        raise InputError(f"{path}: missing key 'form' (paper or physical: the J-A form the parameters were fitted "
                         f"with, as `mrhyst fit` writes it)")
    form = d["form"]
    if form not in ja.FORMS:
        raise InputError(f"{path}: form must be one of {', '.join(ja.FORMS)}, got {form!r}")
    if "temperature_laws" in d:
        from mrhyst.materials.templaws import Laws

        try:
            laws, x = Laws.from_json(d["temperature_laws"])
        except InputError as e:  # its one line, with the file it came from
            raise InputError(f"{path}: {e}") from None
        loops = d.get("per_loop")
        if not isinstance(loops, list) or not loops or not all(isinstance(e, dict) for e in loops):
            raise InputError(f"{path}: temperature laws without per_loop temperatures")
        temps = [_celsius(e.get("temperature_C"), f"{path}: per_loop temperature_C") for e in loops]
        t_ref = _celsius(d.get("reference_temperature_C", float(np.median(temps))), f"{path}: reference_temperature_C")
        rms = max(_rms_of(e.get("rms_T"), f"{path}: per_loop rms_T") for e in loops)
        try:  # laws that do not evaluate at their own reference temperature (edited by hand)
            p0 = _params_of(dict(zip(JA_NAMES, laws.params(x, t_ref)[0])), f"{path}: temperature_laws at {t_ref:g} C")
        except (ValueError, TypeError, KeyError, IndexError, ArithmeticError) as e:
            raise InputError(f"{path}: temperature_laws do not evaluate ({type(e).__name__}: {e})") from None
        return Reference(str(path), p0, form, rms, laws, x, t_ref, (min(temps), max(temps)), _start_of(d, path))
    if "params" not in d:
        raise InputError(f"{path}: no 'params' (a reference is what `mrhyst fit` wrote)")
    if "rms_T" not in d:  # the reference's own misfit is the floor a new sweep is judged against
        raise InputError(f"{path}: missing key 'rms_T' (the fit's own RMS misfit in tesla, as `mrhyst fit` writes "
                         f"it: a new sweep is judged against it)")
    return Reference(str(path), _params_of(d["params"], f"{path}: params"), form, _rms_of(d["rms_T"], f"{path}: rms_T"),
                     start=_start_of(d, path))


STARTS = ("auto", "cyclic", "fit", "first_sample", "demagnetised")  # what `mrhyst fit` writes (config pso.start)


def _start_of(d: dict, path) -> str | None:
    """The fit's start state (how its loop was simulated), one `mrhyst fit` writes: an unknown one was read as a
    cyclic start, which changed the verdict (none -> unexplained on the loop the fit came from)."""
    s = d.get("start")
    if s is not None and s not in STARTS:
        raise InputError(f"{path}: start must be one of {', '.join(STARTS)} (as `mrhyst fit` writes it), got {s!r}")
    return s


def _celsius(v, where: str) -> float:
    if not json_number(v) or not (-273.15 <= float(v) < 1e4):
        raise InputError(f"{where}: expected a temperature in degrees C (a number from -273.15 to 10000), got {v!r}")
    return float(v)


def _rms_of(v, where: str) -> float:
    """A reference's own RMS misfit (T): a number above 0 and below 10 T (no B loop misses by more)."""
    if not json_number(v) or not (0.0 < float(v) < 10.0):
        raise InputError(f"{where}: expected the fit's RMS misfit in tesla, a number above 0 and below 10, got {v!r}")
    return float(v)


def load_reference(spec: str, paper: dict | None = None) -> Reference:
    if spec.startswith("table1:"):
        if paper is None:
            from mrhyst.config import defaults

            paper = defaults().get("paper") or {}
        if not paper.get("table1"):
            import pathlib

            import yaml

            cfg = pathlib.Path("config.yaml")
            paper = yaml.safe_load(cfg.read_text()).get("paper", {}) if cfg.is_file() else {}
        if not paper.get("table1"):
            raise InputError(f"--reference {spec}: no paper.table1 in the config (give --config config.yaml)")
        return table1_reference(spec.split(":", 1)[1], paper)
    return fit_reference(spec)


def ref_coords(p) -> np.ndarray:
    return np.array([math.log(p[0]), math.log(p[1]), p[2], p[3], math.log(p[4])])


class RefProblem(Problem):
    """The sweep's problem with the reference held (see the module docstring)."""

    def __init__(self, sweep, cfg: dict, ref: Reference, t_box_K: float = 30.0):
        from mrhyst.diagnose.settings import resolve_config

        super().__init__(sweep, resolve_config(cfg).replace(form=ref.form))  # the reference's own J-A form
        self.ref = ref
        self.u_ref = ref_coords(ref.params)
        self.null[:5] = self.u_ref
        self.lo[:5] = np.minimum(self.lo[:5], self.u_ref - 1e-9)
        self.hi[:5] = np.maximum(self.hi[:5], self.u_ref + 1e-9)
        self.iT = None
        if ref.laws is not None:
            lo, hi = ref.T_range_C
            tc = float(ref.coords[1]) - 273.15  # the laws' Curie point (C)
            self.cols = self.cols + (T_COL,)
            self.iT = len(self.cols) - 1
            self.lo = np.append(self.lo, lo - t_box_K)
            self.hi = np.append(self.hi, min(hi + t_box_K, tc - 0.05))
            self.null = np.append(self.null, ref.T_ref_C)
            self.steps = np.append(self.steps, 1e-4)
        self.col.update({"core_temperature": 0 if self.iT is None else self.iT, MAK: 0, "material_changed": 0})

    def _make_spec(self, effects):
        act = np.zeros(len(self.cols), dtype=bool)
        lo, hi = self.lo.copy(), self.hi.copy()
        for e in effects:
            if e == "air_gap":  # alpha' below the reference's alpha (an opened gap) or above it
                act[2] = True
                lo[2] = self.u_ref[2] + float(self.cfg["alpha_eff_min"])
                hi[2] = self.u_ref[2] + 0.2
            elif e == "core_temperature":
                act[0 if self.iT is None else self.iT] = True
            elif e == MAK:  # Ms, a, k; with laws the temperature, c and k (see the module docstring)
                act[[0, 1, 4] if self.iT is None else [self.iT, 3, 4]] = True
            elif e == "material_changed":
                act[:5] = True
            elif e in self.col:
                act[self.col[e]] = True
            else:
                raise ValueError(f"unknown effect {e!r}")
        for j in np.flatnonzero(~act):
            lo[j] = hi[j] = self.null[j]
        for a in (act, lo, hi):
            a.setflags(write=False)
        return act, lo, hi

    def ja_sets(self, U) -> np.ndarray:
        U = np.atleast_2d(np.asarray(U, dtype=float))
        P = np.empty((U.shape[0], 5))
        P[:, 0], P[:, 1], P[:, 4] = np.exp(U[:, 0]), np.exp(U[:, 1]), np.exp(U[:, 4])
        P[:, 2:4] = U[:, 2:4]
        if self.iT is None:
            return P
        d = U[:, :5] - self.u_ref
        for i, t in enumerate(U[:, self.iT]):
            L = self.ref.laws.params(self.ref.coords, float(t))[0]
            P[i] = [L[0] * math.exp(d[i, 0]), L[1] * math.exp(d[i, 1]), L[2] + d[i, 2], L[3] + d[i, 3],
                    L[4] * math.exp(d[i, 4])]
        P[:, 3] = np.clip(P[:, 3], 0.0, 0.999)
        return P

    def ja_params(self, u) -> np.ndarray:
        return self.ja_sets(np.asarray(u, dtype=float)[None, :])[0]

    def nd(self, u) -> tuple[float, float]:
        """(Nd, dNd/d alpha-coordinate) of an air-gap fit: alpha' against the reference's alpha."""
        a0 = float(self.ja_sets(self.null[None, :])[0][2])
        a1 = a0 + float(u[2]) - float(self.u_ref[2])
        return (a0 - a1) / (1.0 - a1), -(1.0 - a0) / (1.0 - a1) ** 2

    def to_contract(self, e: str, u) -> float:
        if e == "air_gap":
            return self.nd(u)[0]
        return super().to_contract(e, u)

    def contract_slope(self, e: str, u) -> float:
        if e == "air_gap":
            return self.nd(u)[1]
        return super().contract_slope(e, u)
