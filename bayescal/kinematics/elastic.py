"""The kinematic calibration on top of an elastostatic one: a heavy arm's deflection taken from its own model.

The points model's elastic part (:mod:`bayescal.kinematics.model`) turns each joint
by its compliance times the gravity moment of the masses it carries.  A heavy
industrial arm with a spring gravity compensator (the KR-270's joint 2) is not
that: the spring's moment, which cancels most of the arm's weight about joint
2, is no mass.  Its elastostatic calibration (``bayescal calibrate`` on loaded
minus unloaded differences) identifies the compliances, the spring and the
masses' scale; :class:`ArmDeflection` takes that model (the posterior medians,
as the compensation applies them) and gives each marker's elastic displacement
in any configuration, unloaded or under a load: the static equilibrium of the
nominal arm, markers at ``q + θ`` minus markers at ``q``.

Loaded minus unloaded differences leave the spring itself (``K_c``, ``s0``) all but
unknown (docs/twin.md, "Limitations"), and with it the unloaded arm's sag: on the
twin, the posterior medians' sag misses the true one by up to 1.8 mm at the markers.
Absolute positions see it.  :class:`ArmPointModel` therefore adds ``K_c``, ``K_c·s0``
(the spring's moment is linear in both, where it is bilinear in ``K_c`` and ``s0``)
and the scale of the link masses to a rigid rung's parameters (``frames``,
``offsets`` or ``geometry``), with the elastostatic posterior's medians as prior
means; the sag enters linearly about a point that
:class:`ElasticKinematicCalibration` moves to the mode and refits from, until it
settles.  Its results add the elastostatic model's deflection, under any load,
to every prediction.

The displacement is computed on the nominal geometry and turned into the tracker's
axes by the cell's base guess: the identified geometry changes it by the
kinematic errors times the deflection (1 mrad of a few mm: a few μm).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.compensation.calibration import Calibration
from bayescal.errors import InputError
from bayescal.inference.exact import scale_masses
from bayescal.kinematics.cell import PointsCell
from bayescal.kinematics.fit import KinematicCalibration
from bayescal.kinematics.model import Parameter, PointModel
from bayescal.kinematics.positions import Positions
from bayescal.kinematics.results import KinematicResults, results_from_dataset
from bayescal.output import record_read
from bayescal.robot.batched import BatchedChain, equilibria
from bayescal.robot.compensator import Compensator
from bayescal.units import URAD_PER_NM

__all__ = ["ArmDeflection", "ArmPointModel", "ElasticKinematicCalibration", "ElasticKinematicResults", "RIGID_RUNGS"]

RIGID_RUNGS = ("frames", "offsets", "geometry")
"""The rungs without an elastic part of their own: the elastostatic model supplies it."""

STEPS = {"K_c": 1e3, "K_c_s0": 1e2, "gravity_scale": 1e-2}
"""Finite-difference steps of the sag's derivatives (N/m, N, 1): 1 N/mm of a 100-300 N/mm spring, 100 N of a K_c·s0 of
about 66 kN, 1 % of the masses.  The sag is linear in all three but for the spring's share of joint 2's stiffness
(0.1 %, docs/twin.md) and the arm's deflected geometry."""

REFINED = {"K_c": ("compensator", "N/mm", 1e3), "K_c_s0": ("compensator", "N", 1.0), "gravity_scale": ("masses", "1", 1.0)}
"""Each refined parameter's group, edge unit and the unit's factor to SI (the parameter is named ``group.key``)."""

COMPLIANCE_STEP = 1e-3
"""Relative finite-difference step of a load's deflection in the compliances (it is linear in them but for the
deflected geometry's share, below 1 %)."""

LINEARISATIONS = 4
"""Refits about the last mode at most; the spring's values settle to 1e-3 of their sd in 2-3 on the twin."""


class ArmDeflection:
    """Each marker's elastic displacement from an elastostatic model of the arm (tracker axes, m).

    Parameters
    ----------
    cell
        The elastostatic cell: robot, compensator geometry, tool markers (flange frame), load point.
    points
        The cell of measured points; its markers must be the elastostatic cell's, by name.
    compliances
        ``(nq,)`` joint compliances, rad/(N·m), the compensated joint's without its spring.
    compensator
        The compensator (None: none).
    gravity_scale
        Factor on the URDF's link masses.
    """

    def __init__(self, cell: Cell, points: PointsCell, *, compliances: np.ndarray, compensator: Compensator | None,
                 gravity_scale: float = 1.0) -> None:
        missing = [name for name in points.marker_names if name not in cell.markers]
        if missing:
            raise InputError(f"marker '{missing[0]}' of the cell of measured points is not on the elastostatic cell's tool "
                             f"(its markers: {', '.join(cell.markers)})", source=points.source)
        if compensator is not None and not isinstance(compensator, Compensator):
            # The refined parameters below are the spring's static coordinates (K_c, K_c·s0) by name.
            raise InputError(f"the elastic rung refines a spring compensator's K_c and K_c·s0; the cell's is of kind "
                             f"'{compensator.kind}'", source=cell.source)
        self.cell, self.points = cell, points
        self.compliances = np.asarray(compliances, dtype=float)
        self.compensator, self.gravity_scale = compensator, float(gravity_scale)
        self._markers = np.array([cell.markers[name] for name in points.marker_names])

    @classmethod
    def from_calibration(cls, cell: Cell, points: PointsCell, calibration: Calibration) -> ArmDeflection:
        """The model at the posterior medians of an elastostatic calibration (:func:`~bayescal.compensation.calibration.load_calibration`)."""
        return cls(cell, points, compliances=calibration.applied_own, compensator=calibration.median_compensator(),
                   gravity_scale=calibration.gravity_scale)

    def values(self) -> dict[str, float]:
        """The parameters the absolute positions refine (SI): ``K_c`` and ``K_c_s0`` (with a compensator), ``gravity_scale``."""
        c = self.compensator
        spring = {} if c is None else {"K_c": float(c.K_c), "K_c_s0": float(c.K_c * c.s0)}
        return spring | {"gravity_scale": self.gravity_scale}

    def with_values(self, values: dict[str, float]) -> ArmDeflection:
        """This model with the spring and the masses' scale of ``values`` (:meth:`values`' keys)."""
        compensator = None if self.compensator is None else self.compensator.with_spring(values["K_c"], values["K_c_s0"] / values["K_c"])
        return ArmDeflection(self.cell, self.points, compliances=self.compliances, compensator=compensator,
                             gravity_scale=values["gravity_scale"])

    @cached_property
    def _chain(self) -> BatchedChain:
        return BatchedChain.of(scale_masses(self.cell.robot, self.gravity_scale))

    def __call__(self, joints: np.ndarray, wrenches: np.ndarray | None = None, load_points: np.ndarray | None = None) -> np.ndarray:
        """``(N, M, 3)`` each marker's displacement (m, tracker axes) in ``(N, nq)`` configurations (rad, the arm's joints).

        ``wrenches`` ``(N, 6)``: the load of each configuration at the flange origin, base axes (N, N·m), its force
        through the cell's load point (or ``load_points`` ``(N, 3)``, flange frame, m: a campaign's own), as a campaign
        records it; None: unloaded, the arm's own weight alone.
        """
        q = np.atleast_2d(np.asarray(joints, dtype=float))
        wrench = np.zeros((len(q), 6)) if wrenches is None else np.asarray(wrenches, dtype=float)
        theta = equilibria(self._chain, q, wrench, self.compliances, compensator=self.compensator,
                           compensated_joint=self.cell.compensated_joint,
                           load_point=self.cell.load_point if load_points is None else load_points)
        moved, rigid = self._chain.poses(q + theta), self._chain.poses(q)
        shift = np.stack([moved.points(p) - rigid.points(p) for p in self._markers], axis=1)
        return shift @ np.array(self.points.base.rotation).T


class ArmPointModel:
    """A rigid rung's :class:`~bayescal.kinematics.model.PointModel` plus an elastostatic model's deflection.

    The parameters are the rigid rung's, then ``compensator.K_c`` (N/mm), ``compensator.K_c_s0`` (N; both only
    with a compensator) and ``masses.gravity_scale``.  The deflection is linear in them about
    ``deflection``'s values (its derivatives by finite differences, :data:`STEPS`).

    Parameters
    ----------
    rigid
        The rigid rung's model.
    deflection
        The elastostatic model at the linearisation point.
    prior_mean, prior_sd
        ``{name: value}`` (SI) of the refined parameters (:meth:`ArmDeflection.values`' keys).
    """

    def __init__(self, rigid: PointModel, deflection: ArmDeflection, prior_mean: dict[str, float], prior_sd: dict[str, float]) -> None:
        self.rigid, self.deflection = rigid, deflection
        self.cell, self.rung, self.without = rigid.cell, rigid.rung, rigid.without
        self.keys = tuple(deflection.values())
        extra = [Parameter(f"{REFINED[k][0]}.{k}", *REFINED[k], prior_mean[k], prior_sd[k]) for k in self.keys]
        self.parameters = rigid.parameters + tuple(extra)
        self.mean = np.array([p.mean for p in self.parameters])
        self.sd = np.array([p.sd for p in self.parameters])
        self.names = tuple(p.name for p in self.parameters)
        self._point = np.array([deflection.values()[k] for k in self.keys])
        self._cache: tuple[bytes, np.ndarray, np.ndarray] | None = None

    @property
    def size(self) -> int:
        return len(self.parameters)

    def _sag(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The unloaded deflection ``(N, M, 3)`` at the linearisation point and its derivatives ``(N, M, 3, K)``."""
        key = q.tobytes()
        if self._cache is None or self._cache[0] != key:
            base = self.deflection(q)
            columns = []
            for k in self.keys:
                moved = self.deflection.values()
                moved[k] += STEPS[k]
                columns.append((self.deflection.with_values(moved)(q) - base) / STEPS[k])
            self._cache = (key, base, np.stack(columns, axis=-1))
        return self._cache[1], self._cache[2]

    def predict(self, theta: np.ndarray, q: np.ndarray, *, jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """As :meth:`PointModel.predict <bayescal.kinematics.model.PointModel.predict>`, the deflection added."""
        q = np.atleast_2d(q)
        n = self.rigid.size
        rigid, J = self.rigid.predict(theta[:n], q, jacobian=jacobian)
        base, derivative = self._sag(q)
        positions = rigid + base + derivative @ (theta[n:] - self._point)
        if jacobian:
            J = np.concatenate([J, derivative], axis=-1)
        return positions, J

    def refined(self, theta: np.ndarray) -> ArmDeflection:
        """The elastostatic model with the refined parameters of ``theta``."""
        return self.deflection.with_values(dict(zip(self.keys, (float(v) for v in theta[self.rigid.size:]))))


class ElasticKinematicCalibration:
    """A rigid rung of the ladder with the deflection of an elastostatic model, its spring and masses refined.

    Parameters
    ----------
    points
        The cell of measured points.
    deflection
        The arm's elastostatic model at the elastostatic calibration's medians (:class:`ArmDeflection`).
    prior_sd
        Prior sds (SI) of ``K_c``, ``K_c_s0`` and ``gravity_scale`` (:meth:`from_calibration` takes the elastostatic
        posterior's for the spring and the cell's ``mass_sd_fraction`` for the masses).
    rung
        One of :data:`RIGID_RUNGS`.
    compliance_covariance
        ``(nq, nq)`` the elastostatic posterior's covariance of the joint compliances (rad²/(N·m)²), carried to the
        loaded predictions; None: the compliances taken as known.
    """

    def __init__(self, points: PointsCell, deflection: ArmDeflection, prior_sd: dict[str, float], rung: str = "geometry",
                 compliance_covariance: np.ndarray | None = None) -> None:
        if rung not in RIGID_RUNGS:
            raise ValueError(f"rung must be one of {', '.join(RIGID_RUNGS)} (the elastostatic model gives the elastic part), got {rung!r}")
        self.points, self.deflection, self.prior_sd, self.rung = points, deflection, prior_sd, rung
        self.compliance_covariance = compliance_covariance

    @classmethod
    def from_calibration(cls, cell: Cell, points: PointsCell, calibration: Calibration, rung: str = "geometry") -> ElasticKinematicCalibration:
        """From an elastostatic calibration (:func:`~bayescal.compensation.calibration.load_calibration`) of ``cell``."""
        deflection = ArmDeflection.from_calibration(cell, points, calibration)
        draws = calibration.spring
        spring = {} if draws is None else {"K_c": float(np.std(draws[:, 0])), "K_c_s0": float(np.std(draws[:, 0] * draws[:, 1]))}
        return cls(points, deflection, spring | {"gravity_scale": points.priors.mass_fraction}, rung,
                   np.atleast_2d(np.cov(calibration.own, rowvar=False)))

    def fit(self, positions: Positions) -> ElasticKinematicResults:
        """The posterior given unloaded ``positions``: refitted about each mode until the spring and masses settle."""
        prior = self.deflection.values()
        model = ArmPointModel(PointModel(self.points, self.rung), self.deflection, prior, self.prior_sd)
        results = KinematicCalibration(self.points, model=model).fit(positions)
        for _ in range(LINEARISATIONS):
            refined = model.refined(results.mean)
            moved = np.array([abs(refined.values()[k] - model.deflection.values()[k]) / self.prior_sd[k] for k in model.keys])
            model = ArmPointModel(model.rigid, refined, prior, self.prior_sd)
            results = KinematicCalibration(self.points, model=model).fit(positions, start=results)
            if moved.max() < 1e-3:
                break
        return ElasticKinematicResults(results, model.refined(results.mean), self.compliance_covariance)


@dataclass(frozen=True)
class ElasticKinematicResults:
    """The posterior (:attr:`kinematic`, rigid parameters then the spring's and the masses'), the refined elastostatic
    model, and the elastostatic posterior's covariance of the joint compliances (``(nq, nq)``, rad²/(N·m)²; None: taken
    as known)."""

    kinematic: KinematicResults
    deflection: ArmDeflection
    compliance_covariance: np.ndarray | None = None

    def predict(self, joints: np.ndarray, wrenches: np.ndarray | None = None,
                load_points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(N, M, 3)`` positions (m, tracker frame) and ``(N, M, 3, 3)`` predictive covariances under ``wrenches`` ``(N, 6)``
        at ``load_points`` (:meth:`ArmDeflection.__call__`).

        The unloaded prediction and its covariance are the fitted model's (posterior, tracker, learned model error).
        A load adds the refined elastostatic model's extra deflection and its spread, linearised: in the refined
        spring and masses through their posterior (with its correlations to the geometry), and in the joint
        compliances through :attr:`compliance_covariance` (a separate calibration's, so independent of the rest).
        """
        if wrenches is None:
            return self.kinematic.predict(joints)
        extra = self._load_deflection(self.deflection, joints, wrenches, load_points)
        model = self.kinematic.model
        refined = np.zeros(extra.shape + (model.size,))
        for index, key in enumerate(model.keys, start=model.rigid.size):
            moved = self.deflection.values()
            moved[key] += STEPS[key]
            refined[..., index] = (self._load_deflection(self.deflection.with_values(moved), joints, wrenches, load_points)
                                   - extra) / STEPS[key]
        mean, covariance = self.kinematic.predict(joints, added_jacobian=refined)
        if self.compliance_covariance is not None:
            compliances = self._compliance_jacobian(extra, joints, wrenches, load_points)
            covariance = covariance + np.einsum("nmap,pq,nmbq->nmab", compliances, self.compliance_covariance, compliances,
                                                optimize=True)
        return mean + extra, covariance

    @staticmethod
    def _load_deflection(deflection: ArmDeflection, joints, wrenches, load_points) -> np.ndarray:
        """``(N, M, 3)`` what the load adds to each marker's deflection (m)."""
        return deflection(joints, wrenches, load_points) - deflection(joints)

    def _compliance_jacobian(self, extra: np.ndarray, joints, wrenches, load_points) -> np.ndarray:
        """``(N, M, 3, nq)`` the load's deflection's derivatives in the joint compliances (m per rad/(N·m))."""
        base = self.deflection
        columns = []
        for j, value in enumerate(base.compliances):
            step = COMPLIANCE_STEP * max(abs(value), 1e-8)
            compliances = base.compliances.copy()
            compliances[j] += step
            moved = ArmDeflection(base.cell, base.points, compliances=compliances, compensator=base.compensator,
                                  gravity_scale=base.gravity_scale)
            columns.append((self._load_deflection(moved, joints, wrenches, load_points) - extra) / step)
        return np.stack(columns, axis=-1)

    def spring(self) -> dict[str, tuple[float, float]] | None:
        """``K_c`` (N/mm) and ``s0`` (mm), each ``(mean, sd)``: ``s0 = K_c_s0 / K_c`` and its sd to first order; None without
        a compensator."""
        names = self.kinematic.model.names
        if "compensator.K_c" not in names:
            return None
        i, j = names.index("compensator.K_c"), names.index("compensator.K_c_s0")
        k, f = self.kinematic.mean[[i, j]]
        s0 = f / k
        gradient = np.array([-f / k**2, 1.0 / k])
        covariance = self.kinematic.covariance[np.ix_([i, j], [i, j])]
        return {"K_c": (float(k) / 1e3, float(np.sqrt(covariance[0, 0])) / 1e3),
                "s0": (float(s0) * 1e3, float(np.sqrt(gradient @ covariance @ gradient)) * 1e3)}

    def corrections(self) -> np.ndarray:
        """``(nq, 6)`` each joint's identified placement correction ``(tx, ty, tz, rx, ry, rz)`` (m, rad), in the frame
        where its axis is z (:func:`~bayescal.kinematics.axes.axis_frame`); a component the rung leaves out is 0."""
        tree, names = self.kinematic.model.cell.tree, self.kinematic.model.names
        out = np.zeros((tree.nj - 1, 6))
        for j in range(1, tree.nj):
            for i, c in enumerate(("tx", "ty", "tz", "rx", "ry", "rz")):
                if f"{tree.names[j]}.{c}" in names:
                    out[j - 1, i] = self.kinematic.mean[names.index(f"{tree.names[j]}.{c}")]
        return out

    def document(self):
        """The calibration as one document (:mod:`bayescal.summary`): the text ``bayescal kinematics`` prints, and its
        Markdown, HTML and JSON (:func:`~bayescal.kinematics.document.kinematic_document`)."""
        from bayescal.kinematics.document import kinematic_document

        return kinematic_document(self)

    def summary(self) -> pd.DataFrame:
        return self.kinematic.summary()

    def identifiability(self) -> list[dict]:
        return self.kinematic.identifiability()

    def diagnostics(self) -> dict:
        spring = self.spring()
        return self.kinematic.diagnostics() | {"elastic": "an elastostatic calibration's, its spring and masses refined"} | (
            {} if spring is None else {"K_c_N_per_mm": spring["K_c"], "s0_mm": spring["s0"]})

    def to_json(self) -> dict:
        return self.kinematic.to_json() | {"diagnostics": self.diagnostics(),
                                           "elastic": {"compliances_urad_per_Nm": (self.deflection.compliances / URAD_PER_NM).tolist()}}

    def save(self, path) -> None:
        """Write the posterior as NetCDF, with the deflection model it was linearised on (:func:`elastic_results_from_dataset`).

        The file holds the model's numbers (compliances and their posterior covariance, compensator, masses' scale:
        the elastostatic posterior's medians, refined) so that it needs no posterior, and names the elastostatic cell (its path as given and its
        SHA-256) for what numbers cannot carry: the URDF, the tool, the compensated joint.
        """
        point = self.kinematic.model.deflection
        dataset = self.kinematic.dataset()
        dataset.attrs |= {"elastic_cell": point.cell.source, "elastic_cell_sha256": _sha256(point.cell.source),
                          "elastic_compliances_rad_per_Nm": point.compliances, "elastic_gravity_scale": point.gravity_scale}
        if self.compliance_covariance is not None:
            dataset.attrs["elastic_compliance_covariance_rad2_per_Nm2"] = self.compliance_covariance.ravel()
        if point.compensator is not None:
            c = point.compensator
            dataset.attrs["elastic_compensator_L_ax_ay_m_phi_rad_Kc_N_per_m_s0_m"] = np.array([c.L, c.a_x, c.a_y, c.phi, c.K_c, c.s0])
        dataset.to_netcdf(path, engine="netcdf4")


def _sha256(path: str) -> str:
    record_read(path, "the elastostatic cell")
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def elastic_results_from_dataset(dataset, points: PointsCell, source: str) -> ElasticKinematicResults:
    """The results :meth:`ElasticKinematicResults.save` wrote (``dataset``, read from ``source``) for ``points``.

    Raises
    ------
    InputError
        The elastostatic cell the file names is missing or has changed since.
    """
    from bayescal.cell.config import load_cell

    cell_path = str(dataset.attrs["elastic_cell"])
    if not Path(cell_path).is_file():
        raise InputError(f"the elastostatic cell this calibration was made with, '{cell_path}', is missing (a relative "
                         f"path is read from the folder `bayescal kinematics` ran in)", source=source)
    if _sha256(cell_path) != dataset.attrs["elastic_cell_sha256"]:
        raise InputError(f"the elastostatic cell this calibration was made with, '{cell_path}', has changed since "
                         f"(its SHA-256 differs): run `bayescal kinematics` again", source=source)
    cell = load_cell(cell_path)
    values = dataset.attrs.get("elastic_compensator_L_ax_ay_m_phi_rad_Kc_N_per_m_s0_m")
    deflection = ArmDeflection(cell, points, compliances=np.atleast_1d(dataset.attrs["elastic_compliances_rad_per_Nm"]),
                               compensator=None if values is None else Compensator(*(float(v) for v in values)),
                               gravity_scale=float(dataset.attrs["elastic_gravity_scale"]))
    names = [str(n) for n in dataset["parameter"].values]
    refined = {k: f"{REFINED[k][0]}.{k}" for k in deflection.values()}
    absent = [name for name in refined.values() if name not in names]
    if absent:
        raise InputError(f"the calibration has no parameter '{absent[0]}' of its elastostatic model", source=source)
    prior_mean, prior_sd = ({k: float(dataset[v].values[names.index(name)]) for k, name in refined.items()}
                            for v in ("prior_mean", "prior_sd"))
    model = ArmPointModel(PointModel(points, str(dataset.attrs["rung"])), deflection, prior_mean, prior_sd)
    kinematic = results_from_dataset(dataset, model, source)
    covariance = dataset.attrs.get("elastic_compliance_covariance_rad2_per_Nm2")
    if covariance is not None:
        covariance = np.reshape(covariance, (len(deflection.compliances),) * 2)
    return ElasticKinematicResults(kinematic, model.refined(kinematic.mean), covariance)
