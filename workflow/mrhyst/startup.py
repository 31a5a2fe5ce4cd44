"""What a `mrhyst` process does before and after its command (issue 26: a warm fit starts at once).

Only the process entry (the console script and `python -m mrhyst`: ``cli.main()`` with no argv) does this; a
caller of ``cli.main(argv)`` in its own process (the tests) gets none of it. Measured on a warm fit of the paper's
loop (bench/bench_startup.py, docs/lab.md "Start-up"):

* **BLAS threads.** numpy's and scipy's OpenBLAS each start a thread pool when loaded (~0.07 s of CPU and wall at
  start-up on 2 cores). Every matrix a command multiplies is far below OpenBLAS's threading thresholds, so one
  thread gives the same bytes (checked on a fit and a diagnosis); a workflow running jobs side by side is not
  oversubscribed. ``OPENBLAS_NUM_THREADS`` is set to 1 only if the user has not set it.
* **The cyclic garbage collector during the imports.** numpy, numba and scipy.optimize create ~10^6 long-lived
  objects; the collector traverses them again and again while they load (~0.14 s of CPU). For the commands that
  load them it is off until the command's modules are in (:func:`imported`), which then moves everything loaded
  into the permanent generation (``gc.freeze``, the objects a process keeps to its end) and turns it back on, so
  the command's own work is collected as usual. numba's target context (its lowering registries, loaded before
  the first kernel comes from the cache) is set up just before that, still without the collector.
* **Tearing down the interpreter** (freeing ~1000 modules one object at a time, ~0.2 s of CPU): after the
  command, stdout and stderr are flushed, the ``atexit`` handlers run (logging, finalizers, pools), and the
  process ends with the command's exit code. Not when other threads still run (the interpreter joins them), a
  profiler or tracer is attached (it writes its results after the command), or a flush fails (the usual exit
  reports it).
"""

from __future__ import annotations

import atexit
import gc
import os
import sys
import threading


def begin(heavy: bool) -> None:
    """Before the command runs. ``heavy``: the command imports numpy, numba and scipy (the collector is off
    until :func:`imported`)."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    if heavy:
        gc.disable()


def imported() -> None:
    """The command's modules are loaded: keep what they created out of every later collection and collect again.
    A no-op when the collector is on (a command run in a test's process)."""
    if not gc.isenabled():
        numba_context()
        gc.freeze()
        gc.enable()


def numba_context() -> None:
    """Set numba's CPU target context up now, as its first compile or cache load would (``refresh``: it imports
    ~60 modules of lowering registries and fills the typing context, ~0.1 s), so that this runs while the
    collector is still off and its objects are frozen with the rest (measured: ~0.01 s less than the same work
    under the collector). The same call numba makes; a no-op when numba is not loaded, and skipped if another
    numba lacks it (it then sets the context up at its first cache load, as before)."""
    if "numba" not in sys.modules:
        return
    try:
        from numba.core.registry import cpu_target

        cpu_target.target_context.refresh()
    except (ImportError, AttributeError):
        pass


def stdout_to_devnull() -> None:
    """Point stdout's file descriptor at the null device after its reader left (a broken pipe), so what is still
    buffered, and the interpreter's own flush at exit, go nowhere instead of failing again."""
    try:
        fd = os.open(os.devnull, os.O_WRONLY)
        os.dup2(fd, sys.stdout.fileno())
        os.close(fd)
    except (OSError, ValueError, AttributeError):  # no real stdout (replaced by a caller): nothing to point
        pass


def finish(code: int) -> int:
    """End the process with ``code`` after the command without tearing the interpreter down, when that is safe;
    else return ``code`` for the usual exit."""
    if not gc.isenabled():  # a command that never reached imported()
        gc.enable()
    if threading.active_count() > 1 or sys.getprofile() is not None or sys.gettrace() is not None:
        return code
    try:
        sys.stdout.flush()
    except BrokenPipeError:  # the reader left after the command's last line was buffered: its files stand
        stdout_to_devnull()
    except (OSError, ValueError):
        return code
    try:
        sys.stderr.flush()
    except (OSError, ValueError):
        return code
    atexit._run_exitfuncs()  # what the interpreter runs first at exit (CPython's own function)
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):
        return code
    os._exit(code)


def cached_yaml(path, load):
    """``load(text)`` of the YAML file ``path`` (the config schema, read by every command that runs a fit or a
    diagnosis: ~0.013 s of libyaml parsing), kept beside it in ``__pycache__/NAME.cpython-XY.marshal`` with the
    source's bytes: the cache is used only when those bytes are the file's (so never stale, whatever the
    timestamps), and written like Python's own bytecode: not when ``sys.dont_write_bytecode``
    (PYTHONDONTWRITEBYTECODE, ``-B``), and silently not where the folder is read-only. Loading it takes ~0.4 ms."""
    import marshal
    from pathlib import Path

    path = Path(path)
    src = path.read_bytes()
    cache = path.parent / "__pycache__" / f"{path.name}.{sys.implementation.cache_tag}.marshal"
    try:
        cached_src, data = marshal.loads(cache.read_bytes())
        if cached_src == src:
            return data
    except (OSError, EOFError, ValueError, TypeError):  # no cache, or one from another Python or truncated
        pass
    data = load(src.decode("utf-8"))
    if not sys.dont_write_bytecode:
        try:
            blob = marshal.dumps((src, data))
            cache.parent.mkdir(exist_ok=True)
            tmp = cache.with_name(f"{cache.name}.{os.getpid()}.tmp")
            tmp.write_bytes(blob)
            os.replace(tmp, cache)  # atomic: parallel jobs never read half a cache
        except (OSError, ValueError):  # a read-only install, or data marshal cannot hold: parse each time
            pass
    return data
