"""Fill numba's cache before the study's first jobs run (rule ``warmup``; issue 23's build time).

Every compiled kernel is cached on disk (``cache=True``), but a fresh clone starts with an empty cache, and jobs
that start together each compile what they need at once: measured on a fresh build, the two key-draw jobs that
start the build each spent ~9 CPU s compiling the classic J-A kernel, and the two external fits that start
together each ~10 CPU s compiling the anisotropic variant's. Two warm-up jobs compile DISJOINT groups of kernels
side by side, one per core, and the jobs that would otherwise start by compiling wait for them:

* ``ja``: the classic J-A kernel (one set and a batch of sets, with and without a start magnetisation per set:
  one compiled signature, as the callers hand the kernels writable contiguous arrays only) with every registered
  effect (the eddy-lag kernel): what the blind key's draws and the rig need first;
* ``variants``: the anisotropic variant's quadrature kernel (the other variants of ja.MODELS run the classic
  kernel with their own lane constants), the batched Levenberg-Marquardt's kernels (with and without a mask),
  the Preisach candidate's hysteron sum and the flexible base's cell states: what the external fits and the
  diagnoses need.

A kernel is compiled for the argument types of its call, so each group calls the kernels through the same
public paths and with the same kinds of arrays as the jobs do; a kernel already in the cache is only loaded.
Nothing here changes a result: a job finds a kernel cached or compiles it as before.

* ``aot``: the ahead-of-time compiled classic J-A kernel a warm `mrhyst fit` runs without numba
  (mrhyst.model.aot; issue 26), for a user's own machine. Not a group of the workflow's rule: the study's jobs
  run for seconds to minutes and load numba anyway, and its ~5 s of wall and CPU (the C compiler included) would
  only lengthen the build (issue 23).

Measured (docs/lab.md, "The build's first jobs"): 13 compiled signatures (cache files) here when written, was 16 (a
read-only start state, a read-only lag and a strided index array were each a signature of their own; 27 .nbc files
for both groups in an empty cache at 9c0e386, kernels added since; tests/test_kernel_signatures.py checks that no
array flag adds one); the J-A
integration loop (``ja._block``) is most of each group (~5.7 s classic, ~7.2 s anisotropic, over half of it numba's
own inlining of the ``inline="always"`` helpers, which the loop needs to vectorise).
"""

from __future__ import annotations

import numpy as np

GROUPS = ("ja", "variants", "aot")  # the workflow's rule runs "ja" and "variants" only (wildcard_constraints)
_P = np.array([1.2e6, 3.0e4, 2.0e-3, 0.35, 1.5e4])  # a classic J-A set that integrates on the paths below


def _path():
    from mrhyst.model import ja
    from mrhyst.rig import sample_times

    current = ja.paper_current_path()
    return current, sample_times(current.size, 0.1)


def _ja() -> None:
    from mrhyst import rig
    from mrhyst.model import effects as fx
    from mrhyst.model import ja

    current, t = _path()
    k = rig.kernel()
    run = ja.prepared(current, 3.0e4, form=k["form"], substeps=k["substeps"])
    P = np.repeat(_P[None, :], 3, axis=0)
    for name, e in fx.REGISTRY.items():
        starts = [0.0, 0.0, 0.0]
        rig.observe(_P, current, t, 3.0e4, [(name, {e.param: starts[0]})])  # one set, a scalar value
        fx.apply(run, P.copy(), 0.0, t, {name: {e.param: np.asarray(starts)}}, fx.ordered([name]))  # a batch
    rig.observe(_P, current, t, 3.0e4, [])
    run(P, np.zeros(3))  # a start magnetisation per set


def _variants() -> None:
    from mrhyst.diagnose import everett, modelform
    from mrhyst.fit import lm
    from mrhyst.model import anhysteretic as anh
    from mrhyst.model import ja

    current, _ = _path()
    H = current * 3.0e4
    # the other variants run the classic kernel (their own lane constants): group "ja" compiles it
    spec = anh.MODELS["anisotropic"]
    lo = np.array([spec.bounds[n][0] for n in spec.names[5:]])
    hi = np.array([spec.bounds[n][1] for n in spec.names[5:]])
    P = np.append(_P, 0.5 * (lo + hi))[None, :].repeat(2, axis=0)
    ja.simulate_h(P, H, form="physical", substeps=2, model="anisotropic")
    ja.simulate_h(P, H, form="physical", substeps=2, model="anisotropic", M0=np.zeros(2))

    def fun(X, rows):
        return np.hstack([X - 1.0, X * X])

    for mask in (None, [True, False]):
        lm.least_squares_batch(fun, np.zeros((2, 2)), (-5.0, 5.0), mask, max_iter=3)
    modelform._hysteron_sum(np.ones((2, 3)), np.ascontiguousarray(np.ones((3, 4))))
    modelform.distinct_rows(np.ones((3, 2)))
    modelform._states(np.ones(3), -np.ones(3), np.zeros(3), np.linspace(-2.0, 2.0, 4))
    everett.cell_states(np.linspace(-2.0, 2.0, 4), np.linspace(-1.5, 1.5, 4), "demagnetised", 2)


def warm(group: str) -> dict:
    """Compile (or load) the kernels of ``group``; returns what the rule writes: the group and its kernels."""
    if group not in GROUPS:
        raise ValueError(f"warm-up group must be one of {GROUPS}, got {group!r}")
    if group == "aot":
        from mrhyst.model import aot, aot_build

        target = aot.path()
        if target is None:
            raise RuntimeError("the ahead-of-time J-A module needs /proc/cpuinfo to be keyed; the JIT kernels run")
        aot_build.build(target)
        return {"group": group, "kernels": _KERNELS[group], "module": str(target)}
    with np.errstate(all="ignore"):
        _ja() if group == "ja" else _variants()
    return {"group": group, "kernels": _KERNELS[group]}


_KERNELS = {"aot": ["mrhyst_ja_aot.simulate_classic", "mrhyst_ja_aot.lane_constants"],
            "ja": ["ja._simulate_batch", "ja._block", "anhysteretic.lane_constants_compiled", "effects._eddy_rows"],
            "variants": ["ja._simulate_batch (anisotropic)", "ja._aniso_sums", "lm._probes", "lm._columns",
                         "lm._damped", "lm._normal_compiled", "lm._normal_rows", "lm._gather_damped", "lm._probe",
                         "lm._curvature", "lm._trial", "lm._cost_rows", "lm._live", "lm._entries", "lm._accept",
                         "modelform._hysteron_sum", "modelform._distinct", "modelform._states",
                         "everett._cell_sums"]}
