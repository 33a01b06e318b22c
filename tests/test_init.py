import subprocess
import sys

import pytest

import bayescal


def test_every_entry_point_resolves_to_its_module():
    for name in bayescal.__all__:
        value = getattr(bayescal, name)
        if name != "__version__":
            assert value.__module__.startswith("bayescal.")


def test_unknown_names_raise_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'fit'"):
        bayescal.fit  # noqa: B018


def test_import_stays_light():
    # The entry points are imported on first use: importing the package must not load Pinocchio or ArviZ.
    code = "import sys, bayescal; print(sorted(m for m in ('pinocchio', 'arviz', 'emcee', 'scipy') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
