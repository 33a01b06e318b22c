"""Imports run one way: no module imports a layer above its own, the product never imports the research, no circle.

The layers are docs/architecture.md's table (read here, so that the page and the check cannot disagree).  Every
``import`` and ``from ... import`` of every module of ``bayescal`` and ``bayescal_studies`` counts, those inside
functions and under ``TYPE_CHECKING`` included: a deferred import still makes the lower layer depend on the higher.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("bayescal", "bayescal_studies")
"""The top-level packages of the repository: the product and the research beside it."""


def layer_order(architecture: str) -> list[str]:
    """The packages and modules of docs/architecture.md's "Layers" table, lowest first."""
    section = architecture.split("\n## Layers\n", 1)[1]
    rows = [line for line in section.splitlines() if line.startswith("| ") and not line.startswith("| layer")]
    return [name for row in rows for name in re.findall(r"`([\w.]+)`", row.split("|")[2])]


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(name: str, root: Path) -> bool:
    path = root.joinpath(*name.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def imported_modules(path: Path, root: Path, packages=PACKAGES) -> set[str]:
    """The repository's modules that ``path`` imports anywhere in its body (function level and ``TYPE_CHECKING`` too).

    ``from a.b import c`` imports ``a.b.c`` when ``c`` is a module, ``a.b`` (its ``__init__``) otherwise.
    """
    name, is_package = module_name(path, root), path.name == "__init__.py"
    imported = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            imported |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")[: len(name.split(".")) - node.level + (1 if is_package else 0)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            for alias in node.names:
                imported.add(f"{target}.{alias.name}" if _is_module(f"{target}.{alias.name}", root) else target)
    return {module for module in imported if module.split(".")[0] in packages} - {name}


def import_graph(root: Path, packages=PACKAGES) -> dict[str, set[str]]:
    """Every module of ``packages`` under ``root`` and the repository's modules it imports."""
    return {
        module_name(path, root): imported_modules(path, root, packages)
        for package in packages
        for path in sorted((root / package).rglob("*.py"))
    }


def unit_of(module: str, order: list[str]) -> str:
    """The entry of the layer table ``module`` belongs to: the longest entry it is or lies inside."""
    units = [unit for unit in order if module == unit or module.startswith(unit + ".")]
    return max(units, key=len, default="")


def upward_imports(graph: dict[str, set[str]], order: list[str]) -> list[str]:
    """Each import of a module from a package or module listed after its own in ``order``; a module outside the table too."""
    rank = {unit: i for i, unit in enumerate(order)}
    wrong = []
    for module, imported in sorted(graph.items()):
        unit = unit_of(module, order)
        if not unit:
            wrong.append(f"{module} is in no layer of docs/architecture.md")
            continue
        for target in sorted(imported):
            other = unit_of(target, order)
            if other != unit and rank.get(other, len(order)) > rank[unit]:
                wrong.append(f"{module} ({unit}) imports {target} ({other or 'no layer'}), listed after it")
    return wrong


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index, low, stack, on_stack, found, counter = {}, {}, [], set(), [], [0]

    def visit(start: str) -> None:
        work = [(start, iter(sorted(graph.get(start, ()))))]
        index[start] = low[start] = counter[0]
        counter[0] += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, successors = work[-1]
            successor = next(successors, None)
            if successor is not None:
                if successor not in index:
                    index[successor] = low[successor] = counter[0]
                    counter[0] += 1
                    stack.append(successor)
                    on_stack.add(successor)
                    work.append((successor, iter(sorted(graph.get(successor, ())))))
                elif successor in on_stack:
                    low[node] = min(low[node], index[successor])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while not component or component[-1] != node:
                    component.append(stack.pop())
                    on_stack.discard(component[-1])
                if len(component) > 1:
                    found.append(sorted(component))

    for module in sorted(graph):
        if module not in index:
            visit(module)
    return found


@pytest.fixture(scope="module")
def order() -> list[str]:
    return layer_order((ROOT / "docs" / "architecture.md").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    return import_graph(ROOT)


def test_every_package_and_top_level_module_is_in_one_layer_once(order):
    """A new package or module must be placed: inside the table's ``bayescal`` entry it would pass as a foundation."""
    assert len(order) == len(set(order)), "an entry is listed twice in the layers of docs/architecture.md"
    tops = {f"{package}.{path.stem}" for package in PACKAGES for path in (ROOT / package).iterdir()
            if (path.suffix == ".py" and path.stem != "__init__") or (path / "__init__.py").is_file()}
    assert not tops - set(order), f"in no layer of docs/architecture.md: {', '.join(sorted(tops - set(order)))}"


def test_no_module_imports_a_layer_above_its_own(graph, order):
    assert not upward_imports(graph, order), "\n".join(upward_imports(graph, order))


def test_the_product_never_imports_the_research(graph):
    research = {f"{m} imports {t}" for m, imported in graph.items() if m.split(".")[0] == "bayescal"
                for t in imported if t.split(".")[0] == "bayescal_studies"}
    assert not research, "\n".join(sorted(research))


def test_no_module_imports_itself_back_through_others(graph):
    assert not circles(graph), "import circles: " + "; ".join(" ⇄ ".join(c) for c in circles(graph))


def _plant(root: Path, files: dict[str, str]) -> dict[str, set[str]]:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return import_graph(root)


def test_a_planted_back_arrow_and_circle_are_found(tmp_path):
    """The checks on a small tree: a function-level import of a higher layer, a relative one, a type-only circle."""
    graph = _plant(tmp_path, {
        "bayescal/__init__.py": "",
        "bayescal/low/__init__.py": "",
        "bayescal/low/a.py": "def f():\n    from bayescal.high import b\n",
        "bayescal/high/__init__.py": "",
        "bayescal/high/b.py": "from . import c\n",
        "bayescal/high/c.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from bayescal.high.b import B\n",
        "bayescal_studies/__init__.py": "import bayescal.low.a\n",
    })
    order = ["bayescal", "bayescal.low", "bayescal.high", "bayescal_studies"]
    assert graph["bayescal.low.a"] == {"bayescal.high.b"} and graph["bayescal.high.b"] == {"bayescal.high.c"}
    assert upward_imports(graph, order) == ["bayescal.low.a (bayescal.low) imports bayescal.high.b (bayescal.high), listed after it"]
    assert circles(graph) == [["bayescal.high.b", "bayescal.high.c"]]
    assert upward_imports(graph, ["bayescal", "bayescal.high", "bayescal.low", "bayescal_studies"]) == []
    assert "bayescal_studies is in no layer of docs/architecture.md" in upward_imports(graph, ["bayescal", "bayescal.low", "bayescal.high"])
