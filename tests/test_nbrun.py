"""mrhyst.report.nbrun: the workflow's notebook runner (papermill with kernel python3, the kernel stopped at once
after the last cell, the copy cleaned) takes the papermill CLI's -p arguments with the CLI's types."""

import nbformat
import pytest
from mrhyst.report import nbrun


def test_parameters_are_typed_as_the_papermill_cli_types_them():
    src, dst, p = nbrun.parse(["in.ipynb", "out.ipynb", "-p", "x", "1.5", "-p", "n", "3", "-p", "s", "a b",
                               "-p", "t", "True", "-p", "path", "results/x.png"])
    assert (src, dst) == ("in.ipynb", "out.ipynb")
    assert p == {"x": 1.5, "n": 3, "s": "a b", "t": True, "path": "results/x.png"}


@pytest.mark.parametrize("argv", [["in.ipynb"], ["in.ipynb", "out.ipynb", "-p", "x"],
                                  ["in.ipynb", "out.ipynb", "-q", "x", "1"]])
def test_a_malformed_command_line_is_one_usage_line(argv):
    with pytest.raises(SystemExit, match="usage: python -m mrhyst.report.nbrun"):
        nbrun.parse(argv)


def test_a_notebook_runs_with_its_parameters_and_its_copy_is_clean(tmp_path):
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.cells = [nbformat.v4.new_code_cell("n = 1", metadata={"tags": ["parameters"]}),
                nbformat.v4.new_code_cell("print(n * 2)")]
    src, dst = tmp_path / "in.ipynb", tmp_path / "out.ipynb"
    nbformat.write(nb, str(src))
    assert nbrun.main([str(src), str(dst), "-p", "n", "21"]) == 0
    out = nbformat.read(str(dst), as_version=4)
    assert "papermill" not in out.metadata
    assert [c["id"] for c in out.cells] == [f"cell-{i:03d}" for i in range(len(out.cells))]
    assert not any("papermill" in c.metadata or "execution" in c.metadata for c in out.cells)
    assert out.cells[-1].outputs[0]["text"] == "42\n"  # the injected n = 21, not the notebook's 1


def test_notebooks_started_side_by_side_each_get_their_own_kernel(tmp_path):
    """Two job slots start notebooks at the same moment: each kernel listens on Unix sockets of its own (no TCP port
    to race for: the TCP runner once waited 60 s for a kernel that had lost its port and failed)."""
    import subprocess
    import sys

    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.cells = [nbformat.v4.new_code_cell("k = 0", metadata={"tags": ["parameters"]}),
                nbformat.v4.new_code_cell("print(k)")]
    src = tmp_path / "in.ipynb"
    nbformat.write(nb, str(src))
    for r in range(3):
        cmds = [[sys.executable, "-m", "mrhyst.report.nbrun", str(src), str(tmp_path / f"o{r}{j}.ipynb"),
                 "-p", "k", str(10 * r + j)] for j in range(2)]
        procs = [subprocess.Popen(c, stdout=subprocess.PIPE, stderr=subprocess.STDOUT) for c in cmds]
        for j, p in enumerate(procs):
            out, _ = p.communicate(timeout=120)
            assert p.returncode == 0, out.decode()[-2000:]
            got = nbformat.read(str(tmp_path / f"o{r}{j}.ipynb"), as_version=4).cells[-1].outputs[0]["text"]
            assert got == f"{10 * r + j}\n"
