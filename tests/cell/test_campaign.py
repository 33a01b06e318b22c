"""Tests of bayescal.cell.campaign: the campaign CSV round trip and its validation."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bayescal.cell.campaign import WRENCH_COLUMNS, Campaign, read_campaign, write_campaign
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


def test_config_and_repeat_are_labels_of_any_sign(tmp_path):
    def relabel(lines):
        for i, line in enumerate(lines[1:], start=1):
            fields = line.split(",")
            fields[0], fields[1] = str(-int(fields[0]) + 1), str(int(fields[1]) - 1)
            lines[i] = ",".join(fields)

    campaign = read_campaign(_write_rows(tmp_path, relabel))
    assert set(campaign.config) == {0, -1} and set(campaign.repeat) == {0, 1}


def test_campaign_checks_shapes():
    campaign = _campaign()
    with pytest.raises(ValueError, match="p1"):
        Campaign(campaign.config, campaign.repeat, campaign.marker, campaign.q, campaign.wrench, campaign.p0, campaign.p1[:-1], campaign.lines)


def _rewrite(source, tmp_path, change) -> Path:
    """A copy of a campaign CSV with ``change(header, rows)`` applied to its data (lists of fields)."""
    lines = source.read_text().splitlines()
    comments = [line for line in lines if line.startswith("#")]
    header, *rows = (line.split(",") for line in lines if not line.startswith("#"))
    header, rows = change(header, rows)
    path = tmp_path / "edited.csv"
    path.write_text("\n".join(comments + [",".join(fields) for fields in [header, *rows]]) + "\n")
    return path


def _scale(columns, factor):
    def change(header, rows):
        at = [header.index(name) for name in columns]
        return header, [[f"{float(v) * factor:.6g}" if i in at else v for i, v in enumerate(row)] for row in rows]

    return change


def _set(column, value, config="3"):
    def change(header, rows):
        at = header.index(column)
        return header, [[value if i == at and row[0] == config else v for i, v in enumerate(row)] for row in rows]

    return change


def _drop(column):
    def change(header, rows):
        at = header.index(column)
        return [v for i, v in enumerate(header) if i != at], [[v for i, v in enumerate(row) if i != at] for row in rows]

    return change


def _add_q7(header, rows):
    at = header.index("q6_deg") + 1
    return header[:at] + ["q7_deg"] + header[at:], [row[:at] + ["0"] + row[at:] for row in rows]


@pytest.mark.parametrize(
    ("change", "place", "message"),
    [
        (_scale(WRENCH_COLUMNS, 1000), ":9, column 'fz_N'", "the arm can plausibly carry (2 x the weight of 270 kg"),
        (_set("fz_N", "-1e12"), ":9, column 'fz_N'", "a load force of 1e+12 N is more than the 5296 N"),
        (_scale(WRENCH_COLUMNS, 1e-3), ":9, column 'fz_N'", "is the wrench in kN instead of N?"),
        (_scale(WRENCH_COLUMNS[3:], 1000), ":3, column 'm", "are mx_Nm..mz_Nm in N·mm instead of N·m?"),
        (_set("q2_deg", "200"), ":9, column 'q2_deg'", "joint A2 at 200.000 deg is outside its limits"),
        (_scale(["q1_deg", "q2_deg", "q3_deg", "q4_deg", "q5_deg", "q6_deg"], DEG), ":3, column 'q1_deg'", "write q1_deg..q6_deg in degrees"),
    ],
)
def test_a_campaign_is_checked_against_the_cell(cell, campaign_csv, tmp_path, change, place, message):
    path = _rewrite(campaign_csv, tmp_path, change)
    assert len(read_campaign(path)) == 45  # well-formed: only the cell tells these numbers are wrong
    text = _error(path, cell=cell)
    assert message in text and f"edited.csv{place}" in text


@pytest.mark.parametrize(
    ("change", "column", "message"),
    [
        (_drop("q6_deg"), "q6_deg", "has no column q6_deg but the robot"),
        (_add_q7, "q7_deg", "has a column q7_deg but the robot"),
    ],
)
def test_joint_columns_must_match_the_robot(cell, campaign_csv, tmp_path, change, column, message):
    text = _error(_rewrite(campaign_csv, tmp_path, change), cell=cell)
    assert f"edited.csv:2, column '{column}'" in text and message in text and "expected the columns q1_deg..q6_deg" in text


def test_the_twin_campaign_passes_the_cell_checks(cell, campaign_csv):
    campaign = read_campaign(campaign_csv, cell=cell)
    assert len(campaign) == 45 and campaign.q.shape == (45, 6)
    assert np.abs(campaign.wrench[:, :3]).max() < cell.max_force


# --------------------------------------------------------------------------- random perturbations

_JUNK = st.sampled_from(["", "nan", "inf", "-1e12", "1e12", "7_9.20", "abc", "0x10", " ", "1;2", '"', "١", "M9", "-0", "1e400"])


@st.composite
def _perturbed(draw, lines):
    """A valid campaign's lines with cells replaced by junk, rows dropped or duplicated, or columns renamed."""
    comments = [line for line in lines if line.startswith("#")]
    header, *rows = [line.split(",") for line in lines if not line.startswith("#")]
    header, rows = list(header), [list(row) for row in rows]
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["cell", "drop", "duplicate", "rename", "truncate"]))
        if kind == "cell":
            row = draw(st.integers(0, len(rows) - 1))
            if rows[row]:
                rows[row][draw(st.integers(0, len(rows[row]) - 1))] = draw(_JUNK)
        elif kind == "drop" and len(rows) > 1:
            del rows[draw(st.integers(0, len(rows) - 1))]
        elif kind == "duplicate":
            row = draw(st.integers(0, len(rows) - 1))
            rows.insert(draw(st.integers(0, len(rows))), list(rows[row]))
        elif kind == "rename":
            column = draw(st.integers(0, len(header) - 1))
            header[column] = draw(st.sampled_from(["q7_deg", "fx_kN", "x0_m", "", header[column].upper(), "q1_deg"]))
        elif kind == "truncate":
            row = draw(st.integers(0, len(rows) - 1))
            rows[row] = rows[row][: draw(st.integers(0, len(header) - 1))]
    return "\n".join(comments + [",".join(fields) for fields in [header, *rows]]) + "\n"


@settings(max_examples=200, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_random_perturbations_give_a_campaign_or_one_line_error(cell, campaign_csv, tmp_path, data):
    text = data.draw(_perturbed(campaign_csv.read_text().splitlines()))
    path = tmp_path / "perturbed.csv"
    path.write_text(text)
    before = path.read_bytes()
    try:
        campaign = read_campaign(path, cell=cell)
    except InputError as error:
        message = str(error)
        assert "\n" not in message and message.startswith(str(path))
    else:
        assert np.all(np.isfinite(campaign.q)) and np.all(np.isfinite(campaign.p1))
        assert np.linalg.norm(campaign.wrench[:, :3], axis=1).max() <= cell.max_force
    assert path.read_bytes() == before


def test_loaded_positions_equal_to_the_unloaded_ones_are_an_error(tmp_path):
    def copy_unloaded(lines):
        for i, line in enumerate(lines[1:], start=1):
            fields = line.split(",")
            lines[i] = ",".join(fields[:-3] + fields[-6:-3])

    message = _error(_write_rows(tmp_path, copy_unloaded))
    assert "c.csv:2, column 'x1_mm'" in message and "were the unloaded columns copied" in message


def test_the_load_point_columns_round_trip_and_must_come_together(tmp_path, cell, plan):
    import dataclasses

    import pandas as pd

    from bayescal.twin.simulator import DigitalTwin

    two = dataclasses.replace(plan, q=plan.q[:2], load_kg=plan.load_kg[:2], lines=plan.lines[:2])
    campaign = DigitalTwin(cell).simulate(two, 1, np.random.default_rng(0))
    with_point = dataclasses.replace(campaign, load_point=np.tile([0.1, -0.02, 0.3], (len(campaign), 1)))
    path = tmp_path / "c.csv"
    write_campaign(with_point, path)
    np.testing.assert_allclose(read_campaign(path).load_point, with_point.load_point, atol=1e-8)

    partial = tmp_path / "partial.csv"
    pd.read_csv(path, comment="#").drop(columns=["load_z_mm"]).to_csv(partial, index=False)
    with pytest.raises(InputError, match="column 'load_z_mm'.*the load point needs all of load_x_mm, load_y_mm, load_z_mm"):
        read_campaign(partial)


def test_the_reading_times_round_trip_must_come_together_and_run_forward(tmp_path, cell, plan):
    import dataclasses

    import pandas as pd

    from bayescal.twin.simulator import DigitalTwin

    two = dataclasses.replace(plan, q=plan.q[:2], load_kg=plan.load_kg[:2], lines=plan.lines[:2])
    campaign = DigitalTwin(cell).simulate(two, 1, np.random.default_rng(0))
    start = 600.0 * np.arange(len(campaign))
    stamped = dataclasses.replace(campaign, times=np.column_stack([start, start + 480.0]))
    path = tmp_path / "c.csv"
    write_campaign(stamped, path)
    np.testing.assert_allclose(read_campaign(path).times, stamped.times)
    assert DigitalTwin(cell).simulate(two, 1, np.random.default_rng(0)).times is None

    table = pd.read_csv(path, comment="#")
    partial = tmp_path / "partial.csv"
    table.drop(columns=["t1_s"]).to_csv(partial, index=False)
    with pytest.raises(InputError, match="column 't1_s'.*the reading times needs all of t0_s, t1_s"):
        read_campaign(partial)
    backwards = tmp_path / "backwards.csv"
    table.assign(t1_s=table["t0_s"] - 1.0).to_csv(backwards, index=False)
    with pytest.raises(InputError, match=r"backwards.csv:2, column 't1_s'.*stamped before the unloaded one"):
        read_campaign(backwards)
    blank = tmp_path / "blank.csv"
    table.assign(t0_s=[None] + list(table["t0_s"][1:])).to_csv(blank, index=False)
    with pytest.raises(InputError, match="column 't0_s'"):
        read_campaign(blank)


def _written_one_value_at_a_time(campaign: Campaign) -> str:
    """The campaign's CSV as the csv module writes it, each number rounded by ``round`` (write_campaign's rule)."""
    import csv
    import io

    frame = campaign.to_frame()
    places = {name: 6 for name in frame.columns if name.startswith("q")} | {name: 4 for name in WRENCH_COLUMNS}
    places |= {name: 5 for name in frame.columns if name.endswith("_mm")}
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(frame.columns)
    for row in frame.itertuples(index=False):
        writer.writerow(f"{round(float(v), places[n]) + 0.0:.{places[n]}f}" if n in places else v for n, v in zip(frame.columns, row))
    return out.getvalue()


def test_the_written_numbers_are_those_rounded_one_at_a_time(tmp_path):
    # ties of the binary value (2.675 is below its decimal), values that round to -0, -0.0 itself, NaN and
    # magnitudes where the last place is below the float's resolution; a marker name that needs quoting
    campaign = _campaign(n_configs=3, repeats=2, markers=("M1", "M,2", 'M"3'))
    edge = np.array([2.675, -2.675, -4e-6, -5e-6, -6e-6, -0.0, 0.0, 1e-300, -1e-300, 5e9 + 0.123, -7.5e15, np.nan, 1.0000005, -0.0000049])
    p0 = np.resize(edge, campaign.p0.size).reshape(campaign.p0.shape) * MM
    wrench = campaign.wrench.copy()
    wrench[:, :2] = np.resize([-0.00004, -0.00005, 0.00005, -0.0], (len(wrench), 2))
    odd = Campaign(**{**campaign.__dict__, "p0": p0, "p1": p0[::-1].copy(), "wrench": wrench})
    path = tmp_path / "c.csv"
    write_campaign(odd, path)
    assert path.read_text() == _written_one_value_at_a_time(odd)
