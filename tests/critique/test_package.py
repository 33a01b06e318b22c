import subprocess
import sys

import pytest

import bayescal.critique


def test_the_package_names_resolve_to_their_classes():
    for name in bayescal.critique.__all__:
        assert getattr(bayescal.critique, name).__name__ == name
    with pytest.raises(AttributeError, match="no attribute 'fit'"):
        bayescal.critique.fit  # noqa: B018


def test_reading_a_critique_file_loads_neither_the_optimiser_nor_the_registration():
    # bayescal report checks critique.json against the results' schema: the package's classes load on first use only.
    code = ("import sys, bayescal.critique.results; "
            "print(sorted(m for m in ('scipy.optimize', 'bayescal.registration', 'bayescal.critique.geometry') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
