"""Execute one notebook with papermill and make the executed copy byte-stable, in one process (the workflow's
notebook rules, ``PAPERMILL`` in workflow/rules/common.smk; ARCHITECTURE section 5).

Usage: ``python -m mrhyst.report.nbrun IN.ipynb OUT.ipynb [-p NAME VALUE ...]`` — the papermill CLI's
``papermill -k python3 IN OUT -p NAME VALUE ...`` (each VALUE typed as that CLI types it), then
:func:`mrhyst.report.nbclean.clean_file` on OUT.

Why not the papermill CLI (which the rules ran until issue 23's twelfth session):

* The CLI shuts the kernel down gracefully: jupyter_client asks it to exit, then waits for it to do so. The
  kernel (ipykernel 7) sometimes does not exit until jupyter_client gives up and terminates it ~3.3 s later: 5
  of 55 runs of a one-cell notebook on this machine, 4.1-4.4 s instead of 0.9 s (bench/README, "Twelfth session").
  A notebook job held a core slot that long for nothing, and at the build's end the report's own notebook lay on
  its critical path. The kernel has nothing left to do once the last cell's output is in (nbclient waits for
  each cell's idle message), so here it is stopped at once: 25 of 25 runs in 0.74-0.75 s.
* The clean-up ran as a second Python process per notebook.
* The kernel talked to papermill over TCP on ports jupyter_client picks free and the kernel binds a moment later: a
  kernel starting in the other job slot at that moment can take one ("Address already in use"). A run then
  ended with "Kernel died before replying to kernel_info" (the rules started it once more) or, where the failed
  kernel did not exit, waited 60 s for "Kernel didn't respond" and failed (once, in a build of cfe2b2d, with this
  runner's first, TCP version). Here the kernel listens
  on Unix sockets (jupyter_client's ``ipc`` transport) in a directory of its own: nothing to race for (50 runs, two
  at a time, 0.44-0.69 s, no failure).
"""

from __future__ import annotations

import logging
import os
import shutil
import sys
import tempfile

KERNEL = "python3"  # ARCHITECTURE 5: the kernel named explicitly


def parse(argv: list[str]) -> tuple[str, str, dict]:
    """(input, output, parameters) from ``IN OUT [-p NAME VALUE ...]``; a VALUE typed as papermill's CLI types it."""
    from papermill.cli import _resolve_type  # the CLI's own typing of -p values: the same parameters as before

    if len(argv) < 2 or (len(argv) - 2) % 3 or any(argv[i] != "-p" for i in range(2, len(argv), 3)):
        raise SystemExit("usage: python -m mrhyst.report.nbrun IN.ipynb OUT.ipynb [-p NAME VALUE ...]")
    params = {argv[i + 1]: _resolve_type(argv[i + 2]) for i in range(2, len(argv), 3)}
    return argv[0], argv[1], params


def execute(src: str, dst: str, params: dict) -> None:
    """papermill on ``src`` -> ``dst`` (kernel python3 on Unix sockets of its own, stopped at once after the last
    cell), cleaned."""
    import papermill
    from jupyter_client.manager import KernelManager

    from mrhyst.report import nbclean

    home = tempfile.mkdtemp(prefix="mrhyst-kernel-")
    km = KernelManager(kernel_name=KERNEL, transport="ipc", ip=os.path.join(home, "k"))
    try:  # a kernel manager handed in is not shut down by nbclient: here, at once, whatever happened
        papermill.execute_notebook(src, dst, parameters=params, kernel_name=KERNEL, progress_bar=False,
                                   log_output=False, km=km)
    finally:
        if km.has_kernel:
            km.shutdown_kernel(now=True)
        shutil.rmtree(home, ignore_errors=True)
    nbclean.clean_file(dst)


def main(argv=None) -> int:
    logging.basicConfig(level=logging.WARNING)  # the CLI's --log-level WARNING
    src, dst, params = parse(list(sys.argv[1:] if argv is None else argv))
    execute(src, dst, params)
    return 0


if __name__ == "__main__":
    sys.exit(main())
