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
(up to a few per cent of a column in Justin's full model; up to 15 % of the torso's
translations with the coupled torso compliances, whose torques a shift along the
torso changes).  The search evaluates the objective exactly, so every step
it takes lowers it; where it stops, the exact gradient differs from zero by terms
of that order.  On Justin's ``coupled-elastic`` fit, two further steps with a
finite-difference Jacobian lower the objective by 0.2 % and the mean error by
0.002 mm.

The ladder's rungs add parameter groups in the order of Tenhumberg and Bäuml's
table: ``frames`` (the base, the free frames, the markers), ``offsets`` (θ),
``geometry`` (d, r, α: the rest of each joint's 6-D placement correction, in the
frame where its axis is z: ``tz`` is d, ``tx, ty`` r, ``rx, ry`` α and β),
``joint-elastic`` (κθ and the masses) and ``full`` (κα: the transversal
compliances).

Two extensions go beyond the published model (:data:`EXTENSIONS`).
``base-elastic`` lets the base yield under the whole robot's weight: its
placement turns about the tracker's horizontal axes and shifts horizontally by
2 × 2 compliances times the horizontal components of the gravity moment of all
the bodies about the base origin (a platform on wheels or springs tilts about a
point below it; the shift is the tilt's lever about that point).
``coupled-elastic`` adds the mutual compliances of the joints a coupling law
ties together (``[robot.coupled]``: the coupled joint and the joints of its
law): the mechanism that enforces the law is elastic too, so the turn of each
such joint is a symmetric matrix times their torques about their axes, not a
diagonal one.  Both enter linearly, with Jacobians exact in them and in the
masses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from bayescal.kinematics.cell import PointsCell
from bayescal.kinematics.tree import skew
from bayescal.units import DEG, MM, UM, URAD_PER_NM

__all__ = ["EXTENSIONS", "GROUPS", "RUNGS", "Parameter", "PointModel"]

RUNGS = ("frames", "offsets", "geometry", "joint-elastic", "full")
"""The ladder's models, each adding groups to the one before."""

EXTENSIONS = ("base-elastic", "coupled-elastic")
"""Rungs beyond ``full``, each adding a physical effect the published model leaves out (the module's docstring)."""

GROUPS = {
    "frames": ("frames",),
    "offsets": ("frames", "theta"),
    "geometry": ("frames", "theta", "d", "r", "alpha"),
    "joint-elastic": ("frames", "theta", "d", "r", "alpha", "k_theta", "masses"),
    "full": ("frames", "theta", "d", "r", "alpha", "k_theta", "k_alpha", "masses"),
    "base-elastic": ("frames", "theta", "d", "r", "alpha", "k_theta", "k_alpha", "masses", "k_base"),
    "coupled-elastic": ("frames", "theta", "d", "r", "alpha", "k_theta", "k_alpha", "masses", "k_base", "k_coupled"),
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
        One of :data:`RUNGS` or :data:`EXTENSIONS`.
    without
        Groups left out (the leave-one-group-out table).

    Attributes
    ----------
    parameters : tuple of Parameter
    mean, sd : numpy.ndarray
        ``(P,)`` prior means and sds (SI).
    pairs : tuple of (int, int)
        The joints with a mutual compliance (``coupled-elastic``), in pairs of joint indices.
    base_elastic : bool
        Whether the base yields under the robot's weight (``base-elastic`` and above).
    """

    def __init__(self, cell: PointsCell, rung: str = "full", *, without: tuple[str, ...] = ()) -> None:
        if rung not in GROUPS:
            raise ValueError(f"rung must be one of {', '.join(GROUPS)}, got {rung!r}")
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

        for key, entries in self._frame_parameters():
            add(key, entries)
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
        self.pairs, self.base_elastic = _coupled_pairs(cell, self.elastic) if "k_coupled" in groups else (), "k_base" in groups
        for key, entries in self._extension_parameters():
            add(key, entries)
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

    def _frame_parameters(self) -> list[tuple[tuple[str, ...], list[Parameter]]]:
        """The frames' parameters with their keys: the base's and each free frame's twist, each marker's position."""
        cell = self.cell
        names, priors = cell.tree.names, cell.priors

        def twist(prefix: str, translation: float, rotation: float) -> list[Parameter]:
            return [
                Parameter(f"{prefix}.{c}", "frames", "mm" if c[0] == "t" else "deg", MM if c[0] == "t" else DEG, 0.0,
                          translation if c[0] == "t" else rotation)
                for c in _COMPONENTS
            ]

        keyed = [(("base",), twist("base", priors.base_translation, priors.base_rotation))]
        keyed += [(("frame", str(j)), twist(f"frame.{names[j]}", priors.frame_translation, priors.frame_rotation)) for j in cell.free_frames]
        keyed += [
            (("marker", marker.name), [Parameter(f"marker.{marker.name}.{a}", "frames", "mm", MM, float(v), priors.marker)
                                       for a, v in zip("xyz", marker.position)])
            for marker in cell.markers
        ]
        return keyed

    def _extension_parameters(self) -> list[tuple[tuple[str, ...], list[Parameter]]]:
        """The extensions' parameters with their keys: the coupled joints' mutual compliances, the base's compliances."""
        names, priors = self.cell.tree.names, self.cell.priors
        out = [(("coupled", str(a), str(b)), [Parameter(f"{names[a]}.k_theta.{names[b]}", "k_coupled", "μrad/(N·m)", URAD_PER_NM, 0.0,
                                                        priors.joint_compliance)]) for a, b in self.pairs]
        if self.base_elastic:
            out.append((("base compliance",),
                        [Parameter(f"base.turn_{a}_per_M{b}", "k_base", "μrad/(N·m)", URAD_PER_NM, 0.0, priors.base_compliance)
                         for a in "xy" for b in "xy"]
                        + [Parameter(f"base.shift_{a}_per_M{b}", "k_base", "μm/(N·m)", UM, 0.0, priors.base_shift) for a in "xy" for b in "xy"]))
        return out

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
        moments, spread = self._gravity_moments(theta, R, o, g) if self.elastic else ({}, {})
        turns = self._turns(theta, R, moments, spread)
        weight = self._base_moment(theta, R, o, Rb) if self.base_elastic else None
        positions = np.empty((n, len(cell.markers), 3))
        J = np.zeros((n, len(cell.markers), 3, self.size)) if jacobian else None
        for k, marker in enumerate(cell.markers):
            local = self._part(theta, "marker", marker.name)
            p = np.einsum("nab,b->na", R[:, marker.joint], local) + o[:, marker.joint]
            deflection = np.zeros((n, 3))
            for j in self.elastic:
                if j in self.paths[k]:
                    deflection += np.cross(turns[j], p - o[:, j])
            moved = p + deflection
            positions[:, k] = moved @ Rb.T + tb
            if weight is not None:
                yielded, columns, slope, turn = self._base_yield(theta, positions[:, k] - tb, weight)
                positions[:, k] += yielded
            if not jacobian:
                continue
            Jk = np.zeros((n, 3, self.size))
            Jk[:, :, self._slices[("marker", marker.name)]] = R[:, marker.joint]
            self._placement_jacobian(Jk, k, p, frames, deltas)
            if self.elastic:
                self._elastic_jacobian(Jk, k, p, R, o, skew(g), moments, spread, theta)
            Jk = np.einsum("ab,nbp->nap", Rb, Jk)
            base_block = np.concatenate([np.broadcast_to(Rb, (n, 3, 3)), -Rb @ skew(moved)], axis=-1)
            Jk[:, :, self._slices[("base",)]] = base_block @ pin.Jexp6(pin.Motion(base_delta))
            if weight is not None:
                self._base_jacobian(Jk, columns, slope, turn, R, o, Rb)
            J[:, k] = Jk
        return positions, J

    def _placement_jacobian(self, Jk: np.ndarray, k: int, p: np.ndarray, frames, deltas: dict[int, np.ndarray]) -> None:
        """Fill ``Jk`` ``(N, 3, P)``, marker ``k``'s Jacobian at ``p`` ``(N, 3)`` m, in the joint placements' columns."""
        for j, delta in deltas.items():
            if j not in self.paths[k]:
                continue
            arm = skew(p - frames.origin[:, j])
            block = np.concatenate([frames.before[:, j], -arm @ frames.before[:, j]], axis=-1) @ pin.Jexp6(pin.Motion(delta))
            if j in self.cell.free_frames:
                Jk[:, :, self._slices[("frame", str(j))]] = block
            else:
                Jk[:, :, self._slices[("joint", str(j))]] = block[:, :, [_COMPONENTS.index(c) for c in self.corrected[j]]]

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

    def _turns(self, theta, R, moments, spread) -> dict[int, np.ndarray]:
        """Each elastic joint's turn under the weight ``(N, 3)`` (rad, base frame): its compliance times its moment, plus
        each coupled partner's compliance times that partner's torque about its axis."""
        turns = {j: np.einsum("nab,nb->na", spread[j], moments[j]) for j in self.elastic}
        for a, b in self.pairs:
            c = self._part(theta, "coupled", str(a), str(b))[0]
            turns[a] = turns[a] + c * R[:, a, :, 2] * _torque(R, moments, b)[:, None]
            turns[b] = turns[b] + c * R[:, b, :, 2] * _torque(R, moments, a)[:, None]
        return turns

    def _elastic_jacobian(self, Jk, k, p, R, o, G, moments, spread, theta) -> None:
        """Add the deflection's derivatives with respect to compliances and masses to ``Jk`` ``(N, 3, P)``."""
        tree = self.cell.tree
        path = [j for j in self.paths[k] if j in self.elastic]
        # Δp = Σ_i A_i M_i over the moments it depends on: A_j = -skew(p - o_j) C_j for each joint j on the path, and
        # -skew(p - o_j) c z_j z_iᵀ added to A_i for each coupled partner i of a joint j on the path.
        slopes: dict[int, np.ndarray] = {}
        for j in path:
            arm = p - o[:, j]
            start = self._slices[("compliance", str(j))].start
            local = np.einsum("nba,nb->na", R[:, j], moments[j])
            for i, a in enumerate(self.axes[j]):
                Jk[:, :, start + i] = np.cross(R[:, j, :, a] * local[:, a : a + 1], arm)
            slopes[j] = slopes.get(j, 0.0) - skew(arm) @ spread[j]
        for a, b in self.pairs:
            column = self._slices[("coupled", str(a), str(b))].start
            for j, i in ((a, b), (b, a)):
                if j in path:
                    arm = p - o[:, j]
                    Jk[:, :, column] += np.cross(R[:, j, :, 2] * _torque(R, moments, i)[:, None], arm)
                    axes = np.einsum("na,nb->nab", R[:, j, :, 2], R[:, i, :, 2])
                    slopes[i] = slopes.get(i, 0.0) - theta[column] * skew(arm) @ axes
        # dM_i/dm_b = -G (o_b - o_i) and dM_i/dh_b = -G R_b for each body b that joint i carries.  The sums over a
        # body's carriers are kept by prefix: a deeper body on the same chain adds one term to its parent's.
        weighed = {i: A @ G for i, A in slopes.items()}
        totals: dict[tuple[int, ...], tuple] = {(): (0.0, 0.0)}
        for b in self.bodies:
            carriers = tuple(i for i in sorted(weighed) if i in tree.supports[b])
            if not carriers:
                continue
            for size in range(1, len(carriers) + 1):
                if carriers[:size] not in totals:
                    summed_a, summed_b = totals[carriers[: size - 1]]
                    i = carriers[size - 1]
                    totals[carriers[:size]] = (summed_a + weighed[i], summed_b + np.einsum("nab,nb->na", weighed[i], o[:, i]))
            summed_a, summed_b = totals[carriers]
            start = self._slices[("body", str(b))].start
            Jk[:, :, start] = -np.einsum("nab,nb->na", summed_a, o[:, b]) + summed_b
            Jk[:, :, start + 1 : start + 4] = -summed_a @ R[:, b]

    def _base_moment(self, theta, R, o, Rb) -> np.ndarray:
        """``(N, 3)`` the gravity moment of all the bodies about the base origin, in the tracker frame (N·m)."""
        mass, moment = self._masses(theta)
        first = sum(np.einsum("nab,b->na", R[:, b], moment[b]) + mass[b] * o[:, b] for b in range(1, self.cell.tree.nj))
        return np.cross(first @ Rb.T, self.cell.gravity)

    def _base_yield(self, theta, arm, weight):
        """The base's yield at points ``arm`` ``(N, 3)`` from its origin (tracker frame, m) under the moment ``weight`` ``(N, 3)``.

        Returns the displacement ``(N, 3)`` (m), its derivatives by the eight base compliances ``(N, 3, 8)`` and by
        the moment ``(N, 3, 3)``, and the base's turn ``(N, 3)`` (rad).
        """
        values = self._part(theta, "base compliance")
        turn, shift = np.zeros((3, 3)), np.zeros((3, 3))
        turn[:2, :2], shift[:2, :2] = values[:4].reshape(2, 2), values[4:].reshape(2, 2)
        columns = np.zeros(arm.shape + (8,))
        for i, (a, b) in enumerate((a, b) for a in range(2) for b in range(2)):
            columns[:, :, i] = np.cross(np.eye(3)[a] * weight[:, b : b + 1], arm)
            columns[:, a, 4 + i] = weight[:, b]
        slope = -skew(arm) @ turn + shift
        return np.einsum("nab,nb->na", slope, weight), columns, slope, weight @ turn.T

    def _base_jacobian(self, Jk, columns, slope, turn, R, o, Rb) -> None:
        """Add the base's yield's derivatives to ``Jk`` ``(N, 3, P)`` (tracker frame): the turn of every other column's
        motion, the compliances' columns, the moment's change with the masses."""
        Jk += skew(turn) @ Jk
        Jk[:, :, self._slices[("base compliance",)]] = columns
        # The moment is -skew(g) Rb Σ (m_b o_b + R_b h_b) in the tracker frame.
        lever = slope @ (-skew(self.cell.gravity) @ Rb)
        for b in self.bodies:
            start = self._slices[("body", str(b))].start
            Jk[:, :, start] += np.einsum("nab,nb->na", lever, o[:, b])
            Jk[:, :, start + 1 : start + 4] += lever @ R[:, b]


def _torque(R: np.ndarray, moments: dict[int, np.ndarray], joint: int) -> np.ndarray:
    """``(N,)`` the moment's component about the joint's axis (N·m)."""
    return np.einsum("na,na->n", R[:, joint, :, 2], moments[joint])


def _coupled_pairs(cell: PointsCell, elastic: tuple[int, ...]) -> tuple[tuple[int, int], ...]:
    """The pairs of elastic joints a coupling law ties together: each coupled joint and the joints of its law, all with all."""
    tree = cell.tree
    pairs: set[tuple[int, int]] = set()
    for j in cell.moving:
        if tree.names[j] in cell.commanded:
            continue
        law = [tree.names.index(cell.commanded[c]) for c in np.flatnonzero(cell.coupling[tree.idx_q[j]])]
        tied = sorted(x for x in {j, *law} if x in elastic)
        pairs |= {(a, b) for i, a in enumerate(tied) for b in tied[i + 1 :]}
    return tuple(sorted(pairs))
