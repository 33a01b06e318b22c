"""Controller programs written for the tests, from joints drawn on the KR-270, independently of the readers.

Poses come from Pinocchio's forward kinematics, angles and quaternions from SciPy's
``Rotation`` (KUKA's A, B, C as intrinsic Z-Y'-X'' angles), and the configuration
bits from the KR-270's own geometry (its URDF: the wrist point 55 mm below the line
of the forearm, so KUKA's status bit 1 turns at A3 = φ = -atan(55/1100)), so that a
reader or a solver built on a wrong convention disagrees with them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial.transform import Rotation

KR270_ELBOW_DEG = -math.degrees(math.atan2(0.055, 1.100))
"""A3 (deg) at which the KR-270's wrist point lies on the line from A2 to A3 (its URDF: A4 55 mm below, A5 1100 mm out)."""

SHOULDER_CLEARANCE = 0.2
"""Least distance (m) of the wrist point from axis 1: nearer, axis 1 is near its singularity and the status bit 0 near its flip."""

BASE_XYZABC = (1500.0, -300.0, 200.0, 30.0, 0.0, 0.0)
"""The program's base (a table): mm and deg."""

TOOL_XYZABC = (300.0, 0.0, 0.0, 0.0, -90.0, 0.0)
"""The program's tool: a spindle 300 mm out along the flange axis, its z along that axis."""


def frame(xyzabc) -> pin.SE3:
    x, y, z, a, b, c = xyzabc
    return pin.SE3(Rotation.from_euler("ZYX", [a, b, c], degrees=True).as_matrix(), np.array([x, y, z]) / 1000.0)


def abc(rotation) -> list[float]:
    return list(Rotation.from_matrix(rotation).as_euler("ZYX", degrees=True))


def wxyz(rotation) -> list[float]:
    x, y, z, w = Rotation.from_matrix(rotation).as_quat()
    return [w, x, y, z]


def draw_joints(n: int, rng: np.random.Generator) -> np.ndarray:
    """``(n, 6)`` machining configurations (deg) clear of every boundary of the configuration bits: no axis within
    2 deg of 0, axes 1, 4 and 6 2 deg clear of ABB's quadrant limits (multiples of 90 deg), A3 2 deg clear of the
    elbow angle, |A5| >= 20 deg."""
    low = np.array([-90.0, -130.0, -10.0, -160.0, 20.0, -160.0])
    high = np.array([90.0, -30.0, 100.0, 160.0, 100.0, 160.0])
    out = []
    while len(out) < n:
        q = rng.uniform(low, high)
        q[4] *= rng.choice([-1.0, 1.0])
        quadrant_edge = np.abs((q[[0, 3, 5]] + 45.0) % 90.0 - 45.0)
        if np.all(np.abs(q) > 2.0) and np.all(quadrant_edge > 2.0) and abs(q[2] - KR270_ELBOW_DEG) > 2.0:
            out.append(q)
    return np.array(out)


@dataclass
class Drawn:
    """Targets drawn for a program: names, joints (deg), poses in the program's base (SE3), wrenches (N, N·m)."""

    names: list[str]
    q_deg: np.ndarray
    poses: list
    wrench: np.ndarray
    status: list[int]
    turn: list[int]
    cfx: list[int]
    quadrants: list[list[int]]


def draw_targets(robot, n: int, rng: np.random.Generator) -> Drawn:
    model = robot.model
    data = model.createData()
    flange = model.getFrameId(robot.flange)
    base, tool = frame(BASE_XYZABC), frame(TOOL_XYZABC)
    q_deg = draw_joints(4 * n, rng)
    kept, poses, status, turn, cfx, quadrants = [], [], [], [], [], []
    for q in q_deg:
        pin.framesForwardKinematics(model, data, np.radians(q))
        wrist_in_a1 = data.oMi[1].actInv(data.oMi[5].translation)
        if abs(wrist_in_a1[0]) < SHOULDER_CLEARANCE or len(kept) == n:
            continue
        kept.append(q)
        poses.append(base.inverse() * data.oMf[flange] * tool)
        overhead = wrist_in_a1[0] < 0
        front = q[2] >= KR270_ELBOW_DEG
        status.append(int(overhead) + 2 * int(front) + 4 * int(q[4] <= 0))
        turn.append(sum(1 << j for j in range(6) if q[j] < 0))
        cfx.append(4 * int(overhead) + 2 * int(not front) + int(q[4] < 0))
        quadrants.append([math.floor(q[j] / 90.0) for j in (0, 3, 5)])
    q_deg = np.array(kept)
    direction = rng.normal(size=(n, 3))
    force = direction / np.linalg.norm(direction, axis=1, keepdims=True) * rng.uniform(200.0, 1500.0, (n, 1))
    moment = rng.uniform(-50.0, 50.0, (n, 3))
    return Drawn([f"P{i + 1}" for i in range(n)], q_deg, poses, np.column_stack([force, moment]), status, turn, cfx, quadrants)


def krl_texts(drawn: Drawn, *, home_deg=(0.0, -90.0, 90.0, 0.0, 45.0, 0.0), decimals: int = 4) -> tuple[str, str]:
    """A ``.src`` with BASE/TOOL frames, PTP/LIN/CIRC and non-motion statements, and its ``.dat``."""
    f = f".{decimals}f"
    dat = ["&ACCESS RVP", "DEFDAT  mill", ";FOLD EXTERNAL DECLARATIONS", ";ENDFOLD",
           "DECL FRAME TABLE={X %s,Y %s,Z %s,A %s,B %s,C %s}" % BASE_XYZABC,
           "DECL FRAME SPINDLE={X %s,Y %s,Z %s,A %s,B %s,C %s}" % TOOL_XYZABC,
           "DECL E6AXIS XHOME={A1 %s,A2 %s,A3 %s,A4 %s,A5 %s,A6 %s,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}" % home_deg,
           "DECL FDAT FP1={TOOL_NO 1,BASE_NO 1,IPO_FRAME #BASE}"]
    for name, pose, s, t in zip(drawn.names, drawn.poses, drawn.status, drawn.turn):
        x, y, z = pose.translation * 1000.0
        a, b, c = abc(pose.rotation)
        dat.append(f"DECL E6POS X{name}={{X {x:{f}},Y {y:{f}},Z {z:{f}},A {a:{f}},B {b:{f}},C {c:{f}},S {s},T {t},E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}}")
    dat.append("ENDDAT")
    src = ["&ACCESS RVP", "&REL 1", "DEF mill( )", ";FOLD INI", "BAS(#INITMOV,0)", ";ENDFOLD (INI)",
           "$TOOL = SPINDLE", "$BASE = TABLE", "PTP XHOME", "$VEL.CP = 0.2", "$APO.CDIS = 1.0"]
    i = 0
    names = drawn.names
    while i < len(names):
        kind = i % 7
        if kind == 3 and i + 1 < len(names):
            src.append(f"CIRC X{names[i]}, X{names[i + 1]} C_DIS")
            i += 2
            continue
        src.append(f"{'PTP' if kind == 0 else 'LIN'} X{names[i]}{' C_DIS' if kind in (1, 2) else ''}")
        if kind == 5:
            src.append("$OUT[3] = TRUE ; coolant")
        i += 1
    src += ["WAIT SEC 0.5", "PTP XHOME", "END"]
    return "\r\n".join(src) + "\r\n", "\r\n".join(dat) + "\r\n"


def rapid_text(drawn: Drawn, *, decimals: int = 4) -> str:
    """A RAPID module with a tool, a work object, MoveAbsJ/MoveJ/MoveL/MoveC and non-motion statements."""
    f = f".{decimals}f"
    x, y, z, *angles = BASE_XYZABC
    base = frame(BASE_XYZABC)
    tool = frame(TOOL_XYZABC)
    q = wxyz(base.rotation)
    tq = wxyz(tool.rotation)
    t = tool.translation * 1000.0
    lines = [
        "MODULE Mill",
        f"    PERS tooldata spindle:=[TRUE,[[{t[0]:.3f},{t[1]:.3f},{t[2]:.3f}],[{tq[0]:.9f},{tq[1]:.9f},{tq[2]:.9f},{tq[3]:.9f}]],[20,[0,0,100],[1,0,0,0],0,0,0]];",
        f"    TASK PERS wobjdata table:=[FALSE,TRUE,\"\",[[{x:.3f},{y:.3f},{z:.3f}],[{q[0]:.9f},{q[1]:.9f},{q[2]:.9f},{q[3]:.9f}]],[[0,0,0],[1,0,0,0]]];",
        "    CONST jointtarget home:=[[0,-90,90,0,45,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];",
    ]
    for name, pose, cfx, quadrants in zip(drawn.names, drawn.poses, drawn.cfx, drawn.quadrants):
        px, py, pz = pose.translation * 1000.0
        w, qx, qy, qz = wxyz(pose.rotation)
        lines.append(
            f"    CONST robtarget {name}:=[[{px:{f}},{py:{f}},{pz:{f}}],[{w:.6f},{qx:.6f},{qy:.6f},{qz:.6f}],"
            f"[{quadrants[0]},{quadrants[1]},{quadrants[2]},{cfx}],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];"
        )
    lines += ["    PROC main()", "        ConfL\\On;", "        MoveAbsJ home,v1000,fine,spindle;"]
    i = 0
    while i < len(drawn.names):
        kind = i % 7
        name = drawn.names[i]
        if kind == 3 and i + 1 < len(drawn.names):
            lines.append(f"        MoveC {name},{drawn.names[i + 1]},v100,z1,spindle\\WObj:=table;")
            i += 2
            continue
        lines.append(f"        {'MoveJ' if kind == 0 else 'MoveL'} {name},v200,z1,spindle\\WObj:=table;")
        if kind == 5:
            lines.append("        SetDO do_coolant,1; ! coolant")
        i += 1
    lines += ["        WaitTime 0.5;", "        MoveAbsJ home,v1000,fine,spindle;", "    ENDPROC", "ENDMODULE"]
    return "\n".join(lines) + "\n"


def wrench_csv(drawn: Drawn, prefix: str, home: str) -> str:
    """Each target's wrench, the targets named ``prefix`` + name; the ``home`` joint target unloaded."""
    rows = ["target,fx_N,fy_N,fz_N,mx_Nm,my_Nm,mz_Nm", f"{home},0,0,0,0,0,0"]
    rows += [",".join([prefix + name] + [f"{v:.3f}" for v in w]) for name, w in zip(drawn.names, drawn.wrench)]
    return "\n".join(rows) + "\n"


@pytest.fixture(scope="session")
def drawn(robot):
    """300 targets on the KR-270 (seed 38)."""
    return draw_targets(robot, 300, np.random.default_rng(38))


@pytest.fixture(scope="session")
def programs():
    """The writers of this module: ``draw_targets``, ``krl_texts``, ``rapid_text``, ``wrench_csv``."""
    from types import SimpleNamespace

    return SimpleNamespace(draw_targets=draw_targets, krl_texts=krl_texts, rapid_text=rapid_text, wrench_csv=wrench_csv)
