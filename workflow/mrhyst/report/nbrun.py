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
  each cell's idle message), so here it is stopped at once (nbclient's ``shutdown_kernel="immediate"``): 25 of
  25 runs in 0.74-0.75 s.
* The clean-up ran as a second Python process per notebook.

A kernel that dies before it answers (jupyter_client picks its TCP ports free, then the kernel binds them: a
kernel starting at that moment elsewhere can take one) is started once more; any other failure is raised.
"""

from __future__ import annotations

import logging
import sys

KERNEL = "python3"  # ARCHITECTURE 5: the kernel named explicitly


def parse(argv: list[str]) -> tuple[str, str, dict]:
    """(input, output, parameters) from ``IN OUT [-p NAME VALUE ...]``; a VALUE typed as papermill's CLI types it."""
    from papermill.cli import _resolve_type  # the CLI's own typing of -p values: the same parameters as before

    if len(argv) < 2 or (len(argv) - 2) % 3 or any(argv[i] != "-p" for i in range(2, len(argv), 3)):
        raise SystemExit("usage: python -m mrhyst.report.nbrun IN.ipynb OUT.ipynb [-p NAME VALUE ...]")
    params = {argv[i + 1]: _resolve_type(argv[i + 2]) for i in range(2, len(argv), 3)}
    return argv[0], argv[1], params


def _died_before_ready(err: BaseException) -> bool:
    return "Kernel died before replying to kernel_info" in str(err)


def execute(src: str, dst: str, params: dict) -> None:
    """papermill on ``src`` -> ``dst`` (kernel python3, the kernel stopped at once after the last cell), cleaned."""
    import papermill

    from mrhyst.report import nbclean

    def run():
        papermill.execute_notebook(src, dst, parameters=params, kernel_name=KERNEL, progress_bar=False,
                                   log_output=False, shutdown_kernel="immediate")

    try:
        run()
    except RuntimeError as err:
        if not _died_before_ready(err):
            raise
        run()
    nbclean.clean_file(dst)


def main(argv=None) -> int:
    logging.basicConfig(level=logging.WARNING)  # the CLI's --log-level WARNING
    src, dst, params = parse(list(sys.argv[1:] if argv is None else argv))
    execute(src, dst, params)
    return 0


if __name__ == "__main__":
    sys.exit(main())
