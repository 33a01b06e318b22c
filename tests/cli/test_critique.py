import json
from pathlib import Path

import pytest

from bayescal.cell.campaign import write_campaign
from bayescal.cli import main

CONFIG = str(Path(__file__).resolve().parents[2] / "data" / "kr270.toml")


@pytest.fixture(scope="module")
def campaign_files(twin_campaign, tmp_path_factory):
    folder = tmp_path_factory.mktemp("critique")
    paths = {}
    for name, effects in (("plain", []), ("backlash", ["backlash"])):
        paths[name] = folder / f"{name}.csv"
        write_campaign(twin_campaign(effects, seed=2), paths[name], comments=[f"twin, Table III, {name}"])
    return paths


def run(capsys, argv):
    status = main(["critique", *argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err

def _critique_of_twin(capsys, cell, plan, tmp_path, effect: str):
    """The twin's Table III campaign (3 repeats, seed [3, 39]) with one planted effect, written and criticised: its path,
    the exit status and the printed text."""
    import numpy as np

    from bayescal.twin.effects import parse_effect
    from bayescal.twin.simulator import DigitalTwin

    campaign = DigitalTwin(cell, [parse_effect(effect)]).simulate(plan, 3, np.random.default_rng(np.random.SeedSequence([3, 39])))
    path = tmp_path / "campaign.csv"
    write_campaign(campaign, path)
    status, out, _ = run(capsys, [str(path), "--config", CONFIG])
    return path, status, out


def test_json_names_the_planted_cause_and_the_gain(capsys, campaign_files, tmp_path):
    status, out, _ = run(capsys, [str(campaign_files["backlash"]), "--config", CONFIG, "--json", "--figures", str(tmp_path)])
    assert status == 0
    payload = json.loads(out)
    assert payload["verdict"] == "misfit" and payload["causes"][0] == "backlash"
    assert {"delta_elpd", "se"} <= set(payload["evidence"]["outliers"])
    assert payload["gain"]["before"]["residual_rms_mm"] > payload["gain"]["after"]["residual_rms_mm"]
    assert all(Path(path).is_file() for path in payload["figures"])


def test_text_says_adequate_without_causes(capsys, campaign_files):
    status, out, _ = run(capsys, [str(campaign_files["plain"]), "--config", CONFIG])
    assert status == 0
    assert "verdict: adequate" in out and "held-out gain" in out


def test_same_seed_gives_the_same_output(capsys, campaign_files):
    argv = [str(campaign_files["plain"]), "--config", CONFIG, "--json", "--seed", "3"]
    assert run(capsys, argv)[1] == run(capsys, argv)[1]


def test_bad_input_is_one_line_and_exit_2(capsys, campaign_files, tmp_path):
    status, out, err = run(capsys, [str(tmp_path / "missing.csv"), "--config", CONFIG])
    assert status == 2 and out == "" and len(err.strip().splitlines()) == 1 and "missing.csv" in err
    lines = campaign_files["plain"].read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if not line.startswith("#")) + 1
    fields = lines[first].split(",")
    fields[-3] = str(float(fields[-3]) + 1000.0)
    edited = tmp_path / "edited.csv"
    edited.write_text("\n".join(lines[:first] + [",".join(fields)] + lines[first + 1 :]) + "\n")
    status, _, err = run(capsys, [str(edited), "--config", CONFIG])
    assert status == 2 and "plausibly deflect" in err and "edited.csv:3" in err
    status, _, err = run(capsys, [str(campaign_files["plain"]), "--config", str(tmp_path / "none.toml")])
    assert status == 2 and "none.toml" in err


TABLE_I = str(Path(__file__).resolve().parents[2] / "data" / "table1_geometry.csv")


def test_geometry_json_has_the_critique_shape(capsys):
    status, out, _ = run(capsys, ["--geometry", TABLE_I, "--json"])
    assert status == 0
    payload = json.loads(out)
    assert payload["verdict"] in ("adequate", "misfit")
    assert set(payload["evidence"]) == {"tilt", "pivot_motion", "cylinder_slip", "joint_scale", "closed_loop"}
    assert {"delta_elpd", "se", "step", "named"} <= set(payload["evidence"]["tilt"])
    assert {"delta_elpd", "se", "before", "after"} <= set(payload["gain"])
    assert payload["gain"]["held_out"] == "leave-one-angle-out"


def test_geometry_text(capsys):
    status, out, _ = run(capsys, ["--geometry", TABLE_I])
    assert status == 0 and "verdict:" in out and "held-out gain" in out and "6 joint angles" in out


def test_geometry_figures_show_the_held_out_residuals(capsys, tmp_path):
    status, out, _ = run(capsys, ["--geometry", TABLE_I, "--figures", str(tmp_path / "figures"), "--json"])
    assert status == 0
    (path,) = json.loads(out)["figures"]
    assert path.endswith("geometry_residuals.png") and Path(path).stat().st_size > 10_000


@pytest.mark.parametrize(
    "argv, expected",
    [
        (["--geometry", "{tmp}/missing.csv"], "missing.csv"),
        (["--geometry", TABLE_I, "--config", CONFIG], "--geometry takes the points file only"),
        (["--geometry", "{tmp}/four.csv"], "at least 5"),
        ([], "expected a campaign CSV and --config"),
    ],
)
def test_geometry_bad_input_is_one_line_and_exit_2(capsys, tmp_path, argv, expected):
    lines = Path(TABLE_I).read_text().splitlines()
    keep = [line for line in lines if not line.startswith(("-120,", "-145,"))]
    (tmp_path / "four.csv").write_text("\n".join(keep) + "\n")
    before = Path(TABLE_I).read_text()
    status, out, err = run(capsys, [arg.replace("{tmp}", str(tmp_path)) for arg in argv])
    assert status == 2 and out == "" and len(err.strip().splitlines()) == 1 and expected in err, err
    assert Path(TABLE_I).read_text() == before


def test_a_contest_offers_the_plan_that_separates_that_pair_and_drift_says_how_to_become_testable(capsys, cell, plan, tmp_path):
    # the twin's Table III campaign whose nonlinear stiffness is contested by backlash (held out within 2 SE of it, their
    # fitted deflections apart by more than the plan's noise can hide: a tie until the plan's readings were summed)
    path, status, out = _critique_of_twin(capsys, cell, plan, tmp_path, "nonlinear_stiffness=0.2")
    assert status == 0
    assert "nonlinear_stiffness contested by backlash" in out
    assert f"--criterion discriminate --between nonlinear_stiffness,backlash --campaign {path}" in out
    assert "drift: not testable on this campaign" in out and "t0_s, t1_s" in out
    assert "test pose moved" in out and "> 25 nats and > 1 SE" in out


def test_a_detectable_cause_too_small_to_matter_is_said_so_in_the_verdict(capsys, cell, plan, tmp_path):
    # the twin's Table III campaign with 1 % gross readings (seed [3, 39]): the robust fit moves the test pose
    # by 3.0 μm against its sd of 5.4 μm
    _, status, out = _critique_of_twin(capsys, cell, plan, tmp_path, "outliers=0.01")
    assert status == 0
    assert "verdict: misfit - causes in order of gain: outliers (outliers detectable but too small to matter at the test pose)" in out
    assert "outliers is detectable on held-out configurations but too small to matter" in out.replace("\n", " ")


def test_the_help_names_every_candidate_of_both_catalogues(capsys):
    from bayescal.critique.extensions import CATALOGUE
    from bayescal.critique.geometry import GEOMETRY_CATALOGUE

    assert main(["critique", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert all(name in text for name in [*CATALOGUE, *GEOMETRY_CATALOGUE]) and "{" not in text
