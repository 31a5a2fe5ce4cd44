"""The fitting problem: model path, measured samples, start state, objective J of Eq. (15)."""

from __future__ import annotations

import hashlib
import math
import threading
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from mrhyst.data.io import InputError, Loop, read_json
from mrhyst.data.shape import path_shape
from mrhyst.fit import lockstep
from mrhyst.fit.box import Box, model_names
from mrhyst.fit.settings import JA_NAMES, M0_NAME, MU0, START_STATES, resolve_config
from mrhyst.model import ja


# --------------------------------------------------------------------------------------------
# the kernel rows a fitting process already integrated
# --------------------------------------------------------------------------------------------
class KernelMemo:
    """The B rows (and ok) of the J-A kernel already integrated, by all a lane's bytes depend on: the path, form,
    dman, variant, substep count, the set's parameters and M0. The kernel integrates each set in its own lane, so a
    row has the same bytes whatever batch it was in (ja_jit.py), and a call whose every row is here needs no
    integration: the answer is the one the kernel would give. A fit asks for many points twice (measured on
    M130-27s: 1218 of 10595 kernel calls, 5.0 of 24.5 kernel s): the step error at an LSM's solution, which the
    LSM integrated, and again in settle(); the final point again for per_loop and rms_all; a held-out fold's
    start, the full fit's optimum; a joint round's start, the round before's optimum.

    Only calls of at most one block of lanes (ja.LANES sets: an LSM step with its Jacobian's points, a step error,
    a final point) are looked up and kept: a swarm or a screen is seldom asked again. Least recently used rows go
    first beyond ``max_floats`` floats of B (64 MB: every row of the M130-27s file's held-out folds, ~6 KB each)."""

    def __init__(self, max_floats: int = 1 << 23):
        self.rows: OrderedDict = OrderedDict()
        self.max_floats = int(max_floats)
        self.floats = 0
        self.lock = threading.Lock()  # the threads of lockstep.run_all share it

    def simulate(self, prob, P, M0, substeps: int):
        """ja.simulate_h of ``prob``'s path for the sets P (n, p) from M0 (n,): (B (n, path), ok (n,)); in a thread
        of :func:`mrhyst.fit.lockstep.run_all`, integrated with the other threads' calls."""
        kw = {} if prob.variant == "ja" else {"model": prob.variant}

        def run(P, M0):
            return ja.simulate_h(P, prob.path, form=prob.form, substeps=substeps, dman=prob.dman, M0=M0, **kw)

        if P.ndim != 2 or P.shape[0] > ja.LANES:
            return run(P, M0)
        tag = (hashlib.blake2b(prob.path.tobytes(), digest_size=16).digest(), prob.form, prob.dman, prob.variant,
               int(substeps))
        M0s = np.array(np.broadcast_to(np.asarray(M0, dtype=np.float64), (P.shape[0],)))
        keys = [(tag, P[i].tobytes(), M0s[i].tobytes()) for i in range(P.shape[0])]
        with self.lock:
            got = [self.rows.get(k) for k in keys]
            if all(g is not None for g in got):
                for k in keys:
                    self.rows.move_to_end(k)
                return np.array([g[0] for g in got]), np.array([g[1] for g in got])
        B, ok = lockstep.integrate(tag, P, M0s, run)
        with self.lock:
            self._keep(keys, B, ok)
        return B, ok

    def _keep(self, keys, B, ok) -> None:
        for k, b, o in zip(keys, B, ok):
            if k not in self.rows:
                self.rows[k] = (b.copy(), bool(o))
                self.floats += b.size
        while self.floats > self.max_floats:
            self.floats -= self.rows.popitem(last=False)[1][0].size


MEMO = KernelMemo()


# --------------------------------------------------------------------------------------------
# the fitting problem: model path, measured samples, objective Eq. (15)
# --------------------------------------------------------------------------------------------
@dataclass
class Problem:
    """What is compared with what: the model path H, the measured B at the samples, the start. The settings
    (form ... variant) have no defaults here: :func:`problem_kw` gives them from the config (the schema's)."""

    H: np.ndarray  # field at the samples, A/m
    B: np.ndarray  # measured B at the samples, T
    valid: np.ndarray  # samples used in J (not saturated)
    form: str = field(kw_only=True)  # ja.form
    dman: str = field(kw_only=True)  # ja.dman
    substeps: int = field(kw_only=True)  # ja.substeps (the floor; mrhyst.fit.accuracy raises it)
    start: str = field(kw_only=True)  # pso.start
    cyclic_passes: int = field(kw_only=True)  # pso.cyclic_passes (external.cyclic_passes for external loops)
    fail_cost_T: float = field(kw_only=True)  # pso.fail_cost_T
    variant: str = field(kw_only=True)  # J-A model variant (ja.MODELS; "ja" = the classic five parameters); --model
    M0_fixed: float | None = None  # None: 0 (demagnetised), or the first sample's state (first_sample, cyclic)
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

    @property
    def shape(self):
        """The shape of the measured path H (:class:`mrhyst.data.shape.PathShape`, derived on first use, once);
        None when H never changes."""
        if "_shape" not in self.__dict__:
            try:
                self.__dict__["_shape"] = path_shape(self.H)
            except ValueError:
                self.__dict__["_shape"] = None
        return self.__dict__["_shape"]

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
        """ja.simulate_h along this problem's path (every pass); the variant only when it is not "ja". Rows the
        process integrated before come from :data:`MEMO` (the same bytes)."""
        return MEMO.simulate(self, np.asarray(P, dtype=np.float64), M0, int(substeps or self.substeps))

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

    def residual_rows(self, X) -> np.ndarray:
        """:meth:`residuals` of every row of X (n, D), in one batched ja call: row i gives the same bytes as
        ``residuals(X[i])`` (the kernel integrates each set in its own lane, whatever batch it sits in), so a
        finite-difference Jacobian's columns cost about one evaluation instead of one each."""
        P, M0 = self.split(X)
        Bs, ok = self.simulate(P, M0)
        self.n_evals += P.shape[0]
        R = Bs[:, self.idx] - self.Bv
        bad = ~ok | ~np.all(np.isfinite(R), axis=1)
        R[bad] = self.fail_cost_T
        return R


def problem_kw(cfg=None, *, kind: str = "loop", **given) -> dict:
    """:class:`Problem`'s settings: ``given`` (those not None) > ``cfg`` (FitSettings, a config mapping or path;
    None: the schema's defaults): form, dman, substeps, variant (config ja: form, dman, substeps, model), start
    (pso.start of the loop's ``kind``: loop or bh), cyclic_passes, fail_cost_T (pso)."""
    cfg = resolve_config(cfg)
    jc, pc = cfg["ja"], cfg["pso"]
    kw = {"form": jc["form"], "dman": jc["dman"], "substeps": int(jc["substeps"]), "variant": jc["model"],
          "start": pc["start"]["bh" if kind == "bh" else "loop"], "cyclic_passes": int(pc["cyclic_passes"]),
          "fail_cost_T": float(pc["fail_cost_T"])}
    kw.update({k: v for k, v in given.items() if v is not None})
    return kw


def problem_from_loop(loop: Loop, *, n_over_le=None, form=None, dman=None, substeps=None,
                      start=None, cfg=None, variant: str | None = None) -> tuple[Problem, dict]:
    """Build the Problem of a loop; returns (problem, info for the fit JSON). form, dman, substeps, start,
    variant: None = the config's (:func:`problem_kw`).

    H: for a loop file with ``n_over_le`` given, H = (N/Le) I (Eq. 12) with the inferred N/Le;
    without it, the loop's own H column; a third-party B(H) loop is fitted in H directly.
    """
    kw = problem_kw(cfg, kind=loop.kind, form=form, dman=dman, substeps=substeps, start=start, variant=variant)
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
        info["n_over_le"] = _coil_of(loop, H)
        info["h_source"] = ("H_A_per_m column (the sweep's coil_turns_per_m x current_A)" if info["n_over_le"]
                            else "H_A_per_m column")
    prob = Problem(H, loop.B_T, loop.valid, **kw)
    info["start"] = prob.start
    info["n_samples"] = int(H.size)
    info["n_valid"] = prob.nv
    if prob.start == "first_sample":
        info["M0_A_per_m"] = prob.M0_fixed
    return prob, info


def _coil_of(loop: Loop, H: np.ndarray) -> float | None:
    """N/Le of a loop file (mrhyst convert's: H = coil_turns_per_m x current_A), read back from its columns (the
    largest |current| sample); None for a third-party B(H) loop (its H is measured)."""
    if loop.kind != "loop" or loop.current_A is None:
        return None
    cur = np.asarray(loop.current_A, dtype=float)
    k = int(np.argmax(np.abs(cur)))
    return float(H[k] / cur[k]) if cur[k] != 0 else None


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
