"""Every runtime dependency in pyproject.toml is one the package uses: a library only the tests use is a test extra."""

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODULE = {"pin": "pinocchio"}
"""Distribution names whose module is named otherwise."""
ENGINE = {"netCDF4": "netcdf4"}
"""Distributions the package uses through xarray, by the engine name it passes (``engine="netcdf4"``)."""


def _runtime_dependencies() -> list[str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    return [re.match(r"[A-Za-z0-9_.-]+", requirement).group() for requirement in project["dependencies"]]


def test_every_runtime_dependency_is_used_by_the_package():
    source = "\n".join(path.read_text(encoding="utf-8") for path in (ROOT / "bayescal").rglob("*.py"))
    unused = []
    for name in _runtime_dependencies():
        if name in ENGINE:
            used = f'engine="{ENGINE[name]}"' in source
        else:
            module = MODULE.get(name, name)
            used = re.search(rf"^\s*(import|from) {re.escape(module)}\b", source, re.M) is not None
        if not used:
            unused.append(name)
    assert unused == []
