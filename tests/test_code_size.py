"""No module over 500 lines, no function over 60 lines (its docstring included), in every package of the repository.

A long function is read as a whole or not at all: split into named steps, each step can be read, tested and
reused alone.  The packages are found, not listed: every folder at the top of the repository with an
``__init__.py``.
"""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODULE_LINES = 500
FUNCTION_LINES = 60


def _modules():
    for package in sorted(p.parent for p in ROOT.glob("*/__init__.py")):
        yield from sorted(package.rglob("*.py"))


def _long_functions(path: Path) -> list[tuple[str, int]]:
    """``(name, lines)`` of every function or method of ``path`` longer than :data:`FUNCTION_LINES`."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    return [
        (node.name, node.end_lineno - node.lineno + 1)
        for node in ast.walk(tree)
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.end_lineno - node.lineno + 1 > FUNCTION_LINES
    ]


def test_the_packages_are_found():
    assert ROOT / "bayescal" / "inference" / "elastostatic.py" in set(_modules())


def test_no_module_is_over_500_lines():
    long = {str(p.relative_to(ROOT)): n for p in _modules() if (n := len(p.read_text(encoding="utf-8").splitlines())) > MODULE_LINES}
    assert long == {}


def test_no_function_is_over_60_lines():
    long = {
        (str(path.relative_to(ROOT)), name): lines
        for path in _modules()
        for name, lines in _long_functions(path)
    }
    assert long == {}

