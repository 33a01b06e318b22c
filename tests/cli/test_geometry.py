import json

import pytest

from bayescal.sampling import summary as posterior
from bayescal.cli import main

LIGHT = ["--chains", "2", "--tune", "200", "--draws", "150"]


@pytest.fixture(scope="module")
def table1_csv(data_dir):
    return str(data_dir / "table1_geometry.csv")


@pytest.fixture(scope="module")
def good(table1_csv):
    """Table I's file as text, for the bad-input cases to spoil."""
    with open(table1_csv, encoding="utf-8") as handle:
        return handle.read()


def run_json(capsys, table1_csv, *args):
    assert main(["geometry", table1_csv, "--json", *LIGHT, *args]) == 0
    return json.loads(capsys.readouterr().out)


def test_json_output_has_parameters_diagnostics_and_residuals(capsys, table1_csv):
    payload = run_json(capsys, table1_csv)
    for name in ("L", "a_x", "a_y"):
        block = payload["parameters"][name]
        assert set(block) == {"mean", "sd", "lo3", "hi3", "q_lo3", "q_hi3", "unit"}
        assert block["unit"] == "mm"
    assert payload["parameters"]["phi"]["unit"] == "deg"
    assert abs(payload["parameters"]["L"]["mean"] - 184.72) < 0.03
    assert {"r_hat_max", "ess_bulk_min"} <= set(payload["diagnostics"])
    assert set(payload["residuals_rms_mm"]) == {"P1", "P01", "P02"}
    assert 0.01 < payload["residuals_rms_mm"]["P1"] < 0.2
    assert payload["arc_sense"] == "clockwise"
    assert payload["paper"]["a_y"]["value"] == 120.30
    assert payload["paper"]["a_y"]["hi3"] == pytest.approx(120.99)


def test_same_seed_gives_identical_output(capsys, table1_csv):
    assert run_json(capsys, table1_csv, "--seed", "3") == run_json(capsys, table1_csv, "--seed", "3")


def test_text_output_sets_table2_beside(capsys, table1_csv):
    assert main(["geometry", table1_csv, *LIGHT]) == 0
    text = capsys.readouterr().out
    assert "Table II" in text
    assert "184.72" in text
    assert "reflection" in text
    assert "R-hat max" in text


def test_text_rounds_every_row_to_its_sd_as_the_json_gives_it(capsys, table1_csv):
    from bayescal.numbers import decimals_of, rounded_pair

    payload = run_json(capsys, table1_csv)
    assert main(["geometry", table1_csv, *LIGHT]) == 0
    rows = {line.split()[0]: line.split() for line in capsys.readouterr().out.splitlines() if line.split()}
    for name, block in payload["parameters"].items():
        mean, sd = rounded_pair(block["mean"], block["sd"])
        places = decimals_of(block["sd"])
        assert rows[name][2:6] == [mean, sd, f"{block['lo3']:.{places}f}", f"{block['hi3']:.{places}f}"], name


def test_posterior_is_saved(capsys, tmp_path, table1_csv):
    path = tmp_path / "geometry.nc"
    payload = run_json(capsys, table1_csv, "--posterior", str(path))
    tree = posterior.load(path)
    assert tree["posterior"]["a_x"].attrs["units"] == "mm"
    assert float(tree["posterior"]["L"].mean()) == pytest.approx(payload["parameters"]["L"]["mean"])


def test_rigid_cylinder_model_option(capsys, table1_csv):
    payload = run_json(capsys, table1_csv, "--cylinder-model", "rigid")
    assert payload["cylinder_model"] == "rigid"
    assert "delta[P01]" in payload["parameters"]


def write(tmp_path, text):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize(
    ("spoil", "fragment"),
    [
        (lambda good: good.replace("q2_deg,marker,x_mm,y_mm", "q2_deg,marker,x_mm,ymm"), "missing column 'y_mm'"),
        (lambda good: good.replace("-118.44", "nan"), "column 'x_mm'"),
        (
            lambda good: "q2_deg,marker,x_mm,y_mm\n" + "\n".join(line for line in good.splitlines() if line.startswith(("-0.01", "-30"))),
            "at least 3",
        ),
        (lambda good: good.replace("-872.30,-126.07", "-872.10,-125.38").replace("-872.50,-109.90", "-872.10,-125.38")
         .replace("-868.43,-78.20", "-872.10,-125.38").replace("-858.90,-47.60", "-872.10,-125.38")
         .replace("-852.53,-33.68", "-872.10,-125.38"), "identical"),
        (lambda good: "\n".join(line for line in good.splitlines() if "P02" not in line or line.startswith("-0.01")), "marker P02 has 1 point"),
        (lambda good: good.replace("-813.33", "abc"), "got 'abc'"),
    ],
    ids=["missing-column", "nan", "few-angles", "identical", "one-point", "text"],
)
def test_bad_input_exits_2_with_one_line(capsys, tmp_path, good, spoil, fragment):
    path = write(tmp_path, spoil(good))
    assert main(["geometry", path, *LIGHT]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("bayescal geometry: error: ")
    assert path in lines[0]
    assert fragment in lines[0]


def test_missing_reference_file_is_an_input_error(capsys, tmp_path, table1_csv):
    assert main(["geometry", table1_csv, *LIGHT, "--reference", str(tmp_path / "none.csv")]) == 2
    assert "file not found" in capsys.readouterr().err


def test_one_chain_is_refused(capsys, table1_csv):
    assert main(["geometry", table1_csv, "--chains", "1"]) == 2
    assert "at least 2 chains" in capsys.readouterr().err


def _rows(good, keep):
    lines = [line for line in good.splitlines() if line and not line.startswith("#")]
    return "\n".join([lines[0], *(line for line in lines[1:] if keep(line))]) + "\n"


def test_points_that_leave_the_noise_unestimable_exit_2(capsys, tmp_path, good):
    # three angles of P1 and one cylinder marker: the concentric arc fits exactly
    text = _rows(good, lambda line: line.split(",")[0] in ("-0.01", "-30", "-60") and line.split(",")[1] in ("P1", "P01"))
    assert main(["geometry", write(tmp_path, text), *LIGHT]) == 2
    assert "noise cannot be estimated" in capsys.readouterr().err


def test_angles_in_radians_exit_2_with_a_hint(capsys, tmp_path, good):
    lines = _rows(good, lambda line: True).splitlines()
    radians = [lines[0]] + [",".join([f"{float(f[0]) * 3.14159265 / 180:.5f}", *f[1:]]) for f in (line.split(",") for line in lines[1:])]
    assert main(["geometry", write(tmp_path, "\n".join(radians) + "\n"), *LIGHT]) == 2
    assert "are q2 in deg" in capsys.readouterr().err


def test_non_numeric_draws_is_a_usage_error_on_one_line(capsys, table1_csv):
    assert main(["geometry", table1_csv, "--draws", "abc"]) == 2
    err = capsys.readouterr().err
    assert "argument --draws: expected a whole number >= 1, got 'abc'" in err and len(err.strip().splitlines()) == 1


def test_the_command_imports_no_heavy_library_it_does_not_use(tmp_path, table1_csv, modules_loaded_by):
    # ArviZ's statistics, emcee and SciPy (through scipy.stats) cost about 2 s of start-up, Pinocchio
    # (through the simulate parser) a few tenths: longer than the whole fit.
    heavy = ("arviz", "arviz_base", "arviz_stats", "emcee", "scipy", "pinocchio", "matplotlib")
    assert modules_loaded_by(["geometry", table1_csv, "--json", "--posterior", tmp_path / "g.nc"], heavy) == []
