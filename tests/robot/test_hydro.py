"""The hydro-pneumatic compensator law (bayescal.robot.hydro) and its cell, end to end."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from bayescal.cell.config import load_cell
from bayescal.cli import main
from bayescal.errors import InputError
from bayescal.inference.closedform import regress
from bayescal.robot.hydro import HydroCompensator
from bayescal.robot.stiffness import ElasticArm
from bayescal_studies.studies.elastostatic_coverage import Truth, fit_against_truth, random_plan
from bayescal.twin.simulator import DigitalTwin

ANGLES = np.radians(np.linspace(-150.0, 50.0, 41))


@pytest.fixture(scope="module")
def hydro_path(data_dir):
    return data_dir / "robots" / "kr270_hydro.toml"


@pytest.fixture(scope="module")
def hydro(hydro_path):
    return load_cell(hydro_path)


def test_the_cell_reads_a_hydro_pneumatic_compensator_with_its_own_keys(hydro, cell):
    law = hydro.compensator
    assert isinstance(law, HydroCompensator) and law.kind == "hydro"
    assert law.values == pytest.approx((20e3, 0.5)) and (law.n, law.s_ref) == pytest.approx((1.3, 0.6))
    # the linkage is the spring's: same line P0-P1
    np.testing.assert_allclose(law.s(ANGLES), cell.compensator.s(ANGLES))
    assert [p.name for p in law.PARAMETERS] == ["F0", "h0"]


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('kind = "hydro"', 'kind = "gas"', "'compensator.kind': unknown compensator kind 'gas'; expected one of hydro, spring"),
        ("F0_kN = 20.0", "F0_kN = 20.0\nK_c_N_per_mm = 144.0", "'compensator.K_c_N_per_mm': not a key of a 'hydro' compensator"),
        ("h0_mm = 500.0", "h0_mm = -5.0", "'compensator.h0_mm': expected a positive number in mm, got -5.0"),
        ("n_polytropic = 1.3\n", "", "missing key 'n_polytropic'"),
    ],
)
def test_a_wrong_compensator_table_is_one_line_naming_its_key(hydro_path, tmp_path, old, new, message):
    (tmp_path / "kr270.urdf").write_text((hydro_path.parent / "kr270.urdf").read_text())
    bad = tmp_path / "bad.toml"
    bad.write_text(hydro_path.read_text().replace(old, new))
    with pytest.raises(InputError) as error:
        load_cell(bad)
    assert "\n" not in str(error.value) and message in str(error.value)


def test_stiffness_is_the_derivative_of_the_torque(hydro):
    law = hydro.compensator
    for variant in (law, law.at(law.vector + [0.02, -0.05, 0.03, 0.1], (35e3, 0.35))):
        step = 1e-6
        numeric = (variant.torque(ANGLES + step) - variant.torque(ANGLES - step)) / (2 * step)
        np.testing.assert_allclose(variant.stiffness(ANGLES), numeric, rtol=1e-6, atol=1e-3)
        # the torque is the force along P0-P1 times ds/dq
        ds = (variant.s(ANGLES + step) - variant.s(ANGLES - step)) / (2 * step)
        np.testing.assert_allclose(variant.torque(ANGLES), variant.force(ANGLES) * ds, rtol=1e-6)


def test_the_regressor_reproduces_the_stiffness_and_is_its_gradient(hydro):
    law = hydro.compensator
    K0 = 3.3e6
    w = law.linear(law.values)
    np.testing.assert_allclose(law.regressor(ANGLES) @ [K0, *w], K0 + law.stiffness(ANGLES), rtol=1e-12)
    np.testing.assert_allclose(law.from_linear(w), law.values)
    # columns 1 and 2 are the derivatives in F0 (at fixed n F0/h0) and in n F0/h0 (at fixed F0)
    for i, step in ((0, 1.0), (1, 1.0)):
        moved = w.copy()
        moved[i] += step
        up = law.at(law.vector, law.from_linear(moved)).stiffness(ANGLES)
        moved[i] -= 2 * step
        down = law.at(law.vector, law.from_linear(moved)).stiffness(ANGLES)
        np.testing.assert_allclose(law.regressor(ANGLES)[:, i + 1], (up - down) / (2 * step), rtol=1e-5, atol=1e-9)
    jacobian = np.column_stack([(law.from_linear(w + d) - law.from_linear(w - d)) / 2e-3 for d in np.eye(2) * 1e-3])
    np.testing.assert_allclose(law.linear_jacobian(w), jacobian, rtol=1e-6)


def test_eq_34_regressed_again_recovers_a_gas_column_far_from_the_start(hydro):
    law = hydro.compensator
    truth = law.at(law.vector, (27e3, 0.38))
    angles = np.radians([-140.0, -100.0, -57.0, -25.0, 0.0])
    found = regress(law, angles, 3.3e6 + truth.stiffness(angles))
    np.testing.assert_allclose(found, [3.3e6, 27e3, 0.38], rtol=1e-8)


def test_the_compliance_gradient_is_that_of_the_equivalent_compliance(hydro):
    law, own = hydro.compensator, 0.302e-6
    effective = law.equivalent_compliance(ANGLES, own)
    gradient = law.compliance_gradient(ANGLES, effective)
    for i, step in enumerate((1.0, 1e-5)):
        values = np.array(law.values)
        values[i] += step
        up = law.at(law.vector, values).equivalent_compliance(ANGLES, own)
        values[i] -= 2 * step
        down = law.at(law.vector, values).equivalent_compliance(ANGLES, own)
        np.testing.assert_allclose(gradient[:, i], (up - down) / (2 * step), rtol=1e-5, atol=1e-22)


def test_the_twin_balances_the_arm_with_the_cylinders_torque(hydro, plan):
    silent = replace(hydro, tracker=replace(hydro.tracker, factor=0.0))
    twin = DigitalTwin(silent)
    points = np.array(list(hydro.markers.values()))
    q = plan.q[4]
    arm = ElasticArm.linear(hydro.robot, hydro.compliances, compensator=hydro.compensator, load_point=hydro.load_point, compensated_joint=1)
    bare = ElasticArm.linear(hydro.robot, hydro.compliances, load_point=hydro.load_point)
    theta = arm.equilibrium(q, np.zeros(6))
    # the batched solve of the twin and the one-configuration Newton solve agree
    np.testing.assert_allclose(twin.positions(q, 265.0)[0], hydro.robot.point_position(q + theta, points), atol=1e-12)
    # the cylinder lifts the arm by k2 times its torque (to first order in the deflection)
    lift = theta[1] - bare.equilibrium(q, np.zeros(6))[1]
    assert lift == pytest.approx(-hydro.compliances[1] * hydro.compensator.torque(q[1]), rel=0.02)
    campaign = twin.simulate(plan, 1, np.random.default_rng(0))
    assert len(campaign) == 3 * len(plan.q) and np.all(np.isfinite(campaign.p1))


def test_calibrate_identifies_the_cylinders_force_and_gas_column(hydro):
    rng = np.random.default_rng(3)
    truth = Truth(hydro.compliances * 1.05, (24e3, 0.46), 1.05)
    rows = {row["parameter"]: row for row in fit_against_truth(hydro, truth, rng, size=(6, 5, 2), noise_um=0.3)}
    for name, value in (("F0", 24.0), ("h0", 460.0)):
        assert rows[name]["identifiable"] and rows[name]["truth"] == pytest.approx(value)
        assert abs(rows[name]["z"]) < 4 and rows[name]["sd"] < 0.05 * value


def test_plan_critique_and_report_run_on_the_hydro_cell(hydro, hydro_path, tmp_path, capsys):
    plan = random_plan(hydro, 5, 3, np.random.default_rng(0))
    campaign = DigitalTwin(hydro).simulate(plan, 2, np.random.default_rng(1))
    from bayescal.cell.campaign import write_campaign

    write_campaign(campaign, tmp_path / "campaign.csv")
    config = ["--config", str(hydro_path)]
    assert main(["plan", *config, "--model", "linear", "--starts", "2", "-o", str(tmp_path / "plan.csv"), "--json"]) == 0
    planned = json.loads(capsys.readouterr().out)
    assert {"F0", "h0"} <= set(planned["parameters"]) and planned["parameters"]["F0"]["unit"] == "kN"
    (tmp_path / "plan.json").write_text(json.dumps(planned))
    assert main(["calibrate", str(tmp_path / "campaign.csv"), *config, "--posterior", str(tmp_path / "post.nc"), "--json"]) == 0
    calibrated = json.loads(capsys.readouterr().out)
    assert {"F0", "h0"} <= set(calibrated["parameters"]) and "K_c" not in calibrated["parameters"]
    assert main(["critique", str(tmp_path / "campaign.csv"), *config, "--json"]) == 0
    (tmp_path / "critique.json").write_text(capsys.readouterr().out)
    status = main(["report", "--calibration", str(tmp_path / "post.nc"), "--campaign", str(tmp_path / "campaign.csv"), *config,
                   "--plan", str(tmp_path / "plan.json"), "--critique", str(tmp_path / "critique.json"), "-o", str(tmp_path / "r")])
    assert status == 0, capsys.readouterr().err
    summary = (tmp_path / "r" / "summary.md").read_text()
    assert "F0 in kN, h0 in mm" in summary and "joint2_compliance.png" in summary and "eta.png" not in summary
