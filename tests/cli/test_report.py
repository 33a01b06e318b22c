import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from bayescal.cell.campaign import read_campaign, write_campaign
from bayescal.cli import main

FIXTURES = Path(__file__).resolve().parents[1] / "reports" / "data"


def run(capsys, argv):
    status = main(["report", *argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def calibration_args(paths) -> list[str]:
    return [arg for option in ("calibration", "campaign", "config") for arg in (f"--{option}", str(paths[option]))]


def digest(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def test_json_output_names_the_files_and_leaves_the_inputs_untouched(capsys, short_calibration, tmp_path):
    inputs = [short_calibration[name] for name in ("geometry", "calibration", "campaign")]
    before = [digest(path) for path in inputs]
    status, out, err = run(capsys, ["--geometry", str(short_calibration["geometry"]), *calibration_args(short_calibration), "-o", str(tmp_path / "r"), "--json"])
    assert status == 0, err
    payload = json.loads(out)
    assert payload["report"] == str(tmp_path / "r" / "index.html")
    assert {"index.html", "summary.md", "numbers.json", "joint2_compliance.png", "test_pose_error.png"} <= set(payload["files"])
    assert sorted(path.name for path in (tmp_path / "r").iterdir()) == payload["files"]
    assert [digest(path) for path in inputs] == before


@pytest.mark.parametrize(
    "argv, message",
    [
        ([], "nothing to report"),
        (["--calibration", "{calibration}"], "--calibration needs the --campaign and the --config"),
        (["--plan", "{missing}"], "file not found"),
        (["--geometry", "{calibration}"], "has the variable 'k2_q2' of a --calibration posterior"),
        (["--calibration", "{geometry}", "--campaign", "{campaign}", "--config", "{config}"], "has no variable 'k2_q2'"),
        (["--critique", "{campaign}"], "not valid JSON"),
        (["--plan", "{list_json}"], "expected a JSON object"),
    ],
)
def test_bad_input_is_one_line_and_status_2(capsys, short_calibration, tmp_path, argv, message):
    (tmp_path / "list.json").write_text("[1, 2]\n")
    names = {name: str(path) for name, path in short_calibration.items()} | {
        "missing": str(tmp_path / "nope.json"),
        "list_json": str(tmp_path / "list.json"),
    }
    status, out, err = run(capsys, [arg.format(**names) for arg in argv] + ["-o", str(tmp_path / "r")])
    assert status == 2 and out == ""
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "r").exists()


def test_the_garbage_collector_is_left_as_it_was_found(capsys, tmp_path):
    # The review pauses it while it reads and renders; a refused input, raised inside the pause, restores it too.
    import gc

    bad = tmp_path / "critique.json"
    bad.write_text("{not json\n")
    assert gc.isenabled()
    assert run(capsys, ["--critique", str(bad), "-o", str(tmp_path / "r")])[0] == 2
    assert gc.isenabled()
    gc.disable()
    try:
        assert run(capsys, ["--critique", str(bad), "-o", str(tmp_path / "r")])[0] == 2
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_bad_json_names_its_line_and_column(capsys, tmp_path):
    bad = tmp_path / "critique.json"
    bad.write_text('{\n  "verdict": "misfit",\n  "causes": [1, 2,]\n}\n')
    status, _, err = run(capsys, ["--critique", str(bad), "-o", str(tmp_path / "r")])
    assert status == 2 and "critique.json:3:" in err and "at character 19" in err, err


def test_a_posterior_of_another_campaign_is_refused(capsys, short_calibration, cell, tmp_path):
    campaign = read_campaign(short_calibration["campaign"], cell=cell)
    keep = np.flatnonzero(campaign.q[:, 1] > np.radians(-120.0))
    other = type(campaign)(**{name: getattr(campaign, name)[keep] for name in ("config", "repeat", "marker", "q", "wrench", "p0", "p1", "lines")})
    write_campaign(other, tmp_path / "other.csv")
    paths = short_calibration | {"campaign": tmp_path / "other.csv"}
    status, _, err = run(capsys, [*calibration_args(paths), "-o", str(tmp_path / "r")])
    assert status == 2 and "not one of this campaign" in err and "q2 angles" in err


def test_output_is_refused_when_it_is_an_input_a_file_or_has_no_parent(capsys, short_calibration, tmp_path):
    plan = tmp_path / "plan.json"
    plan.write_text((FIXTURES / "plan.json").read_text())
    status, _, err = run(capsys, ["--plan", str(plan), "-o", str(plan)])
    assert status == 2 and "is the --plan file this command reads; expected a folder" in err
    status, _, err = run(capsys, ["--plan", str(plan), "-o", str(tmp_path / "no" / "such")])
    assert status == 2 and "does not exist" in err
    # A report folder holding an input under a name the report writes: that input is not overwritten.
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / "numbers.json").write_text(plan.read_text())
    status, _, err = run(capsys, ["--plan", str(folder / "numbers.json"), "-o", str(folder)])
    assert status == 2 and "would destroy the input" in err
    assert (folder / "numbers.json").read_text() == plan.read_text()


def test_a_calibration_of_another_robot_is_refused(capsys, short_calibration, tmp_path):
    from bayescal.sampling.summary import load, save

    tree = load(short_calibration["calibration"])
    tree.attrs["robot"] = "another_arm"
    save(tree, tmp_path / "other.nc")
    paths = short_calibration | {"calibration": tmp_path / "other.nc"}
    status, _, err = run(capsys, [*calibration_args(paths), "-o", str(tmp_path / "r")])
    assert status == 2 and "the calibration is of robot 'another_arm'" in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "r").exists()
