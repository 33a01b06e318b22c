"""The robot's frames in the tracker frame, built from the fitted axes of joints 1 and 2.

Two frames, each as ``p_tracker = R p_frame + t``:

* the paper's frame (Klimchik et al., Section IV.A): origin at the foot on
  axis 2 of the common perpendicular of axes 1 and 2, Z along axis 2, Y along
  axis 1 made perpendicular to Z, X = Y × Z.  Two non-parallel axes fix it
  whole.
* the URDF's base frame: the URDF's axes 1 and 2 at the sweep's home angles
  (directions and common perpendicular) are turned onto the fitted ones (the
  least-squares rotation of the two directions and their cross product) and
  the URDF's foot on axis 1 is placed on the fitted one.  The sweeps cannot fix
  where the base origin sits along axis 1 (its height) nor the joint-1 zero
  (the frame's turn about axis 1 is that of the home angle ``q1``): both come
  from the URDF's nominal geometry.

Uncertainty by sampling Gaussians with the axes' covariances (:class:`AxisFit.cov`):
each draw rebuilds the frames; the rotation's spread is that of the rotation
vector of ``R_draw R̂ᵀ``.  Each component's degrees of freedom are Welch and
Satterthwaite's over the two axes' sandwiches, the component linearised in the
axes (:func:`_component_dof`); its intervals are Student-t's at them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from bayescal.errors import InputError
from bayescal.registration.axes import INTERVAL_NOTE, AxisFit
from bayescal.registration.robust import combined_dof, interval_factor, sandwich_dof
from bayescal.robot.kinematics import Robot
from bayescal.units import MM

__all__ = ["Frame", "common_perpendicular", "paper_frame", "base_frame", "draw_axis", "frames_with_uncertainty", "urdf_axes"]

_PARALLEL = 1e-3
"""Smallest sine of the angle between axes 1 and 2 for which their common perpendicular is defined."""


@dataclass(frozen=True)
class Frame:
    """A frame in the tracker frame: ``p_tracker = rotation @ p_frame + translation``.

    Attributes
    ----------
    name
        ``"paper"`` or ``"base"``.
    rotation
        (3, 3) rotation matrix.
    translation
        (3,) frame origin in the tracker frame, m.
    rotation_cov
        (3, 3) covariance of the rotation vector of ``R_true R̂ᵀ`` (tracker axes), rad².
    translation_cov
        (3, 3) covariance of the translation, m².
    from_nominal
        What the sweeps cannot fix and where it comes from instead.
    rotation_dof, translation_dof
        (3,) degrees of freedom of each component's sd (``inf``: a normal's), from which its intervals' Student-t
        quantiles come; None when not known (a file written before they were).
    """

    name: str
    rotation: np.ndarray
    translation: np.ndarray
    rotation_cov: np.ndarray
    translation_cov: np.ndarray
    from_nominal: str
    rotation_dof: np.ndarray | None = None
    translation_dof: np.ndarray | None = None

    def from_tracker(self, points) -> np.ndarray:
        """(..., 3) tracker-frame points, m -> this frame, m (``Rᵀ (p - t)``)."""
        return (np.asarray(points, dtype=float) - self.translation) @ self.rotation

    def to_json(self) -> dict:
        """A JSON-ready dictionary, units in the keys."""
        return {
            "rotation": self.rotation.tolist(),
            "translation_mm": (self.translation / MM).tolist(),
            "rotation_sd_mrad": (np.sqrt(np.diag(self.rotation_cov)) * 1e3).tolist(),
            "translation_sd_mm": (np.sqrt(np.diag(self.translation_cov)) / MM).tolist(),
            "rotation_cov_mrad2": (self.rotation_cov * 1e6).tolist(),
            "translation_cov_mm2": (self.translation_cov / MM**2).tolist(),
            "from_nominal": self.from_nominal,
            **self._intervals(),
        }

    def _intervals(self) -> dict:
        """Each component's degrees of freedom (null: a normal's) and half-widths at the normal's ±1/2/3 sd coverage."""
        if self.rotation_dof is None or self.translation_dof is None:
            return {}
        out = {"interval": INTERVAL_NOTE}
        for key, dof, sd in (("rotation", self.rotation_dof, np.sqrt(np.diag(self.rotation_cov)) * 1e3),
                             ("translation", self.translation_dof, np.sqrt(np.diag(self.translation_cov)) / MM)):
            unit = "mrad" if key == "rotation" else "mm"
            out[f"{key}_dof"] = [float(v) if np.isfinite(v) else None for v in dof]
            out[f"{key}_half_width_{unit}"] = {str(k): (interval_factor(k, dof) * sd).tolist() for k in (1, 2, 3)}
        return out


def common_perpendicular(a1, c1, a2, c2) -> tuple[np.ndarray, np.ndarray]:
    """Feet (3,), (3,) on lines 1 and 2 of their common perpendicular; lines are (unit direction, point)."""
    w = c1 - c2
    b, d, e = a1 @ a2, a1 @ w, a2 @ w
    denominator = 1.0 - b * b
    if denominator < _PARALLEL**2:
        raise InputError(f"axes 1 and 2 are parallel within {_PARALLEL * 1e3:g} mrad: their common perpendicular is not defined",
                         source="sweeps")
    s = (b * e - d) / denominator
    t = (e - b * d) / denominator
    return c1 + s * a1, c2 + t * a2


def paper_frame(a1, c1, a2, c2) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (3, 3) and origin (3,) of the paper's frame from axes 1 and 2 (tracker frame)."""
    _, foot2 = common_perpendicular(a1, c1, a2, c2)
    z = a2
    y = a1 - (a1 @ z) * z
    y /= np.linalg.norm(y)
    return np.column_stack([np.cross(y, z), y, z]), foot2


def urdf_axes(robot: Robot, q: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(unit direction, point) in the base frame of joints 1 and 2 at angles ``q`` (rad), from the URDF."""
    import pinocchio as pin

    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, np.asarray(q, dtype=float))
    axes = []
    for j in (1, 2):
        placement = data.oMi[j]
        axes.append((placement.rotation @ _joint_axis(robot, j), placement.translation.copy()))
    return axes


def _joint_axis(robot: Robot, j: int) -> np.ndarray:
    """Unit axis of revolute joint ``j`` (1-based Pinocchio index) in its own frame."""
    import pinocchio as pin

    data = robot.model.createData()
    q = pin.neutral(robot.model)
    pin.computeJointJacobians(robot.model, data, q)
    # The joint's motion subspace is its column of the local Jacobian: angular part = the axis.
    jacobian = pin.getJointJacobian(robot.model, data, j, pin.ReferenceFrame.LOCAL)
    column = jacobian[3:, robot.model.joints[j].idx_v]
    if np.linalg.norm(column) < 0.5:
        raise InputError(f"joint {j} is not revolute: the frames need revolute joints 1 and 2", source=robot.source)
    return column / np.linalg.norm(column)


def base_frame(a1, c1, a2, c2, nominal: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (3, 3) and origin (3,) of the URDF base frame in the tracker frame.

    ``nominal`` holds the URDF's (direction, point) of axes 1 and 2 in the base frame.
    """
    (u1, p1), (u2, p2) = nominal
    f1, _ = common_perpendicular(u1, p1, u2, p2)
    F1, _ = common_perpendicular(a1, c1, a2, c2)
    measured = np.array([a1, a2, np.cross(a1, a2) / np.linalg.norm(np.cross(a1, a2))])
    model = np.array([u1, u2, np.cross(u1, u2) / np.linalg.norm(np.cross(u1, u2))])
    rotation, _ = Rotation.align_vectors(measured, model)
    R = rotation.as_matrix()
    return R, F1 - R @ f1


def draw_axis(fit: AxisFit, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` draws of (direction, nearest point) from the fit's Gaussian, renormalised onto the line model."""
    x = rng.multivariate_normal(np.concatenate([fit.direction, fit.point]), fit.cov, size=n, method="eigh")
    a = x[:, :3] / np.linalg.norm(x[:, :3], axis=1, keepdims=True)
    c = x[:, 3:] - np.sum(x[:, 3:] * a, axis=1, keepdims=True) * a
    return a, c


def frames_with_uncertainty(first: AxisFit, second: AxisFit, nominal, rng: np.random.Generator, draws: int = 400) -> list[Frame]:
    """The paper and base frames from the axes of joints 1 and 2, with covariances from ``draws`` draws of the axes
    and each component's degrees of freedom."""
    a1, c1, a2, c2 = first.direction, first.point, second.direction, second.point
    estimates = {"paper": paper_frame(a1, c1, a2, c2), "base": base_frame(a1, c1, a2, c2, nominal)}
    d1, d2 = draw_axis(first, rng, draws), draw_axis(second, rng, draws)
    notes = {
        "paper": "fixed whole by axes 1 and 2",
        "base": "height of the base origin along axis 1 and the joint-1 zero (the turn about axis 1) from the URDF's "
                "nominal geometry at the sweep's home angles; the offsets between axes 1 and 2 also from the URDF",
    }
    frames = []
    for name, (R, t) in estimates.items():
        rotations, translations = [], []
        for k in range(draws):
            args = (d1[0][k], d1[1][k], d2[0][k], d2[1][k])
            Rk, tk = paper_frame(*args) if name == "paper" else base_frame(*args, nominal)
            rotations.append(Rotation.from_matrix(Rk @ R.T).as_rotvec())
            translations.append(tk)
        rotation_dof, translation_dof = np.split(_component_dof(first, second, nominal, name, R), 2)
        frames.append(Frame(name, R, t, np.cov(np.array(rotations).T), np.cov(np.array(translations).T), notes[name],
                            rotation_dof, translation_dof))
    return frames


_STEP = 1e-7
"""Finite-difference step of an axis's direction (1) and point (m) in :func:`_component_dof`: the frame's
components are smooth in them, and 1e-7 of a metre-long lever is far above round-off and far below any sd."""


def _component_dof(first: AxisFit, second: AxisFit, nominal, name: str, R: np.ndarray) -> np.ndarray:
    """(6,) degrees of freedom of the frame's rotation (3) and translation (3) sds: Welch and Satterthwaite's over
    the two axes' sandwiches, each component linearised in the axes' ``[direction, point]``."""
    def components(fits) -> np.ndarray:
        (a1, c1), (a2, c2) = [(f[:3] / np.linalg.norm(f[:3]), f[3:] - (f[3:] @ f[:3]) * f[:3] / (f[:3] @ f[:3])) for f in fits]
        Rk, tk = paper_frame(a1, c1, a2, c2) if name == "paper" else base_frame(a1, c1, a2, c2, nominal)
        return np.concatenate([Rotation.from_matrix(Rk @ R.T).as_rotvec(), tk])

    x = [np.concatenate([fit.direction, fit.point]) for fit in (first, second)]
    centre = components(x)
    gradients = []
    for i in range(2):
        g = np.empty((6, 6))
        for k in range(6):
            moved = [v.copy() for v in x]
            moved[i][k] += _STEP
            g[:, k] = (components(moved) - centre) / _STEP
        gradients.append(g)
    dof = np.empty(6)
    for m in range(6):
        fits = [(fit, gradients[i][m]) for i, fit in enumerate((first, second))]
        variance = sum(float(g @ fit.cov @ g) for fit, g in fits)
        dof[m] = combined_dof(variance, [(float(g @ fit.sandwich @ g), sandwich_dof(fit.dof_kernel, g)) for fit, g in fits])
    return dof
