"""Tests of bayescal.cell.cellfile: the cell file's TOML, its schema and typed values that name their line."""

from __future__ import annotations

import pytest

from bayescal.cell.cellfile import SCHEMA, read_cell_file
from bayescal.errors import InputError

TEXT = """# a cell
[load]
mass_kg = 250
gravity_m_per_s2 = "g"

[tracker]
position_mm = [1, 2, 3]
U0_um = -1
"""


def _reader(tmp_path, text: str = TEXT):
    path = tmp_path / "cell.toml"
    path.write_text(text, encoding="utf-8")
    return read_cell_file(path)


def test_typed_values_and_errors_that_name_the_line_and_key(tmp_path):
    reader = _reader(tmp_path)
    assert reader.number("load", "mass_kg", unit="kg", positive=True) == 250.0
    assert reader.vector("tracker", "position_mm", 3, unit="mm").tolist() == [1.0, 2.0, 3.0]
    assert reader.number("tracker", "factor", unit="a fraction", default=0.8) == 0.8
    with pytest.raises(InputError, match=r"cell\.toml:4, column 'load\.gravity_m_per_s2': expected a number in m/s²"):
        reader.number("load", "gravity_m_per_s2", unit="m/s²")
    with pytest.raises(InputError, match=r":8, column 'tracker\.U0_um': expected a number >= 0"):
        reader.number("tracker", "U0_um", unit="μm", non_negative=True)
    with pytest.raises(InputError, match=r"expected a list of 2 numbers in mm"):
        reader.vector("tracker", "position_mm", 2, unit="mm")
    with pytest.raises(InputError, match=r"missing table \[robot\]"):
        reader.table("robot")
    assert reader.table("design", required=False) is None


def test_an_unknown_key_names_the_closest_known_one(tmp_path):
    with pytest.raises(InputError, match=r":3, column 'tracker\.factr': unknown key 'factr' in \[tracker\]; did you mean 'factor'\?"):
        _reader(tmp_path, "[tracker]\nposition_mm = [0, 0, 0]\nfactr = 0.8\n")
    with pytest.raises(InputError, match=r"unknown table \[trackers\]; did you mean \[tracker\]\?"):
        _reader(tmp_path, "[trackers]\nfactor = 0.8\n")
    assert "factor" in SCHEMA["tracker"] and SCHEMA["tool.markers_mm"] is None


def test_text_is_utf8_with_or_without_a_byte_order_mark(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf[load]\nmass_kg = 250\n")
    assert read_cell_file(path).number("load", "mass_kg", unit="kg") == 250.0
    path.write_bytes(b"[load]\n# 250 kg \xb0\nmass_kg = 250\n")
    with pytest.raises(InputError, match=r":2: byte 0xb0 is not UTF-8"):
        read_cell_file(path)
    path.write_text("[load\n", encoding="utf-8")
    with pytest.raises(InputError, match="not a valid TOML file"):
        read_cell_file(path)
