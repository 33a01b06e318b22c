"""Tests of bayescal.cell.campaign: the campaign CSV round trip and its validation."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.cell.campaign import Campaign, read_campaign, write_campaign
from bayescal.errors import InputError
from bayescal.units import DEG, MM


def _campaign(n_configs: int = 2, repeats: int = 2, markers=("M1", "M2", "M3")) -> Campaign:
    rng = np.random.default_rng(0)
    rows = [(c, r, m) for c in range(1, n_configs + 1) for r in range(1, repeats + 1) for m in markers]
    config = np.array([row[0] for row in rows])
    q = rng.uniform(-1, 1, (n_configs, 6))[config - 1]
    wrench = rng.normal(0, 1000, (n_configs, 6))[config - 1]
    p0 = rng.normal(0, 1, (len(rows), 3))
    return Campaign(
        config=config,
        repeat=np.array([row[1] for row in rows]),
        marker=np.array([row[2] for row in rows]),
        q=q,
        wrench=wrench,
        p0=p0,
        p1=p0 + rng.normal(0, 1e-3, p0.shape),
        lines=np.zeros(len(rows), dtype=int),
        source="test",
    )


def test_round_trip(tmp_path):
    campaign = _campaign()
    path = tmp_path / "c.csv"
    write_campaign(campaign, path, comments=["simulated", "seed 1"])
    text = path.read_text()
    assert text.startswith("# simulated\n# seed 1\nconfig,repeat,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,")
    assert "fx_N,fy_N,fz_N,mx_Nm,my_Nm,mz_Nm,marker,x0_mm,y0_mm,z0_mm,x1_mm,y1_mm,z1_mm\n" in text
    back = read_campaign(path)
    assert len(back) == len(campaign) == 12 and back.n_equations == 36
    np.testing.assert_array_equal(back.config, campaign.config)
    np.testing.assert_array_equal(back.repeat, campaign.repeat)
    np.testing.assert_array_equal(back.marker, campaign.marker)
    np.testing.assert_allclose(back.q, campaign.q, atol=1e-6 * DEG)
    np.testing.assert_allclose(back.wrench, campaign.wrench, atol=1e-4)
    np.testing.assert_allclose(back.p0, campaign.p0, atol=1e-5 * MM)
    np.testing.assert_allclose(back.displacement, campaign.displacement, atol=2e-5 * MM)
    np.testing.assert_array_equal(back.lines, np.arange(4, 16))
    assert back.source == str(path)
    frame = back.to_frame()
    assert frame["x1_mm"].iloc[0] == pytest.approx(campaign.p1[0, 0] / MM, abs=1e-5)


def test_writing_is_deterministic(tmp_path):
    write_campaign(_campaign(), tmp_path / "a.csv")
    write_campaign(_campaign(), tmp_path / "b.csv")
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


def _write_rows(tmp_path, edit):
    path = tmp_path / "c.csv"
    write_campaign(_campaign(), path)
    lines = path.read_text().splitlines()
    edit(lines)
    path.write_text("\n".join(lines) + "\n")
    return path


def _error(path, **kwargs) -> str:
    with pytest.raises(InputError) as caught:
        read_campaign(path, **kwargs)
    message = str(caught.value)
    assert "\n" not in message
    return message


def test_missing_column(tmp_path):
    def drop_z1(lines):
        for i, line in enumerate(lines):
            lines[i] = ",".join(line.split(",")[:-1])

    message = _error(_write_rows(tmp_path, drop_z1))
    assert ":1:" in message and "missing column 'z1_mm'" in message


def test_unpaired_row(tmp_path):
    def blank_x1(lines):
        fields = lines[3].split(",")
        fields[-3] = ""
        lines[3] = ",".join(fields)

    message = _error(_write_rows(tmp_path, blank_x1))
    assert "c.csv:4" in message and "x1_mm" in message and "no loaded position" in message


def test_nan_wrench(tmp_path):
    def nan_force(lines):
        fields = lines[2].split(",")
        fields[10] = "nan"
        lines[2] = ",".join(fields)

    message = _error(_write_rows(tmp_path, nan_force))
    assert "c.csv:3" in message and "fz_N" in message


def test_duplicated_marker(tmp_path):
    def duplicate(lines):
        lines.append(lines[1])

    message = _error(_write_rows(tmp_path, duplicate))
    assert "c.csv:14" in message and "already appears on line 2" in message


def test_configuration_rows_must_agree(tmp_path):
    def move_q3(lines):
        fields = lines[5].split(",")
        fields[4] = str(float(fields[4]) + 0.5)
        lines[5] = ",".join(fields)

    message = _error(_write_rows(tmp_path, move_q3))
    assert "c.csv:6" in message and "q3_deg" in message and "line 2" in message


def test_unknown_marker(tmp_path):
    path = tmp_path / "c.csv"
    write_campaign(_campaign(), path)
    assert len(read_campaign(path, markers=["M1", "M2", "M3"])) == 12
    message = _error(path, markers=["M1", "M2"])
    assert "c.csv:4" in message and "unknown marker 'M3'" in message


def test_repeat_must_be_positive(tmp_path):
    def zero_repeat(lines):
        fields = lines[1].split(",")
        fields[1] = "0"
        lines[1] = ",".join(fields)

    message = _error(_write_rows(tmp_path, zero_repeat))
    assert "c.csv:2" in message and "repeat" in message


def test_campaign_checks_shapes():
    campaign = _campaign()
    with pytest.raises(ValueError, match="p1"):
        Campaign(campaign.config, campaign.repeat, campaign.marker, campaign.q, campaign.wrench, campaign.p0, campaign.p1[:-1], campaign.lines)
