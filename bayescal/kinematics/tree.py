"""Forward kinematics of a kinematic tree for many configurations at once, with corrected joint placements.

Pinocchio computes one configuration per call; a calibration evaluates hundreds
of configurations per step, and the Python cost of each call would set its time.
:class:`BatchedTree` reads the tree from the Pinocchio model once (each joint's
parent, its placement in the parent body, the bodies' masses and centres of
mass) and composes, for ``N`` configurations in one pass of array operations,

    oMi[j] = oMi[parent(j)] · placement[j] · correction[j] · Rz(q[j]),

where ``correction[j]`` is a small rigid transform the calibration identifies
(the 6-D joint placement correction: its rotation about the joint's z axis is the
joint offset θ, its translation along z the DH d, across z the DH r; its
rotations across z the DH α and β).  Every joint is revolute about its own z
axis, as a URDF written from a DH table has it; the tests check the result
against Pinocchio's ``forwardKinematics``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from bayescal.errors import InputError

__all__ = ["BatchedTree", "TreeFrames", "rotations_z", "skew"]

_AXIS_TOLERANCE = 1e-12
"""How far (unit vector components) a joint's axis may be from its frame's z axis."""


def skew(v: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` cross-product matrices of ``(..., 3)`` vectors: ``skew(a) @ b == a × b``."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def rotations_z(angle: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` rotations about z by ``angle`` (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(angle) + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1] = c, -s, s, c
    out[..., 2, 2] = 1.0
    return out


@dataclass(frozen=True)
class TreeFrames:
    """The joint frames of ``N`` configurations, in the robot's base frame (m).

    Attributes
    ----------
    rotation, origin : numpy.ndarray
        ``(N, nj, 3, 3)`` and ``(N, nj, 3)``: each joint's frame after its rotation
        (index 0, the base, is the identity).
    before : numpy.ndarray
        ``(N, nj, 3, 3)``: each joint's frame before its rotation (the frame its
        placement correction acts in; same origin).
    """

    rotation: np.ndarray
    origin: np.ndarray
    before: np.ndarray


class BatchedTree:
    """A Pinocchio model's tree of revolute joints, evaluated for many configurations at once.

    Parameters
    ----------
    model
        The Pinocchio model; every joint revolute about its own z axis.
    source
        Where the model came from, for error messages.

    Attributes
    ----------
    nj : int
        Number of joints, the universe (index 0) included.
    parents : tuple of int
        Each joint's parent joint index.
    names : tuple of str
        Each joint's name (``names[0] == "universe"``).
    placement_rotation, placement_translation : numpy.ndarray
        ``(nj, 3, 3)``, ``(nj, 3)`` each joint's nominal placement in its parent body.
    mass : numpy.ndarray
        ``(nj,)`` each joint's body mass (kg), from the URDF.
    com : numpy.ndarray
        ``(nj, 3)`` each body's centre of mass in its joint frame (m).
    supports : tuple of tuple of int
        Each joint's path from the root, itself last, the universe left out.
    source : str or None
    """

    def __init__(self, model: pin.Model, *, source: str | None = None) -> None:
        data = model.createData()
        pin.forwardKinematics(model, data, pin.neutral(model))
        for j in range(1, model.njoints):
            joint = model.joints[j]
            axis = np.asarray(data.joints[j].S).reshape(-1)[3:] if joint.nv == 1 else None
            if joint.nq != 1 or axis is None or np.abs(axis - [0.0, 0.0, 1.0]).max() > _AXIS_TOLERANCE:
                raise InputError(
                    f"joint '{model.names[j]}' is a {joint.shortname()}; the kinematic calibration takes revolute "
                    "joints about their frame's z axis (write the URDF's joint with axis 0 0 1 and turn its origin)",
                    source=source,
                )
        self.model = model
        self.source = source
        self.nj = int(model.njoints)
        self.parents = tuple(int(p) for p in model.parents)
        self.names = tuple(str(n) for n in model.names)
        self.idx_q = np.array([0] + [model.joints[j].idx_q for j in range(1, self.nj)])
        self.placement_rotation = np.array([np.array(p.rotation) for p in model.jointPlacements])
        self.placement_translation = np.array([np.array(p.translation) for p in model.jointPlacements])
        self.mass = np.array([model.inertias[j].mass for j in range(self.nj)])
        self.com = np.array([np.array(model.inertias[j].lever) for j in range(self.nj)])
        self.supports = tuple(tuple(int(i) for i in model.supports[j] if i > 0) for j in range(self.nj))
        # Read on every prediction of every elastic joint: computed once here.
        self._subtrees = tuple(tuple(k for k in range(1, self.nj) if j in self.supports[k]) for j in range(self.nj))

    def subtree(self, joint: int) -> tuple[int, ...]:
        """The joints whose bodies ``joint`` carries, itself included."""
        return self._subtrees[joint]

    def frames(self, q: np.ndarray, corrections: dict[int, pin.SE3] | None = None) -> TreeFrames:
        """The joint frames of ``N`` configurations.

        Parameters
        ----------
        q
            ``(N, nq)`` the model's joint positions (rad), in Pinocchio's ``idx_q`` order.
        corrections
            Joint index to a placement correction right-multiplied on its nominal placement.

        Returns
        -------
        TreeFrames
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        n = q.shape[0]
        corrections = corrections or {}
        rotation = np.empty((n, self.nj, 3, 3))
        origin = np.empty((n, self.nj, 3))
        before = np.empty((n, self.nj, 3, 3))
        rotation[:, 0], origin[:, 0], before[:, 0] = np.eye(3), 0.0, np.eye(3)
        for j in range(1, self.nj):
            place_r, place_t = self.placement_rotation[j], self.placement_translation[j]
            if j in corrections:
                fix = corrections[j]
                place_t = place_t + place_r @ np.array(fix.translation)
                place_r = place_r @ np.array(fix.rotation)
            parent = self.parents[j]
            before[:, j] = rotation[:, parent] @ place_r
            origin[:, j] = origin[:, parent] + rotation[:, parent] @ place_t
            rotation[:, j] = before[:, j] @ rotations_z(q[:, self.idx_q[j]])
        return TreeFrames(rotation=rotation, origin=origin, before=before)
