"""Tests of bayescal.compensation.results: a compensated program's four verbs agree with its per-pose table."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from bayescal.compensation import compensate_program
from bayescal.compensation.calibration import Calibration
from bayescal_studies.studies.compensation import random_program


def _results(cell, tolerance=None):
    bare = dataclasses.replace(cell, compensator=None)
    rng = np.random.default_rng(3)
    own = cell.compliances * np.exp(0.05 * rng.standard_normal((200, 6)))
    calibration = Calibration(own=own, spring=None, geometry=None, gravity_scale=1.0, compensated_joint=None, unidentified=("k1",))
    return compensate_program(random_program(bare, 10, np.random.default_rng(4)), calibration, bare, tolerance=tolerance)


def test_the_summary_is_the_per_pose_tables_median_and_max(cell):
    results = _results(cell)
    table, summary = results.table(), results.summary()
    assert isinstance(summary, pd.DataFrame) and list(summary.columns) == ["median", "max"]
    for name in ("deflection_mm", "error_rms_mm", "error_q9973_mm"):
        assert summary.loc[name, "median"] == np.median(table[name]) and summary.loc[name, "max"] == table[name].max()
    share = summary.loc["unidentified_share_of_mean_square_error"]
    assert 0 < share["median"] <= share["max"] < 1


def test_the_json_carries_the_summary_the_counts_and_the_worst_poses_and_save_writes_the_table(cell, tmp_path):
    results = _results(cell, tolerance=1e-6)
    payload = results.to_json()
    assert payload["summary"]["poses"] == 10 and payload["summary"]["unidentified"] == ["k1"]
    assert payload["summary"]["error_q9973_mm"]["max"] == results.summary().loc["error_q9973_mm", "max"]
    # A 1 μm tolerance flags every pose of a random program.
    assert payload["summary"]["flagged"] == 10 and payload["diagnostics"]["equilibrium_failures"] == 0
    worst = [pose["error_q9973_mm"] for pose in payload["worst_poses"]]
    assert worst == sorted(worst, reverse=True)
    results.save(tmp_path / "compensated.csv")
    saved = pd.read_csv(tmp_path / "compensated.csv")
    # Fixed decimals, as a controller reads them: 4 by default, never an exponent.
    np.testing.assert_allclose(saved["error_q9973_mm"], results.table()["error_q9973_mm"], rtol=0, atol=5e-5)
    text = (tmp_path / "compensated.csv").read_text()
    assert "e-" not in text.split("\n", 1)[1] and "-0.0000," not in text
    assert (saved["flag"] != "ok").all()


def test_a_program_may_not_carry_the_columns_the_compensated_file_adds_and_those_are_all_it_adds(cell):
    from bayescal.compensation.program import compensated_columns

    results = _results(cell)
    added = [name for name in results.table().columns if name not in results.program.table.columns]
    assert added == list(compensated_columns(results.robot))


def test_the_document_names_the_worst_pose_and_the_flags(cell):
    from bayescal.numbers import error_length

    results = _results(cell, tolerance=1e-6)
    payload = results.to_json()
    document = results.document()
    assert document.title == f"{results.program.source}: 10 poses compensated over {results.n_draws} draws"
    lines = document.as_text().splitlines()
    worst = payload["worst_poses"][0]
    assert f"worst {error_length(worst['error_q9973_mm'])} at line {worst['line']}" in lines[2]
    assert lines[-1] == "flagged: 10 (0 outside the joint limits, 0 without equilibrium, tolerance 0.001 mm)"
    assert document.as_markdown().startswith(f"# {results.program.source}: 10 poses")
