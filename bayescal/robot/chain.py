"""The chain of a URDF that a calibration moves and identifies, and the joints it locks.

A URDF may describe more than the arm: a gripper's fingers, a second arm, a
rotary table.  The calibration moves and identifies one serial chain from the
base to the flange.  :func:`reduce_to_chain` keeps the joints the cell names (or,
when it names none, every joint on the path from the root to the flange) and
locks every other joint at a value the cell gives (default 0) with Pinocchio's
reduced models, so that the locked joints' bodies still weigh on the arm.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pinocchio as pin

from bayescal.errors import InputError

__all__ = ["joint_kind", "reduce_to_chain"]


def joint_kind(joint: pin.JointModel) -> str | None:
    """``"revolute"``, ``"prismatic"`` or ``None`` (any other kind) of a Pinocchio joint model."""
    name = joint.shortname()
    if joint.nq != 1 or joint.nv != 1:
        return None
    if name.startswith("JointModelR") and "Unbounded" not in name:
        return "revolute"
    if name.startswith("JointModelP"):
        return "prismatic"
    return None


def _path_to(model: pin.Model, frame: str) -> list[int]:
    """Ids of the joints from the root to the parent joint of ``frame``, base first."""
    parent = model.frames[model.getFrameId(frame)].parentJoint
    return [int(j) for j in model.supports[parent] if j > 0]


def _checked_names(model: pin.Model, joints: Sequence[str], path: list[int], flange: str, source: str | None) -> list[int]:
    """Ids of the named joints, checked to be movable one-coordinate joints on the path to the flange, in order."""
    names = list(model.names)
    ids = []
    for name in joints:
        if name not in names:
            known = ", ".join(names[j] for j in path)
            raise InputError(f"the URDF has no joint '{name}' (the path to '{flange}' has: {known})", source=source, column="robot.joints")
        ids.append(names.index(name))
    for name, joint_id in zip(joints, ids):
        if joint_id not in path:
            raise InputError(f"joint '{name}' is not on the path from the base to '{flange}'", source=source, column="robot.joints")
        if joint_kind(model.joints[joint_id]) is None:
            raise InputError(
                f"joint '{name}' is a {model.joints[joint_id].shortname()}; a chain joint must be revolute or prismatic "
                "(a 'continuous' joint has two coordinates: give it limits and type 'revolute')",
                source=source,
                column="robot.joints",
            )
    if len(set(ids)) != len(ids) or ids != sorted(ids, key=path.index):
        raise InputError(f"list the joints once each, from the base to '{flange}': {', '.join(joints)}", source=source, column="robot.joints")
    return ids


def _locked_configuration(model: pin.Model, locked: Mapping[str, tuple[float, str]], keep: list[int], source: str | None) -> np.ndarray:
    """The full model's configuration with each locked joint at its given value (SI), others at neutral."""
    q = pin.neutral(model)
    names = list(model.names)
    for name, (value, kind) in locked.items():
        key = "locked_mm" if kind == "prismatic" else "locked_deg"
        if name not in names:
            raise InputError(f"the URDF has no joint '{name}' to lock", source=source, column=f"robot.{key}")
        joint_id = names.index(name)
        if joint_id in keep:
            raise InputError(f"joint '{name}' is in the chain and cannot also be locked", source=source, column=f"robot.{key}")
        if joint_kind(model.joints[joint_id]) != kind:
            raise InputError(
                f"joint '{name}' is a {model.joints[joint_id].shortname()}, not a {kind} joint: "
                "list revolute joints in locked_deg and prismatic ones in locked_mm",
                source=source,
                column=f"robot.{key}",
            )
        q[model.joints[joint_id].idx_q] = value
    return q


def reduce_to_chain(
    model: pin.Model,
    flange: str,
    *,
    joints: Sequence[str] | None = None,
    locked: Mapping[str, tuple[float, str]] | None = None,
    source: str | None = None,
) -> pin.Model:
    """The model with only the chain's joints free, every other movable joint locked.

    Parameters
    ----------
    model
        The full model read from the URDF.
    flange
        The tool flange frame; the chain ends at its parent joint.
    joints
        Names of the chain's joints, base to flange.  ``None``: every joint on the path
        from the root to the flange, and then no movable joint may lie off that path.
    locked
        Joints to lock away from 0: name to (value, kind), the value in rad for a
        ``"revolute"`` joint and m for a ``"prismatic"`` one.  Any joint neither in the
        chain nor here is locked at 0.
    source
        The URDF, for error messages.

    Raises
    ------
    InputError
        A named joint that is missing, off the path, of another kind or out of order;
        without ``joints``, a movable joint off the path (naming the joints to list).
    """
    path = _path_to(model, flange)
    movable_off_path = [j for j in range(1, model.njoints) if j not in path and model.joints[j].nq > 0]
    if joints is None:
        if movable_off_path:
            chain = ", ".join(f'"{model.names[j]}"' for j in path)
            raise InputError(
                f"joint '{model.names[movable_off_path[0]]}' is not on the path from the base to '{flange}' and not fixed: "
                f"name the chain in the cell's [robot] joints = [{chain}]",
                source=source,
            )
        keep = path
    else:
        keep = _checked_names(model, joints, path, flange, source)
    for joint_id in keep:
        if joint_kind(model.joints[joint_id]) is None:
            raise InputError(
                f"joint '{model.names[joint_id]}' is a {model.joints[joint_id].shortname()}; every chain joint must be "
                "revolute or prismatic (a 'continuous' joint has two coordinates: give it limits and type 'revolute')",
                source=source,
            )
    to_lock = [j for j in range(1, model.njoints) if j not in keep and model.joints[j].nq > 0]
    if not to_lock:
        if locked:
            raise InputError(f"joint '{next(iter(locked))}' is in the chain and cannot also be locked", source=source, column="robot.locked_deg")
        return model
    reference = _locked_configuration(model, locked or {}, keep, source)
    return pin.buildReducedModel(model, to_lock, reference)
