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
