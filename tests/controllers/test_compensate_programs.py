"""KRL and RAPID programs of 300 Cartesian targets compensated and moved on the twin."""

from __future__ import annotations

import re

import numpy as np
import pytest

from bayescal.compensation import load_calibration
from bayescal.controllers.compensate import compensate_controller_program, program_joints, read_controller_program, read_wrenches
from bayescal_studies.studies.compensation import twin_misses


@pytest.fixture(scope="module")
def calibration(cell, short_calibration):
    return load_calibration(short_calibration["calibration"], cell)


def _write_program(programs, language, drawn, folder):
    if language == "KRL":
        src, dat = programs.krl_texts(drawn)
        (folder / "mill.src").write_bytes(src.encode())
        (folder / "mill.dat").write_bytes(dat.encode())
        (folder / "wrenches.csv").write_text(programs.wrench_csv(drawn, "X", "XHOME"))
        return folder / "mill.src", {"src": "out.src", "dat": "out.dat"}
    (folder / "mill.mod").write_bytes(programs.rapid_text(drawn).encode())
    (folder / "wrenches.csv").write_text(programs.wrench_csv(drawn, "", "home"))
    return folder / "mill.mod", {"mod": "out.mod"}


@pytest.mark.parametrize("language", ["KRL", "RAPID"])
def test_the_compensated_program_lands_the_loaded_twin_within_its_bound(language, cell, calibration, drawn, programs, tmp_path):
    path, outputs = _write_program(programs, language, drawn, tmp_path)
    program = read_controller_program(path)
    compensated = compensate_controller_program(program, read_wrenches(tmp_path / "wrenches.csv", program, cell), calibration, cell)
    for role, text in compensated.texts().items():
        (tmp_path / outputs[role]).write_bytes(text.encode("latin-1"))
    back = read_controller_program(tmp_path / outputs["src" if language == "KRL" else "mod"])
    commanded = program_joints(back, cell.robot)
    # The twin is the cell itself (the truth the calibration's campaign was simulated with).
    miss, uncompensated = twin_misses(cell, compensated.results.program, commanded)
    bound = compensated.results.errors["q9973"]
    loaded = np.linalg.norm(compensated.results.program.wrench[:, :3], axis=1) > 0
    inside = (miss <= bound)[loaded]
    assert inside.mean() >= 0.99
    assert np.median(miss[loaded]) < 0.2 * np.median(uncompensated[loaded])
    # Configuration kept: the status or cfx, and the turn or quadrants, of every target read back.
    for before, after in zip(program.targets, back.targets):
        assert before.name == after.name and before.configuration == after.configuration
    # Read back from 4 decimals of mm and deg: within 2e-5 rad of the joints compensated (measured: at most 1.1e-5 rad).
    assert np.allclose(commanded, compensated.results.commands, atol=2e-5, rtol=0)


@pytest.mark.parametrize("language", ["KRL", "RAPID"])
def test_only_the_targets_declarations_change(language, cell, calibration, drawn, programs, tmp_path):
    path, outputs = _write_program(programs, language, drawn, tmp_path)
    program = read_controller_program(path)
    compensated = compensate_controller_program(program, read_wrenches(tmp_path / "wrenches.csv", program, cell), calibration, cell)
    comment = ";" if language == "KRL" else "!"
    declared = {t.name.upper() for t in program.targets}
    for role, text in compensated.texts().items():
        before = program.files[role]
        after = text.splitlines(keepends=True)
        assert len(before) == len(after)
        for old, new in zip(before, after):
            name = re.search(r"(?:E6POS|E6AXIS|robtarget|jointtarget)\s+(\w+)", old)
            if name and name.group(1).upper() in declared:
                assert new != old and re.search(rf"{re.escape(comment)} bayescal: compensated, 99.73 % error bound \d+\.\d{{4}} mm", new)
                assert new.endswith(old[len(old.rstrip("\r\n")):])
            else:
                assert new == old
