"""One parameter set for several loops of one material (issue 17, point 1).

A :class:`JointProblem` holds one :class:`mrhyst.fit.identify.Problem` per loop. Each keeps its own path and
start state (cyclic steady state from its own first sample, fitted m0, ...); the model parameters are
shared. With ``start = "fit"`` every loop has its own initial magnetisation m0_i (coordinates after the
shared ones), since each loop has its own unknown history.

Objective: the loops' squared residuals summed, each loop's weighted by w_i:

    J_joint = sqrt( sum_i w_i^2 sum_(samples of i) (B_d - B_m)^2 / N ),   N = all valid samples.

``weight = "none"``: w_i = 1, the plain RMS over every sample (Eq. 15 over the union). ``"amplitude"``:
w_i = mean(A) / A_i with A_i the loop's peak |B|, so each loop counts by its error *relative to its own
peak* (an RMS in T would let the 1.5 T loop drown the 0.43 T one). ``"own"``: w_i = mean(s) / s_i with s_i
the loop's own RMS (T) when fitted alone (``loop_rms``), so J_joint^2 is, up to a constant, the sum over the
loops of (joint RMS / own RMS)^2 weighted by the sample counts: the objective of a goal stated as "every loop
within a factor of its own per-loop RMS" (a loop the model follows well alone counts more, since there a
small miss is a large factor). The fit JSON's ``rms_T`` is always the
plain RMS over all samples, whatever the weight; ``per_loop`` gives each loop's own.

It has the interface the optimisers and the accuracy check use (cost, residuals, model, nv, n_evals,
substeps, fail_cost_T, names), so run_lsm / run_pso / accuracy.accurate take it as they take a Problem.
"""

from __future__ import annotations

import numpy as np

WEIGHTS = ("none", "amplitude", "own")


class JointProblem:
    def __init__(self, probs: list, weight: str, m0_name: str = "m0", loop_rms=None):
        if not probs:
            raise ValueError("a joint problem needs at least one loop")
        if weight not in WEIGHTS:
            raise ValueError(f"joint weight must be one of {WEIGHTS}, got {weight!r}")
        if weight == "own":
            own = np.asarray(loop_rms if loop_rms is not None else [], dtype=float)
            if own.shape != (len(probs),) or not np.all(np.isfinite(own) & (own > 0)):
                raise ValueError(f"joint weight 'own' needs one positive RMS per loop ({len(probs)}), got {loop_rms!r}")
        starts = {p.start for p in probs}
        if len(starts) != 1:
            raise ValueError(f"every loop of a joint fit needs the same kind of start state, got {sorted(starts)}")
        self.probs = list(probs)
        self.start = probs[0].start
        self.npar = probs[0].npar
        self.par_names = probs[0].par_names
        self.fit_m0 = self.start == "fit"
        self.names = self.par_names + (tuple(f"{m0_name}_{i}" for i in range(len(probs))) if self.fit_m0 else ())
        self.fail_cost_T = probs[0].fail_cost_T
        self.weight = weight
        amp = np.array([float(np.max(np.abs(p.Bv))) for p in probs])  # each loop's peak |B|
        self.amplitudes = amp
        if weight == "none":
            self.w = np.ones(len(probs))
        elif weight == "amplitude":
            self.w = float(np.mean(amp)) / np.maximum(amp, 1e-300)
        else:
            self.w = float(np.mean(own)) / own
        self.loop_rms = None if weight != "own" else [float(v) for v in own]
        self.nvs = np.array([p.nv for p in probs])
        self.nv = int(self.nvs.sum())
        self.n_evals = 0
        # the union of the samples, for data estimates
        self.H = np.concatenate([p.H for p in probs])
        self.B = np.concatenate([p.B for p in probs])
        self.valid = np.concatenate([p.valid for p in probs])

    @property
    def substeps(self) -> int:
        return self.probs[0].substeps

    @substeps.setter
    def substeps(self, n: int) -> None:
        for p in self.probs:
            p.substeps = int(n)

    def sub_x(self, X, i: int) -> np.ndarray:
        """Loop i's own coordinates (shared parameters [+ its m0]) from joint coordinates X (n, D)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if not self.fit_m0:
            return X[:, : self.npar]
        return np.hstack([X[:, : self.npar], X[:, self.npar + i : self.npar + i + 1]])

    def join_x(self, shared, m0s=None) -> np.ndarray:
        """Joint coordinates from the shared parameters and (start fit) one m0 per loop."""
        x = list(np.asarray(shared, dtype=float)[: self.npar])
        if self.fit_m0:
            x += list(np.zeros(len(self.probs)) if m0s is None else m0s)
        return np.asarray(x)

    def cost(self, X) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        self.n_evals += X.shape[0]
        ss = np.zeros(X.shape[0])
        bad = np.zeros(X.shape[0], bool)
        for i, p in enumerate(self.probs):
            Ji = p.cost(self.sub_x(X, i))
            bad |= Ji >= self.fail_cost_T
            ss += self.w[i] ** 2 * p.nv * Ji**2
        J = np.sqrt(ss / self.nv)
        J[bad] = self.fail_cost_T
        return J

    def residuals(self, x) -> np.ndarray:
        self.n_evals += 1
        out = []
        for i, p in enumerate(self.probs):
            r = p.residuals(self.sub_x(x, i)[0])
            if np.all(r == p.fail_cost_T):
                return np.full(self.nv, self.fail_cost_T)
            out.append(self.w[i] * r)
        return np.concatenate(out)

    def residual_rows(self, X) -> np.ndarray:
        """:meth:`residuals` of every row of X (n, D), each loop's rows in one batched call (the same bytes
        as row by row: see :meth:`mrhyst.fit.problem.Problem.residual_rows`)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        self.n_evals += X.shape[0]
        out, bad = [], np.zeros(X.shape[0], bool)
        for i, p in enumerate(self.probs):
            R = p.residual_rows(self.sub_x(X, i))
            bad |= np.all(R == p.fail_cost_T, axis=1)
            out.append(self.w[i] * R)
        R = np.hstack(out)
        R[bad] = self.fail_cost_T
        return R

    def model(self, X, substeps: int | None = None):
        """Model B at every loop's samples, concatenated (n, sum m_i), and ok (n,)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        self.n_evals += X.shape[0]
        Bs, oks = [], np.ones(X.shape[0], bool)
        for i, p in enumerate(self.probs):
            B, ok = p.model(self.sub_x(X, i), substeps=substeps)
            Bs.append(B)
            oks &= ok
        return np.hstack(Bs), oks

    def per_loop(self, x) -> list[dict]:
        """Each loop's model B (list or None), plain RMS (T) and RMS relative to its peak |B|."""
        out = []
        for i, p in enumerate(self.probs):
            B, ok = p.model(self.sub_x(x, i))
            if not ok[0]:
                out.append({"B_model_T": None, "rms_T": float(self.fail_cost_T), "rms_rel": None})
                continue
            d = B[0][p.valid] - p.Bv
            rms = float(np.sqrt(np.mean(d**2)))
            out.append({"B_model_T": B[0], "rms_T": rms, "rms_rel": rms / self.amplitudes[i]})
        return out

    def rms_all(self, x) -> float:
        """Plain RMS (T) over every valid sample of every loop (Eq. 15 over the union)."""
        ss = 0.0
        for pl, n in zip(self.per_loop(x), self.nvs):
            ss += pl["rms_T"] ** 2 * n
        return float(np.sqrt(ss / self.nv))
