"""The classic J-A kernel without numba: an ahead-of-time compiled module of the JIT kernel (issue 26's warm fit).

A warm `mrhyst fit --method lsm` spent ~0.31 s of its 0.66-0.69 s loading numba, its lowering registries and the
kernel from numba's cache (0.157 + 0.105 + 0.048 s CPU on main 9760182; bench/bench_startup.py, bench/README.md),
more than the whole budget left after numpy and scipy.optimize. numba's ahead-of-time compiler (``numba.pycc``,
:mod:`mrhyst.model.aot_build`) turns the same source into a plain Python extension that imports without numba.
:func:`kernels` is the ONE place the model's public API (``ja.simulate_h``, ``ja.prepared``) takes its two kernels
for the variants without quadrature from:

* ``batch(Cm, valid, M0, H, substeps, physical, out)``: ``ja_jit._simulate_batch`` with ``quad`` None;
* ``lane_constants(kind, P, total)``: ``anh_jit.lane_constants_compiled``

(the module's functions check no argument types, as pycc's exports never do: ``ja`` hands them only the arrays it
has just made, float64 or bool, C-contiguous, of the exported signatures);

from the ahead-of-time module when it is built for this source and this machine, else the JIT kernels (numba,
imported then). Both give the same bytes: the module is compiled from the JIT kernels themselves, for numba's
own host CPU name and features (the kernels contract to FMA), and a build is checked against the JIT kernel
before it is put in place (tests/test_aot.py compares them on random sets). Everything else (the anisotropic
variant, the effects, the LM, the diagnoses) runs numba's JIT kernels as before.

Where, and when it is stale: ``<folder>/mrhyst_ja_aot.<key><ext>``, the folder numba caches ja's kernels in
(``NUMBA_CACHE_DIR``/mrhyst_aot if set, else model/__pycache__). The key hashes the kernel sources (this folder's
ja, ja_jit, anhysteretic, anh_jit, aot_build), the numba, llvmlite, numpy and Python versions, the CPU
(/proc/cpuinfo's identity and flags: llvmlite's own host query costs ~0.05 s of start-up) and every ``NUMBA_*``
setting that can change machine code (all but RUNTIME_ONLY: the cache folder, threads, messages); a file of
another key is never read (a build deletes them). Without /proc/cpuinfo (not Linux) the CPU cannot be told
cheaply and the JIT kernels run, as before.

When it is built: by ``python -m mrhyst.model.aot_build`` (or ``mrhyst.warmup.warm("aot")``; not by the
workflow's warm-up rule, whose jobs are long), and after the first `mrhyst fit` of a console-script process
that ran the JIT kernels, in a detached process once the fit's output is written (~5 s wall and CPU, C compiler
included, with numba's cache of the kernel warm, ~13 s cold; the fit does not wait). A failed build leaves
``<file>.failed`` (its one-line reason; no build is tried again while it is there) and the JIT kernels run.
``MRHYST_AOT=0`` turns it off: never loaded, never built.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import logging
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

NAME = "mrhyst_ja_aot"  # the extension's module name (its PyInit_ symbol)
ENV = "MRHYST_AOT"  # "0": never load or build the ahead-of-time module
SOURCES = ("ja.py", "ja_jit.py", "anhysteretic.py", "anh_jit.py", "aot_build.py")  # what the key hashes
# numba settings that change no machine code (where things go, threads at run time, messages): not in the key, so
# that e.g. NUMBA_NUM_THREADS=1 in one shell and not in another is one module; every other NUMBA_* setting is
RUNTIME_ONLY = frozenset(f"NUMBA_{k}" for k in (
    "CACHE_DIR", "NUM_THREADS", "THREADING_LAYER", "THREADING_LAYER_PRIORITY", "DEBUG_CACHE", "WARNINGS",
    "DISABLE_PERFORMANCE_WARNINGS", "COLOR_SCHEME", "HIGHLIGHT_DUMPS", "FULL_TRACEBACKS", "DEVELOPER_MODE",
    "CAPTURED_ERRORS", "DISABLE_ERROR_MESSAGE_HIGHLIGHTING", "SHOW_HELP"))
LOCK_AGE = 600.0  # seconds after which a build's lock counts as left by a killed build
_HERE = Path(__file__).resolve().parent
log = logging.getLogger("mrhyst.aot")


class Kernels(NamedTuple):
    batch: Callable  # (Cm, valid, M0, H, substeps, physical, out) -> None
    lane_constants: Callable  # (kind, P, total) -> (Cm, valid)
    origin: str  # "aot" or "jit"


_KERNELS: Kernels | None = None


def kernels() -> Kernels:
    """The kernels of this process (chosen at the first call): the ahead-of-time module's, else numba's JIT."""
    global _KERNELS
    if _KERNELS is None:
        _KERNELS = _load() or jit()
    return _KERNELS


def jit() -> Kernels:
    """numba's JIT kernels (numba imported here)."""
    from mrhyst.model import anh_jit, ja_jit

    return Kernels(ja_jit.simulate_classic, anh_jit.lane_constants_compiled, "jit")


def enabled() -> bool:
    return os.environ.get(ENV, "1").strip() != "0"


def folder() -> Path:
    """Where numba caches ja's kernels: NUMBA_CACHE_DIR (here its subfolder mrhyst_aot), else the package's."""
    root = os.environ.get("NUMBA_CACHE_DIR")
    return Path(root) / "mrhyst_aot" if root else _HERE / "__pycache__"


def _cpu() -> bytes | None:
    """The first CPU's identity and feature flags from /proc/cpuinfo (None where there is none)."""
    try:
        text = Path("/proc/cpuinfo").read_bytes().split(b"\n\n")[0]
    except OSError:
        return None
    keep = (b"vendor_id", b"cpu family", b"model", b"model name", b"stepping", b"flags", b"Features", b"CPU ")
    lines = [ln for ln in text.splitlines() if ln.startswith(keep) and not ln.startswith(b"cpu MHz")]
    return b"\n".join(lines) if lines else None


def _version_file(package: str) -> bytes:
    """The bytes of ``package``'s _version.py (its version), found without importing the package."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError(package)
    return (Path(list(spec.submodule_search_locations)[0]) / "_version.py").read_bytes()


def key() -> str | None:
    """The hash naming the module built for this source, these versions, this CPU and these numba settings; None
    where the CPU cannot be told (no /proc/cpuinfo) or a version cannot be read."""
    import numpy

    cpu = _cpu()
    if cpu is None:
        return None
    h = hashlib.sha256()
    try:
        for name in SOURCES:
            h.update((_HERE / name).read_bytes())
        for package in ("numba", "llvmlite"):
            h.update(_version_file(package))
    except (OSError, ImportError, ValueError):
        return None
    numba_env = sorted((k, v) for k, v in os.environ.items() if k.startswith("NUMBA_") and k not in RUNTIME_ONLY)
    for part in (numpy.__version__, sys.version, sys.platform, repr(numba_env)):
        h.update(part.encode())
    h.update(cpu)
    return h.hexdigest()[:20]


def path() -> Path | None:
    """The module's file for this process (None: no key, the JIT kernels run)."""
    k = key()
    return None if k is None else folder() / f"{NAME}.{k}{importlib.machinery.EXTENSION_SUFFIXES[0]}"


def load(p: Path) -> Kernels:
    """The kernels of the module at ``p`` (raises ImportError/OSError if it is not one)."""
    spec = importlib.util.spec_from_file_location(NAME, p)
    if spec is None or spec.loader is None:
        raise ImportError(f"{p}: not an extension module")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return Kernels(mod.simulate_classic, mod.lane_constants, "aot")


def _load() -> Kernels | None:
    if not enabled():
        return None
    try:
        p = path()
        if p is None or not p.is_file():
            return None
        return load(p)
    except Exception as e:  # noqa: BLE001  a corrupt or foreign file: the JIT kernels run, a rebuild replaces it
        log.debug("ahead-of-time J-A module not used (%s); numba's JIT kernels run", e)
        return None


def build_in_background() -> bool:
    """After a console-script `mrhyst fit` that ran the JIT kernels: start a detached build of the module (unless
    it is off, cannot be keyed, failed before, or another build is under way). True if one was started."""
    if _KERNELS is None or _KERNELS.origin == "aot" or not enabled():
        return False
    try:
        p = path()
        if p is None or Path(f"{p}.failed").exists():
            return False
        p.parent.mkdir(parents=True, exist_ok=True)
        if not _lock(Path(f"{p}.lock")):
            return False
        subprocess.Popen([sys.executable, "-m", "mrhyst.model.aot_build", "--locked", str(p)],
                         stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True, close_fds=True)
        return True
    except (OSError, ValueError) as e:  # a read-only folder, no interpreter to start: the JIT kernels run
        log.debug("ahead-of-time J-A module not built (%s)", e)
        return False


def _lock(lock: Path) -> bool:
    """Take the build's lock file (True), unless a build younger than LOCK_AGE holds it."""
    try:
        if time.time() - lock.stat().st_mtime > LOCK_AGE:
            lock.unlink(missing_ok=True)  # left by a killed build
    except OSError:
        pass
    try:
        os.close(os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        return True
    except FileExistsError:
        return False
