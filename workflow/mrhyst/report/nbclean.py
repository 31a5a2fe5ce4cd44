"""Make a papermill-executed notebook byte-stable (ARCHITECTURE section 5).

Drops ``metadata.papermill``, per-cell ``papermill``/``execution`` metadata and
timing, renumbers cell ids, and rewrites the file with a fixed JSON layout.
Usage: ``python -m mrhyst.report.nbclean NOTEBOOK.ipynb [...]``.
"""

from __future__ import annotations

import sys

import nbformat

from mrhyst.data.io import atomic_path


def clean(nb):
    nb.metadata.pop("papermill", None)
    nb.metadata.pop("widgets", None)
    for i, cell in enumerate(nb.cells):
        cell.metadata.pop("papermill", None)
        cell.metadata.pop("execution", None)
        cell["id"] = f"cell-{i:03d}"
    return nb


def clean_file(path) -> None:
    nb = nbformat.read(path, as_version=4)
    clean(nb)
    with atomic_path(path) as tmp:
        nbformat.write(nb, str(tmp))


def main(argv=None) -> int:
    for p in (argv if argv is not None else sys.argv[1:]):
        clean_file(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
