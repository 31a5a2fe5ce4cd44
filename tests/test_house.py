"""House rules a reader can hold the package to (the developers' guide): every function fits on one screen
(at most 80 lines, decorators and docstring included) and no module is over 600 lines. Read with ast
from the source, so a new function or module that breaks a rule fails here, naming it."""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "workflow" / "mrhyst"
MAX_FUNCTION_LINES = 80
MAX_MODULE_LINES = 600
MODULES = sorted(PACKAGE.rglob("*.py"))


def function_lengths(source: str) -> list[tuple[str, int, int]]:
    """(qualified name, first line, lines) of every function and method, nested ones included; a function's
    lines run from its first decorator to its last line."""
    out = []

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f"{prefix}{child.name}"
                if not isinstance(child, ast.ClassDef):
                    first = min([child.lineno] + [d.lineno for d in child.decorator_list])
                    out.append((name, first, child.end_lineno - first + 1))
                visit(child, name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(source), "")
    return out


def test_the_rule_counts_lines_as_a_reader_sees_them():
    """Hand-counted: a 3-line function with a decorator is 4 lines; a method and a nested function are found."""
    src = "import x\n\n\n@dec\ndef f(a):\n    b = a\n    return b\n\n\nclass C:\n    def m(self):\n" \
          "        def inner():\n            pass\n        return inner\n"
    assert function_lengths(src) == [("f", 4, 4), ("C.m", 11, 4), ("C.m.inner", 12, 2)]


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_functions_fit_on_a_screen_and_modules_stay_small(path):
    source = path.read_text()
    n = len(source.splitlines())
    assert n <= MAX_MODULE_LINES, f"{path.relative_to(PACKAGE)}: {n} lines (at most {MAX_MODULE_LINES})"
    long = [f"{name} (line {first}): {lines} lines" for name, first, lines in function_lengths(source)
            if lines > MAX_FUNCTION_LINES]
    assert not long, f"{path.relative_to(PACKAGE)}: over {MAX_FUNCTION_LINES} lines: " + "; ".join(long)
