"""The package's code as it was at an earlier commit, importable beside the current one, for the benchmarks' baselines.

A benchmark that times new code against the code it replaced loads the replaced modules from
the repository's history (``git show REVISION:path``) instead of keeping a second copy of them
in the tree: ``previous("design", ("criteria", "optimise"), revision)`` returns a package named
``previous_design`` whose modules are those of ``bayescal/design/`` at ``revision``, their
imports of each other redirected to it; everything else they import is today's package, unless
``redirect`` sends it to another such package (``{"bayescal.robot.batched": "previous_robot.batched"}``).
A benchmark of whole commands runs them in :func:`previous_tree`, the repository's files at that
revision, beside the working tree.
"""

from __future__ import annotations

import io
import subprocess
import sys
import tarfile
import tempfile
import types
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


class NoHistory(RuntimeError):
    """The revision is not in this checkout (an export without ``.git``, or a shallow clone)."""


def previous(subpackage: str, modules: Sequence[str], revision: str, redirect: Mapping[str, str] | None = None) -> types.ModuleType:
    """The ``modules`` of ``bayescal/<subpackage>/`` at ``revision`` as the package ``previous_<subpackage>``.

    ``redirect`` maps other modules they import (``bayescal.robot.batched``) to modules loaded before by
    :func:`previous` (``previous_robot.batched``).

    Raises
    ------
    NoHistory
        When git cannot show those files at ``revision``; the benchmark then says so and skips its baseline.
    """
    name = f"previous_{subpackage}"
    if name in sys.modules:
        return sys.modules[name]
    sources = {}
    for module in modules:
        try:
            sources[module] = subprocess.run(
                ["git", "show", f"{revision}:bayescal/{subpackage}/{module}.py"], cwd=ROOT, capture_output=True, text=True, check=True
            ).stdout
        except (OSError, subprocess.CalledProcessError) as error:
            raise NoHistory(f"bayescal/{subpackage}/{module}.py at {revision} is not in this checkout ({error})") from None
    package = types.ModuleType(name)
    package.__path__ = []
    sys.modules[name] = package
    for module in modules:
        loaded = types.ModuleType(f"{name}.{module}")
        loaded.__file__ = f"<bayescal/{subpackage}/{module}.py at {revision}>"
        sys.modules[loaded.__name__] = loaded
        setattr(package, module, loaded)
    # Executed in the order given, so that a module may import one listed before it; imports of the replaced
    # modules go to their previous versions, the rest of the package is today's.
    for module in modules:
        text = sources[module]
        for other in modules:
            text = text.replace(f"from bayescal.{subpackage}.{other} import", f"from {name}.{other} import")
        for module_name, replacement in (redirect or {}).items():
            text = text.replace(f"from {module_name} import", f"from {replacement} import")
        loaded = sys.modules[f"{name}.{module}"]
        exec(compile(text, loaded.__file__, "exec"), loaded.__dict__)
    return package


@contextmanager
def previous_tree(revision: str) -> Iterator[Path]:
    """A temporary folder holding the repository's files at ``revision`` (``git archive``), removed on exit.

    ``python -m bayescal`` run with that folder as its working directory imports the package from it, not
    the installed one: the command line as it was, on the same data.

    Raises
    ------
    NoHistory
        When git cannot archive ``revision``.
    """
    try:
        archive = subprocess.run(["git", "archive", revision], cwd=ROOT, capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as error:
        raise NoHistory(f"revision {revision} is not in this checkout ({error})") from None
    with tempfile.TemporaryDirectory() as folder:
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            tar.extractall(folder, filter="data")
        yield Path(folder)
