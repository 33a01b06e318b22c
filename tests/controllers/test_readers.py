"""The KRL and RAPID readers: what they take, what they keep byte for byte, and what they refuse."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bayescal.controllers.krl import read_krl, write_krl
from bayescal.controllers.poses import kuka_angles, kuka_rotation, quaternion_rotation, rotation_quaternion
from bayescal.controllers.rapid import read_rapid, write_rapid
from bayescal.errors import InputError


def test_kuka_angles_and_quaternions_follow_the_controllers_conventions():
    rng = np.random.default_rng(0)
    reference = Rotation.random(200, random_state=rng)
    abc = reference.as_euler("ZYX", degrees=True)
    assert np.allclose(kuka_rotation(abc), reference.as_matrix(), atol=1e-12)
    assert np.allclose(kuka_rotation(kuka_angles(reference.as_matrix())), reference.as_matrix(), atol=1e-12)
    xyzw = reference.as_quat()
    wxyz = np.column_stack([xyzw[:, 3], xyzw[:, :3]])
    assert np.allclose(quaternion_rotation(wxyz), reference.as_matrix(), atol=1e-12)
    back = rotation_quaternion(reference.as_matrix())
    assert np.allclose(np.abs(np.einsum("ni,ni->n", back, wxyz)), 1.0, atol=1e-12) and (back[:, 0] >= 0).all()


def _krl(tmp_path, programs, drawn):
    src, dat = programs.krl_texts(drawn)
    (tmp_path / "mill.src").write_bytes(src.encode())
    (tmp_path / "mill.dat").write_bytes(dat.encode())
    return tmp_path / "mill.src"


def test_krl_reads_targets_frames_and_counts_what_it_passes_through(tmp_path, programs, drawn):
    program = read_krl(_krl(tmp_path, programs, drawn))
    assert len(program.targets) == 301 and program.targets[0].name == "XHOME" and not program.targets[0].cartesian
    # PTP/LIN/CIRC lines of the test program, and its BAS(#INITMOV), $VEL, $APO, WAIT and $OUT statements.
    src = (tmp_path / "mill.src").read_text()
    motions = sum(line.split(" ")[0] in ("PTP", "LIN", "CIRC") for line in src.splitlines())
    assert program.motions == motions
    assert program.unsupported == 4 + src.count("$OUT[3]")
    first = program.targets[1]
    assert first.configuration == {"S": drawn.status[0], "T": drawn.turn[0]}
    assert np.allclose(first.tool[1], [0.3, 0.0, 0.0]) and np.allclose(first.base[1], [1.5, -0.3, 0.2])
    texts = write_krl(program, {}, 4)
    assert texts["src"].encode("latin-1") == (tmp_path / "mill.src").read_bytes()
    assert texts["dat"].encode("latin-1") == (tmp_path / "mill.dat").read_bytes()


def test_rapid_reads_targets_tool_and_work_object(tmp_path, programs, drawn):
    path = tmp_path / "mill.mod"
    path.write_bytes(programs.rapid_text(drawn).encode())
    program = read_rapid(path)
    assert len(program.targets) == 301 and program.targets[0].name == "home"
    assert program.unsupported == 2 + path.read_text().count("SetDO")
    target = program.targets[1]
    assert target.configuration == dict(zip(("cf1", "cf4", "cf6", "cfx"), [*drawn.quadrants[0], drawn.cfx[0]]))
    assert target.tool_name == "spindle" and target.base_name == "table"
    assert write_rapid(program, {}, 4)["mod"].encode("latin-1") == path.read_bytes()


KRL_DAT = "DEFDAT t\nDECL FRAME B1={X 0,Y 0,Z 0,A 0,B 0,C 0}\nDECL E6POS XP1={X 1000,Y 0,Z 1500,A 0,B 90,C 0,S 2,T 0}\n{extra}ENDDAT\n"
KRL_SRC = "DEF t( )\n$TOOL = $NULLFRAME\n$BASE = B1\n{motion}\nEND\n"


@pytest.mark.parametrize(
    "motion, extra, line, expected",
    [
        ("LIN XP2", "DECL E6POS XP2={X 1000,Y 0,Z 1500,A 0,B 90,C 0}\n", 4, "without 'S' and 'T'"),
        ("LIN_REL XP1", "", 4, "'LIN_REL' is not supported"),
        ("LIN {X 1,Y 2,Z 3,A 0,B 0,C 0}", "", 4, "inline target is not supported"),
        ("LIN XP9", "", 4, "not a target declared"),
        ("$TOOL = TOOL_DATA[1]", "", 4, "not a FRAME literal"),
        ("BAS(#TOOL,1)", "", 4, "is not supported"),
        ("LIN XP1 C_DIS, junk", "", 4, "unexpected 'junk'"),
    ],
)
def test_krl_errors_name_the_file_and_line(tmp_path, motion, extra, line, expected):
    (tmp_path / "t.src").write_text(KRL_SRC.replace("{motion}", motion))
    (tmp_path / "t.dat").write_text(KRL_DAT.replace("{extra}", extra))
    with pytest.raises(InputError, match=expected) as error:
        read_krl(tmp_path / "t.src")
    assert error.value.line == line and error.value.source.endswith(".src" if "XP2" not in extra else ".dat")


def test_krl_without_its_data_file_is_named(tmp_path):
    (tmp_path / "t.src").write_text(KRL_SRC.replace("{motion}", "LIN XP1"))
    with pytest.raises(InputError, match="t.dat is not beside it"):
        read_krl(tmp_path / "t.src")


RAPID = """MODULE m
    PERS tooldata t1:=[TRUE,[[0,0,300],[1,0,0,0]],[20,[0,0,100],[1,0,0,0],0,0,0]];
    PERS wobjdata w1:=[FALSE,TRUE,"",[[1000,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
    CONST robtarget p1:=[[500,0,1000],{quaternion},[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    PROC main()
        {move}
    ENDPROC
ENDMODULE
"""


@pytest.mark.parametrize(
    "quaternion, move, line, expected",
    [
        ("[0,1,0,0]", "MoveL p1,v100,z1,t1\\WObj:=w2;", 6, "work object 'w2' is not declared"),
        ("[0,90,0,0]", "MoveL p1,v100,z1,t1\\WObj:=w1;", 4, "norm 90, not 1"),
        ("[0,1,0,0]", "MoveL Offs(p1,0,0,10),v100,z1,t1;", 6, "inline target or a function"),
        ("[0,1,0,0]", "MoveLDO p1,v100,z1,t1,do1,1;", 6, "'MoveLDO' is not supported"),
        ("[0,1,0,0]", "MoveL p1,v100,z1,t9;", 6, "tool 't9' is not declared"),
    ],
)
def test_rapid_errors_name_the_file_and_line(tmp_path, quaternion, move, line, expected):
    path = tmp_path / "m.mod"
    path.write_text(RAPID.replace("{quaternion}", quaternion).replace("{move}", move))
    with pytest.raises(InputError, match=expected) as error:
        read_rapid(path)
    assert error.value.line == line and error.value.source == str(path)


def test_a_target_moved_to_in_two_work_objects_is_refused(tmp_path):
    path = tmp_path / "m.mod"
    two = "MoveL p1,v100,z1,t1\\WObj:=w1;\n        MoveL p1,v100,z1,t1;"
    path.write_text(RAPID.replace("{quaternion}", "[0,1,0,0]").replace("{move}", two))
    with pytest.raises(InputError, match="declare a target per frame") as error:
        read_rapid(path)
    assert error.value.line == 7
