"""Build the ahead-of-time J-A module (:mod:`mrhyst.model.aot` says what it is for, where it lives, when it is built).

    python -m mrhyst.model.aot_build          # build it now for this source, machine and numba settings

numba's ``numba.pycc.CC`` compiles two plain functions that call the JIT dispatchers themselves
(``ja_jit.simulate_classic``: ``_simulate_batch`` with ``quad`` None; ``_lane_constants``:
``anh_jit.lane_constants_compiled``), so the module holds the kernels compiled with their own flags (fastmath
contract, error_model numpy) and the exported function is only a call. pycc compiles for a CPU model and that
model's default features; numba's JIT for the host's name and its detected features (both honour
``NUMBA_CPU_NAME``/``NUMBA_CPU_FEATURES``). To give the JIT's bytes (FMA contraction depends on the features), the
build sets the target CPU to numba's "host" name and, for the build only, hands pycc's code generator numba's own
host feature string (``AOTCPUCodegen._customize_tm_features``, restored after). The module is loaded and compared
with the JIT kernel on a fixed batch (both forms, two step counts, failing sets, a partial block) before it is
renamed into place (atomically: two builds at once leave one whole file). Needs a C compiler and setuptools
(pycc links its C helpers); ~5 s wall and CPU with numba's cache of the kernel warm, ~13 s with it cold.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from mrhyst.model import anh_jit, aot, ja_jit

SIG_BATCH = "void(f8[:,::1], b1[::1], f8[::1], f8[::1], i8, b1, f8[:,::1])"
SIG_LANES = "Tuple((f8[:,::1], b1[::1]))(i8, f8[:,::1], b1)"


def _lane_constants(kind, P, total):
    return anh_jit.lane_constants_compiled(kind, P, total)


@contextlib.contextmanager
def _host_features():
    """pycc's code generator with numba's JIT feature string for the host (pycc leaves it to the CPU model)."""
    from numba.core import codegen

    cls = codegen.AOTCPUCodegen
    old = cls.__dict__["_customize_tm_features"]
    cls._customize_tm_features = lambda self: self._get_host_cpu_features()
    try:
        yield
    finally:
        cls._customize_tm_features = old


def compile_to(folder: Path, filename: str) -> Path:
    """Compile the module into ``folder/filename``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pycc's pending-deprecation warning
        from numba.pycc import CC

    cc = CC(aot.NAME, source_module=ja_jit)
    cc.output_dir, cc.output_file, cc.target_cpu = str(folder), filename, "host"
    cc.export("simulate_classic", SIG_BATCH)(ja_jit.simulate_classic)
    cc.export("lane_constants", SIG_LANES)(_lane_constants)
    with _host_features(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cc.compile()
    return folder / filename


def _check_batch():
    """A fixed batch: 21 sets (a block and a partial one), a fifth of them failing or invalid, on a path with a
    minor loop."""
    rng = np.random.default_rng(26)
    n = 21
    P = np.column_stack([10 ** rng.uniform(5.0, 6.5, n), 10 ** rng.uniform(3.0, 4.5, n), rng.uniform(-3e-3, 3e-3, n),
                         rng.uniform(0.0, 0.99, n), 10 ** rng.uniform(3.0, 4.5, n)])
    P[::5, 2] = 0.5  # alpha large: the pole of Eq. 8
    P[3, 0] = np.nan
    H = np.concatenate([np.linspace(0.0, 4e4, 20), np.linspace(4e4, -1e4, 15)[1:], np.linspace(-1e4, 2e4, 9)[1:]])
    return np.ascontiguousarray(P), H, rng.uniform(-1e4, 1e4, n)


def same_bytes(built: aot.Kernels, ref: aot.Kernels) -> bool:
    """Whether ``built`` gives ``ref``'s bytes on the fixed batch (every kind, both forms, 1 and 3 steps)."""
    P, H, M0 = _check_batch()
    for kind in (0, 1, 2):
        for total in (True, False):
            Cm, valid = ref.lane_constants(kind, P, total)
            Cb, vb = built.lane_constants(kind, P, total)
            if Cm.tobytes() != Cb.tobytes() or valid.tobytes() != vb.tobytes():
                return False
            for physical in (True, False):
                for steps in (1, 3):
                    out = [np.empty((32, H.size)) for _ in range(2)]
                    ref.batch(Cm, valid, M0, H, steps, physical, out[0])
                    built.batch(Cm, valid, M0, H, steps, physical, out[1])
                    if out[0].tobytes() != out[1].tobytes():
                        return False
    return True


def build(target: Path) -> Path:
    """Compile, check against the JIT kernels, and rename into ``target``; raises on any failure."""
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".aot-build-", dir=target.parent))
    try:
        built = compile_to(tmp, target.name)
        if not same_bytes(aot.load(built), aot.jit()):
            raise RuntimeError("the compiled module does not give the JIT kernel's bytes")
        os.replace(built, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    for old in target.parent.glob(f"{aot.NAME}.*"):  # other keys' modules (an older source): each is ~0.7 MB
        if old != target and not old.name.endswith(".lock"):
            old.unlink(missing_ok=True)
    return target


def main(argv: list[str]) -> int:
    """``[--locked] [PATH]``: build (PATH: where; default aot.path()). ``--locked``: started by a fit, which took
    PATH.lock; a failure is written to PATH.failed."""
    locked = "--locked" in argv
    args = [a for a in argv if a != "--locked"]
    target = Path(args[0]) if args else aot.path()
    if target is None:
        print("mrhyst aot: this machine's CPU cannot be told (no /proc/cpuinfo): numba's JIT kernels run")
        return 1
    t0 = time.perf_counter()
    try:
        if locked and aot.path() != target:  # this process imported another source than the fit that started it
            raise RuntimeError(f"this source's module would be {aot.path()}, not {target}")
        build(target)
    except Exception as e:  # noqa: BLE001  any failure: the JIT kernels keep running; say why once
        reason = " ".join(f"{type(e).__name__}: {e}".split())[:500]
        if locked:
            with contextlib.suppress(OSError):
                Path(f"{target}.failed").write_text(reason + "\n")
        print(f"mrhyst aot: not built ({reason}); numba's JIT kernels run")
        return 1
    finally:
        if locked:
            Path(f"{target}.lock").unlink(missing_ok=True)
    print(f"mrhyst aot: {target} built in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
