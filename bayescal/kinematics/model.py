"""The measured points' model: a rung of the ladder, its parameters with priors, predictions and Jacobians.

A marker on link ``L`` of configuration ``q`` is predicted in the tracker frame as

    p = T_base · exp(δ_base) · ( oM_L(q; δ) · p_marker + Δp_elastic ),

with ``oM_L`` the tree's forward kinematics with each joint's placement corrected by
``exp(δ_j)`` (:mod:`bayescal.kinematics.tree`), and ``Δp_elastic`` the first-order
deflection under the robot's own weight: each elastic joint ``j`` turns everything
it carries by ``C_j · M_j``, where ``M_j`` is the gravity moment of its subtree about
its origin and ``C_j = R_j diag(κx, κy, κθ) R_j^T`` its compliance (κθ about the
joint's axis, κx and κy, the transversal compliance, across it).  ``M_j`` is linear
in the bodies' masses and first moments, which are parameters too: the data fix
the products of compliances and masses, the priors the rest.

The Jacobian is exact in the compliances and masses; in the kinematic parameters it
leaves out how a correction changes the deflection itself (and the base's tilt the
direction of gravity): terms of the order of the deflection over the arm's length
(up to a few per cent of a column on Justin).  The search evaluates the objective exactly, so every step
it takes lowers it; where it stops, the exact gradient differs from zero by terms
of that order.

The ladder's rungs add parameter groups in the order of Tenhumberg and Bäuml's
table: ``frames`` (the base, the free frames, the markers), ``offsets`` (θ),
``geometry`` (d, r, α: the rest of each joint's 6-D placement correction, in the
frame where its axis is z: ``tz`` is d, ``tx, ty`` r, ``rx, ry`` α and β),
``joint-elastic`` (κθ and the masses) and ``full`` (κα: the transversal
compliances).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from bayescal.kinematics.cell import PointsCell
from bayescal.kinematics.tree import skew
from bayescal.units import DEG, MM, URAD_PER_NM

__all__ = ["GROUPS", "RUNGS", "Parameter", "PointModel"]

RUNGS = ("frames", "offsets", "geometry", "joint-elastic", "full")
"""The ladder's models, each adding groups to the one before."""

GROUPS = {
    "frames": ("frames",),
    "offsets": ("frames", "theta"),
    "geometry": ("frames", "theta", "d", "r", "alpha"),
    "joint-elastic": ("frames", "theta", "d", "r", "alpha", "k_theta", "masses"),
    "full": ("frames", "theta", "d", "r", "alpha", "k_theta", "k_alpha", "masses"),
}
"""The parameter groups of each rung; a leave-one-group-out model drops one of them."""

_COMPONENTS = ("tx", "ty", "tz", "rx", "ry", "rz")
_COMPONENT_GROUP = {"tx": "r", "ty": "r", "tz": "d", "rx": "alpha", "ry": "alpha", "rz": "theta"}
"""Which DH group each component of a joint's placement correction belongs to."""


@dataclass(frozen=True)
class Parameter:
    """One parameter: its name, group, unit at the edges and that unit's SI value, prior mean and sd (SI)."""

    name: str
    group: str
    unit: str
    scale: float
    mean: float
    sd: float


class PointModel:
    """One model of the ladder on a cell of measured points (immutable).

    Parameters
    ----------
    cell
        The cell: tree, markers, base guess, priors.
    rung
        One of :data:`RUNGS`.
    without
        Groups left out (the leave-one-group-out table).

    Attributes
    ----------
    parameters : tuple of Parameter
    mean, sd : numpy.ndarray
        ``(P,)`` prior means and sds (SI).
    """

    def __init__(self, cell: PointsCell, rung: str = "full", *, without: tuple[str, ...] = ()) -> None:
        if rung not in RUNGS:
            raise ValueError(f"rung must be one of {', '.join(RUNGS)}, got {rung!r}")
        self.cell, self.rung, self.without = cell, rung, tuple(without)
        groups = set(GROUPS[rung]) - set(without)
        tree, priors = cell.tree, cell.priors
        self.paths = [tuple(j for j in tree.supports[m.joint]) for m in cell.markers]
        on_path = sorted({j for path in self.paths for j in path} & set(cell.moving))
        parameters: list[Parameter] = []
        self._slices: dict[tuple[str, ...], slice] = {}

        def add(key: tuple[str, ...], entries: list[Parameter]) -> None:
            self._slices[key] = slice(len(parameters), len(parameters) + len(entries))
            parameters.extend(entries)

        def twist(prefix: str, group_of, translation: float, rotation: float, components=_COMPONENTS) -> list[Parameter]:
            return [
                Parameter(f"{prefix}.{c}", group_of(c), "mm" if c[0] == "t" else "deg", MM if c[0] == "t" else DEG, 0.0,
                          translation if c[0] == "t" else rotation)
                for c in components
            ]

        add(("base",), twist("base", lambda c: "frames", priors.base_translation, priors.base_rotation))
        for j in cell.free_frames:
            add(("frame", str(j)), twist(f"frame.{tree.names[j]}", lambda c: "frames", priors.frame_translation, priors.frame_rotation))
        for marker in cell.markers:
            add(("marker", marker.name), [Parameter(f"marker.{marker.name}.{a}", "frames", "mm", MM, float(v), priors.marker)
                                          for a, v in zip("xyz", marker.position)])
        self.corrected: dict[int, tuple[str, ...]] = {}
        for j in on_path:
            if j in cell.free_frames:
                continue
            kept = tuple(c for c in _COMPONENTS if _COMPONENT_GROUP[c] in groups)
            if kept:
                self.corrected[j] = kept
                add(("joint", str(j)), [
                    Parameter(f"{tree.names[j]}.{c}", _COMPONENT_GROUP[c], *(("mm", MM, 0.0, priors.length) if c[0] == "t" else
                              ("deg", DEG, 0.0, priors.offset if c == "rz" else priors.twist)))
                    for c in kept
                ])
        self.elastic = tuple(j for j in on_path if "k_theta" in groups or "k_alpha" in groups)
        self.axes: dict[int, tuple[int, ...]] = {}
        for j in self.elastic:
            axes = tuple(a for a, g in ((0, "k_alpha"), (1, "k_alpha"), (2, "k_theta")) if g in groups)
            self.axes[j] = axes
            add(("compliance", str(j)), [
                Parameter(f"{tree.names[j]}.{'kx' if a == 0 else 'ky' if a == 1 else 'k_theta'}", "k_theta" if a == 2 else "k_alpha",
                          "μrad/(N·m)", URAD_PER_NM, 0.0, priors.joint_compliance if a == 2 else priors.transversal_compliance)
                for a in axes
            ])
        carried = sorted({b for j in self.elastic for b in tree.subtree(j)})
        self.bodies = tuple(b for b in carried if tree.mass[b] > 0) if "masses" in groups and self.elastic else ()
        for b in self.bodies:
            m, c = tree.mass[b], tree.com[b]
            entries = [Parameter(f"{tree.names[b]}.mass", "masses", "kg", 1.0, m, priors.mass_fraction * m)]
            entries += [Parameter(f"{tree.names[b]}.moment_{a}", "masses", "kg·mm", MM, m * v, priors.com * m) for a, v in zip("xyz", c)]
            add(("body", str(b)), entries)
        self.parameters = tuple(parameters)
        self.mean = np.array([p.mean for p in parameters])
        self.sd = np.array([p.sd for p in parameters])
        self.names = tuple(p.name for p in parameters)

    @property
    def size(self) -> int:
        return len(self.parameters)

    def _part(self, theta: np.ndarray, *key: str) -> np.ndarray:
        return theta[self._slices[key]]

    def _corrections(self, theta: np.ndarray) -> dict[int, np.ndarray]:
        """Each corrected joint's 6-D placement correction (SI), free frames included."""
        out = {j: self._part(theta, "frame", str(j)) for j in self.cell.free_frames}
        for j, kept in self.corrected.items():
            delta = np.zeros(6)
            delta[[_COMPONENTS.index(c) for c in kept]] = self._part(theta, "joint", str(j))
            out[j] = delta
        return out

    def predict(self, theta: np.ndarray, q: np.ndarray, *, jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Marker positions in the tracker frame and their Jacobian.

        Parameters
        ----------
        theta
            ``(P,)`` parameters (SI).
        q
            ``(N, nq)`` the model's joint angles (rad): :meth:`PointsCell.model_configuration`.
        jacobian
            Whether to compute the Jacobian.

        Returns
        -------
        positions : numpy.ndarray
            ``(N, M, 3)`` each marker's position (m), markers in the cell's order.
        jacobian : numpy.ndarray or None
            ``(N, M, 3, P)`` derivatives with respect to ``theta``.
        """
        cell, tree = self.cell, self.cell.tree
        q = np.atleast_2d(q)
        n = q.shape[0]
        deltas = self._corrections(theta)
        frames = tree.frames(q, {j: pin.exp6(d) for j, d in deltas.items()})
        R, o = frames.rotation, frames.origin
        base_delta = self._part(theta, "base")
        base = cell.base * pin.exp6(base_delta)
        Rb, tb = np.array(base.rotation), np.array(base.translation)
        g = Rb.T @ cell.gravity
        G = skew(g)
        moments, spread = self._gravity_moments(theta, R, o, g) if self.elastic else ({}, {})
        positions = np.empty((n, len(cell.markers), 3))
        J = np.zeros((n, len(cell.markers), 3, self.size)) if jacobian else None
        for k, marker in enumerate(cell.markers):
            local = self._part(theta, "marker", marker.name)
            p = np.einsum("nab,b->na", R[:, marker.joint], local) + o[:, marker.joint]
            deflection = np.zeros((n, 3))
            for j in self.elastic:
                if j in self.paths[k]:
                    deflection += np.cross(np.einsum("nab,nb->na", spread[j], moments[j]), p - o[:, j])
            moved = p + deflection
            positions[:, k] = moved @ Rb.T + tb
            if not jacobian:
                continue
            Jk = np.zeros((n, 3, self.size))
            Jk[:, :, self._slices[("marker", marker.name)]] = R[:, marker.joint]
            for j, delta in deltas.items():
                if j not in self.paths[k]:
                    continue
                arm = skew(p - o[:, j])
                block = np.concatenate([frames.before[:, j], -arm @ frames.before[:, j]], axis=-1) @ pin.Jexp6(pin.Motion(delta))
                if j in cell.free_frames:
                    Jk[:, :, self._slices[("frame", str(j))]] = block
                else:
                    Jk[:, :, self._slices[("joint", str(j))]] = block[:, :, [_COMPONENTS.index(c) for c in self.corrected[j]]]
            if self.elastic:
                self._elastic_jacobian(Jk, k, p, R, o, G, moments, spread, theta)
            Jk = np.einsum("ab,nbp->nap", Rb, Jk)
            base_block = np.concatenate([np.broadcast_to(Rb, (n, 3, 3)), -Rb @ skew(moved)], axis=-1)
            Jk[:, :, self._slices[("base",)]] = base_block @ pin.Jexp6(pin.Motion(base_delta))
            J[:, k] = Jk
        return positions, J

    def _masses(self, theta: np.ndarray) -> tuple[dict[int, float], dict[int, np.ndarray]]:
        """Each carried body's mass (kg) and first moment in its joint frame (kg·m): parameters, or the URDF's."""
        tree = self.cell.tree
        mass = {b: float(tree.mass[b]) for b in range(1, tree.nj)}
        moment = {b: tree.mass[b] * tree.com[b] for b in range(1, tree.nj)}
        for b in self.bodies:
            values = self._part(theta, "body", str(b))
            mass[b], moment[b] = float(values[0]), values[1:]
        return mass, moment

    def _gravity_moments(self, theta, R, o, g):
        """Each elastic joint's gravity moment about its origin ``(N, 3)`` and its compliance ``R diag(κ) R^T`` ``(N, 3, 3)``."""
        tree = self.cell.tree
        mass, moment = self._masses(theta)
        moments, spread = {}, {}
        for j in self.elastic:
            carried = tree.subtree(j)
            first = sum(np.einsum("nab,b->na", R[:, b], moment[b]) + mass[b] * o[:, b] for b in carried)
            total = sum(mass[b] for b in carried)
            moments[j] = np.cross(first - total * o[:, j], g)
            kappa = np.zeros(3)
            kappa[list(self.axes[j])] = self._part(theta, "compliance", str(j))
            spread[j] = np.einsum("nab,b,ncb->nac", R[:, j], kappa, R[:, j])
        return moments, spread

    def _elastic_jacobian(self, Jk, k, p, R, o, G, moments, spread, theta) -> None:
        """Add the deflection's derivatives with respect to compliances and masses to ``Jk`` ``(N, 3, P)``."""
        tree = self.cell.tree
        path = [j for j in self.paths[k] if j in self.elastic]
        n = p.shape[0]
        summed_a = np.zeros((n, 3, 3))
        summed_b = np.zeros((n, 3))
        prefix: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        for j in path:
            arm = p - o[:, j]
            start = self._slices[("compliance", str(j))].start
            local = np.einsum("nba,nb->na", R[:, j], moments[j])
            for i, a in enumerate(self.axes[j]):
                Jk[:, :, start + i] = np.cross(R[:, j, :, a] * local[:, a : a + 1], arm)
            # Δp = A_j M_j with A_j = -skew(p - o_j) C_j; dM_j/dm_b = -G (o_b - o_j), dM_j/dh_b = -G R_b.
            A = -skew(arm) @ spread[j]
            summed_a = summed_a + A @ G
            summed_b = summed_b + np.einsum("nab,nb->na", A @ G, o[:, j])
            prefix[j] = (summed_a, summed_b)
        for b in self.bodies:
            common = [j for j in path if j in tree.supports[b]]
            if not common:
                continue
            sa, sb = prefix[common[-1]]
            start = self._slices[("body", str(b))].start
            Jk[:, :, start] = -np.einsum("nab,nb->na", sa, o[:, b]) + sb
            Jk[:, :, start + 1 : start + 4] = -sa @ R[:, b]
