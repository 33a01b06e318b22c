import numpy as np
import pytest

from bayescal.compensation.program import read_program
from bayescal.errors import InputError

HEADER = "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,fx_N,fy_N,fz_N,mx_Nm,my_Nm,mz_Nm"


def test_per_row_tool_points_and_other_columns_are_read(cell, tmp_path):
    path = tmp_path / "p.csv"
    path.write_text(
        "# drilling\n"
        f"op,{HEADER},tcp_x_mm,tcp_y_mm,tcp_z_mm\n"
        "N10,0,-50,80,0,-30,0,-800,0,0,0,0,12.5,400,0,50\n"
        "\n"
        "N20,10,-60,85,5,-40,15,-800,100,-50,0,0,0,350,10,0\n"
    )
    program = read_program(path, cell)
    assert list(program.lines) == [3, 5] and list(program.table["op"]) == ["N10", "N20"]
    assert program.tcp[0] == pytest.approx([0.4, 0.0, 0.05]) and program.tcp[1] == pytest.approx([0.35, 0.01, 0.0])
    assert program.q[1, 5] == pytest.approx(np.radians(15))
    # The moment about the tool point plus the force's moment about the flange origin.
    rotation = np.stack([cell.robot.flange_pose(q)[0] for q in program.q])
    flange = program.flange_wrench(rotation)
    assert flange[0, 5] == pytest.approx(12.5 + np.cross(rotation[0] @ program.tcp[0], program.wrench[0, :3])[2])


def test_without_tool_point_columns_the_cells_is_used(cell, tmp_path):
    path = tmp_path / "p.csv"
    path.write_text(f"{HEADER}\n0,-50,80,0,-30,0,-800,0,0,0,0,0\n")
    assert read_program(path, cell).tcp[0] == pytest.approx(cell.tool_point)


def test_a_missing_joint_column_names_it(cell, tmp_path):
    path = tmp_path / "p.csv"
    path.write_text(HEADER.replace("q6_deg,", "") + "\n0,-50,80,0,-30,-800,0,0,0,0,0\n")
    with pytest.raises(InputError, match="q6_deg"):
        read_program(path, cell)


@pytest.mark.parametrize(
    ("row", "message"),
    [
        ("0,-50,80,0,-30,0,-800000,0,0,0,0,0", r"p\.csv:3, column 'fx_N': a process force of 8e\+05 N is more than"),
        ("0,-50,80,0,-30,0,-800,0,0,0,0,12500", r"p\.csv:3, column 'mz_Nm': .* from the tool point, beyond any tool .* N·mm instead of N·m"),
    ],
)
def test_a_wrench_in_another_unit_is_refused_and_a_program_at_rest_is_not(cell, tmp_path, row, message):
    path = tmp_path / "p.csv"
    path.write_text(f"{HEADER}\n0,-50,80,0,-30,0,0,0,0,0,0,0\n{row}\n")
    with pytest.raises(InputError, match=message):
        read_program(path, cell)
    path.write_text(f"{HEADER}\n0,-50,80,0,-30,0,0,0,0,0,0,0\n")
    assert read_program(path, cell).wrench.sum() == 0
