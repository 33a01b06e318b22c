import json

import pytest

from bayescal.errors import InputError
from bayescal.reports.compensation import read_compensated
from bayescal.reports.review import ReviewInputs, render_review


def _write(path, rows):
    path.write_text("q1_deg,deflection_mm,error_rms_mm,error_q9973_mm,flag\n" + "".join(f"{r}\n" for r in rows))
    return path


def test_the_section_shows_the_program_and_its_worst_poses(tmp_path):
    rows = [f"{i},{1 + i / 10:.3f},{0.01 * i:.4f},{0.05 * i:.4f},ok" for i in range(1, 13)]
    rows[4] = "5,1.5,0.2,0.9,\"99.73% error 0.9 mm above the tolerance 0.5 mm\""
    frame = read_compensated(str(_write(tmp_path / "c.csv", rows)))
    files = render_review(ReviewInputs(sources={"compensated program": "c.csv"}, compensation=frame))
    html = files["index.html"].decode()
    assert "Compensated machining program" in html and "12 poses, 1 flagged" in html
    assert "program_errors.png" in files
    # The worst pose (line 6 of the file: its fifth row) heads the worst-poses table.
    worst = json.loads(files["numbers.json"])["compensation"]["worst_poses"]
    assert list(worst)[:2] == ["6", "13"] and worst["6"]["error_q9973_mm"] == 0.9


def test_a_file_without_the_error_columns_is_refused(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("q1_deg,deflection_mm\n0,1\n")
    with pytest.raises(InputError, match="error_rms_mm"):
        read_compensated(str(path))
