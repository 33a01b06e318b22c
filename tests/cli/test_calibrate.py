import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bayescal.cell.campaign import read_campaign, write_campaign
from bayescal.cell.config import load_cell
from bayescal.cli import main
from bayescal.cell.plan import Plan, read_plan
from bayescal.sampling.summary import load
from bayescal.twin.simulator import DigitalTwin


@pytest.fixture(scope="module")
def config_toml(data_dir):
    return str(data_dir / "kr270.toml")


@pytest.fixture(scope="module")
def campaign_file(tmp_path_factory, config_toml, data_dir):
    cell = load_cell(config_toml)
    plan = read_plan(data_dir / "table3_plan.csv", cell.robot)
    campaign = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(1))
    path = tmp_path_factory.mktemp("cli") / "campaign.csv"
    write_campaign(campaign, path, comments=["twin, Table III, seed 1"])
    return path


@pytest.fixture(scope="module")
def json_run(campaign_file, tmp_path_factory, config_toml):
    posterior = tmp_path_factory.mktemp("post") / "posterior.nc"
    return posterior, [str(campaign_file), "--config", config_toml, "--json", "--draws", "100", "--posterior", str(posterior)]


def run(capsys, argv):
    status = main(["calibrate", *argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_json_output_has_every_parameter_with_units(capsys, json_run):
    posterior, argv = json_run
    status, out, err = run(capsys, argv)
    assert status == 0
    payload = json.loads(out)
    parameters = payload["parameters"]
    assert list(parameters) == ["k1", "k2", "k3", "k4", "k5", "k6", "K_c", "s0"]
    assert parameters["k1"]["identifiable"] is False and "joint 1" in parameters["k1"]["reason"]
    assert parameters["k3"]["unit"] == "urad/(N m)"
    assert parameters["k3"]["lo3"] < parameters["k3"]["mean"] < parameters["k3"]["hi3"]
    assert payload["diagnostics"]["n_equations"] == 405 and payload["diagnostics"]["model"] == "exact"
    lack_of_fit = payload["diagnostics"]["lack_of_fit"]
    # Table III: 15 configurations x 3 markers x 3 coordinates, each read 3 times: 270 pure-error degrees
    # of freedom, fewer in the reference matched to three directions weighted by their own pure error
    assert lack_of_fit["dof"][0] < 135 and 200 < lack_of_fit["dof"][1] < 2 * 135 and 0 < lack_of_fit["p_value"] <= 1
    assert payload["identifiability"]["not_identifiable"].keys() == {"k1", "K_c", "s0"}
    assert payload["identifiability"]["structural"] == ["k1"]
    assert parameters["K_c"]["identifiable"] is False and "includes 0" in parameters["K_c"]["reason"]
    assert payload["weakly_determined"]["K_c"]["unit"] == "N/mm" and "mean" in payload["weakly_determined"]["s0"]
    assert parameters["K_c"]["posterior"]["q_lo3"] < parameters["K_c"]["posterior"]["q_hi3"]
    assert "k1" in parameters and "posterior" not in parameters["k1"]
    assert all("mean" in entry for entry in payload["k2_per_angle"].values())
    assert payload["test_pose"]["residual_error_mm"]["rms"] > 0
    # the cell hangs masses only: in k1's reason, neither a parallel-loads warning nor a warning about k1
    assert "all loads are parallel" not in err and "hangs masses only" not in err and "warning: k1" not in err
    assert "hangs masses only" in parameters["k1"]["reason"]
    tree = load(posterior)
    assert tree["posterior"]["k3"].attrs["units"] == "urad/(N m)"
    assert tree["posterior"]["K_c"].attrs["units"] == "N/mm"


def test_text_output_sets_the_estimates_beside_table_iv(capsys, campaign_file, config_toml):
    status, out, _ = run(capsys, [str(campaign_file), "--config", config_toml, "--model", "linear", "--draws", "100"])
    assert status == 0
    assert "Table IV" in out and "linear model" in out
    rows = {line.split()[0]: line for line in out.splitlines() if line[:3] in ("k1 ", "k3 ", "K_c", "s0 ")}
    assert "not identifiable" in rows["k1"] and "not identifiable" in rows["K_c"] and "not identifiable" in rows["s0"]
    assert "21.5%" in rows["K_c"] and "0.4064" not in rows["K_c"]
    assert "not identifiable" not in rows["k3"]
    below = out[out.index("Not identifiable:") :]
    assert "  k1: no load" in below and "  K_c: the compensator changes" in below and "  s0: s0 enters" in below
    assert out.count("not identifiable: held") == 0 and out.count("k1, which this campaign cannot identify (prior: log-normal") == 1
    assert "everything counted" in out and "from the identified parameters alone" in out
    assert out.index("Not identifiable:") < out.index("Joint 2 with its compensator") < out.index("test pose")
    assert out.count("q2 = ") == 5
    assert "test pose" in out


def test_one_q2_angle_warns_and_still_reports_the_rest(capsys, campaign_file, tmp_path, config_toml):
    campaign = read_campaign(campaign_file)
    rows = np.isclose(campaign.q[:, 1], campaign.q[0, 1])
    lines = campaign_file.read_text().splitlines()
    kept = [line for line in lines if line.startswith("#")] + [lines[[i for i, l in enumerate(lines) if not l.startswith("#")][0]]]
    data = [line for line in lines if not line.startswith("#")][1:]
    kept += [line for line, keep in zip(data, rows) if keep]
    path = tmp_path / "one_angle.csv"
    path.write_text("\n".join(kept) + "\n")
    status, out, err = run(capsys, [str(path), "--config", config_toml, "--json", "--draws", "100"])
    assert status == 0
    payload = json.loads(out)
    assert payload["parameters"]["K_c"]["identifiable"] is False
    assert "mean" in payload["parameters"]["k3"]
    assert "k2, K_c, s0 are not identifiable: the campaign has 1 q2 angle(s)" in err
    assert payload["test_pose"]["available"] is False and "q2 = -50.00 deg" in payload["test_pose"]["reason"]


def edit(campaign_file, tmp_path, change):
    lines = campaign_file.read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if not line.startswith("#")) + 1
    lines = change(lines, first)
    path = tmp_path / "edited.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_duplicated_row_is_an_error(capsys, campaign_file, tmp_path, config_toml):
    path = edit(campaign_file, tmp_path, lambda lines, first: lines + [lines[first]])
    status, _, err = run(capsys, [str(path), "--config", config_toml])
    assert status == 2 and "already appears" in err


def test_nan_is_an_error(capsys, campaign_file, tmp_path, config_toml):
    def nan(lines, first):
        fields = lines[first].split(",")
        fields[-1] = "nan"
        return lines[:first] + [",".join(fields)] + lines[first + 1 :]

    status, _, err = run(capsys, [str(edit(campaign_file, tmp_path, nan)), "--config", config_toml])
    assert status == 2 and "z1_mm" in err


def test_implausible_deflection_is_an_error(capsys, campaign_file, tmp_path, config_toml):
    def metres(lines, first):
        fields = lines[first].split(",")
        fields[-3] = str(float(fields[-3]) + 1000.0)  # a loaded x a metre away
        return lines[:first] + [",".join(fields)] + lines[first + 1 :]

    status, _, err = run(capsys, [str(edit(campaign_file, tmp_path, metres)), "--config", config_toml])
    assert status == 2 and "plausibly deflect" in err and "edited.csv:3" in err


def relabel(label):
    def change(lines, first):
        fields = lines[first].split(",")
        fields[14] = label
        return lines[:first] + [",".join(fields)] + lines[first + 1 :]

    return change


def test_unknown_marker_is_an_error(capsys, campaign_file, tmp_path, config_toml):
    status, _, err = run(capsys, [str(edit(campaign_file, tmp_path, relabel("M9"))), "--config", config_toml])
    assert status == 2 and "unknown marker 'M9'" in err and "edited.csv:3, column 'marker'" in err


def test_swapped_marker_labels_are_an_error(capsys, campaign_file, tmp_path, config_toml):
    def swap(lines, first):
        a, b = lines[first].split(","), lines[first + 1].split(",")
        assert (a[14], b[14]) == ("M1", "M2")
        a[14], b[14] = b[14], a[14]
        return lines[:first] + [",".join(a), ",".join(b)] + lines[first + 2 :]

    status, _, err = run(capsys, [str(edit(campaign_file, tmp_path, swap)), "--config", config_toml])
    assert status == 2 and "mislabelled marker" in err and "column 'marker'" in err


# --------------------------------------------------------------------------- random perturbations through the CLI

_JUNK = st.sampled_from(["", "nan", "1e12", "-1e-3", "7_9.20", "abc", "0", "-0", "M9", "200", "1e400"])


@st.composite
def _perturbed_campaign(draw, lines):
    """A campaign's lines with one or two cells replaced by junk, a row dropped or duplicated, or a column renamed."""
    comments = [line for line in lines if line.startswith("#")]
    header, *rows = [line.split(",") for line in lines if not line.startswith("#")]
    for _ in range(draw(st.integers(1, 2))):
        kind = draw(st.sampled_from(["cell", "drop", "duplicate", "rename"]))
        row = draw(st.integers(0, len(rows) - 1))
        if kind == "cell":
            rows[row][draw(st.integers(0, len(header) - 1))] = draw(_JUNK)
        elif kind == "drop" and len(rows) > 1:
            del rows[row]
        elif kind == "duplicate":
            rows.insert(draw(st.integers(0, len(rows))), list(rows[row]))
        elif kind == "rename":
            header[draw(st.integers(0, len(header) - 1))] = draw(st.sampled_from(["q7_deg", "fx_kN", "x0_m", "config"]))
    return "\n".join(comments + [",".join(fields) for fields in [header, *rows]]) + "\n"


@pytest.mark.slow
@settings(max_examples=25, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_random_perturbations_of_a_small_campaign_never_give_a_traceback(capsys, tmp_path, data, config_toml, data_dir):
    # Four Table III configurations, one repeat: the smallest campaign the linear model still calibrates in seconds.
    cell = load_cell(config_toml)
    plan = read_plan(data_dir / "table3_plan.csv", cell.robot)
    small = Plan(q=plan.q[[0, 3, 6, 9]], load_kg=plan.load_kg[[0, 3, 6, 9]], lines=plan.lines[[0, 3, 6, 9]])
    campaign = DigitalTwin(cell).simulate(small, 1, np.random.default_rng(3))
    valid = tmp_path / "valid.csv"
    write_campaign(campaign, valid)
    path = tmp_path / "perturbed.csv"
    path.write_text(data.draw(_perturbed_campaign(valid.read_text().splitlines())))
    before = path.read_bytes()
    status, out, err = run(capsys, [str(path), "--config", config_toml, "--model", "linear", "--draws", "100", "--json"])
    assert status in (0, 2)
    if status == 2:
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    else:
        assert json.loads(out)["diagnostics"]["n_equations"] > 0
    assert path.read_bytes() == before
