"""The one registry of the identified elastostatic parameters: what every table, JSON key and report reads.

For a robot of ``n`` joints a calibration identifies the joint compliances
``k1``..``k<n>`` (rad/(N·m) inside; μrad/(N·m) at the edges, μm/N for a
prismatic joint such as a linear track: the same factor 1e-6 from SI) and, when
the cell has a compensator on joint ``j``, its law's parameters
(:attr:`bayescal.robot.laws.CompensatorLaw.PARAMETERS`): for the spring of eqs
4-9 (Klimchik et al.) its stiffness ``K_c`` (N/m; N/mm) and free length ``s0``
(m; mm).  Joint
``j``'s ``k<j>`` is then its compliance without the compensator, and its
equivalent compliance at each campaign angle is a per-angle parameter labelled
by the joint's own number, ``k<j>_q<j>[<angle in deg>]``: ``k2_q2[-25.240]``
for the KR-270, ``k3_q3[40.000]`` for a compensator on joint 3.  Without a
compensator nothing is said of the law's parameters and no label is per angle.

A :class:`ParameterRegistry` holds, for one cell's robot, each parameter's
name, symbol, SI factor, edge unit and the published value where the cell names
a reference table (Table IV of the paper for the KR-270, ``[robot]
reference_csv`` for another robot).  :func:`label_angle` is the one parser of
the per-angle labels.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from types import MappingProxyType

from bayescal.cell.joints import DEFAULT_COMPENSATED_JOINT
from bayescal.robot.compensator import Compensator
from bayescal.robot.laws import LawParameter
from bayescal.units import DEG, MM, URAD_PER_NM

__all__ = [
    "ANGLE_DECIMALS",
    "ANGLE_FORMAT",
    "COMPLIANCE_UNIT",
    "GEOMETRY_PARAMETERS",
    "PRISMATIC_COMPLIANCE_UNIT",
    "Parameter",
    "ParameterRegistry",
    "angle_label",
    "label_angle",
    "label_joint",
    "is_per_angle_variable",
]

COMPLIANCE_UNIT = "urad/(N m)"
"""A revolute joint's compliance at the edges (μrad/(N·m), written in ASCII in keys and files)."""
PRISMATIC_COMPLIANCE_UNIT = "um/N"
"""A prismatic joint's compliance at the edges (μm/N: the same factor 1e-6 from SI as μrad/(N·m))."""

_LABEL = re.compile(r"^k(\d+)_q\1\[(-?\d+(?:\.\d*)?)\]$")
_VARIABLE = re.compile(r"^k(\d+)_q\1$")
ANGLE_DECIMALS = 3
"""Decimals of a degree to which the compensated joint's angles are told apart: angles equal when rounded to
them are one angle of eq 34, and a per-angle label or coordinate names its angle with them."""
ANGLE_FORMAT = f"{{:.{ANGLE_DECIMALS}f}}"
"""Degrees of a per-angle label or coordinate (:data:`ANGLE_DECIMALS` decimals)."""


@dataclass(frozen=True)
class Parameter:
    """One identified parameter.

    Attributes
    ----------
    name : str
        Its key in every table and JSON (``k3``, ``K_c``, ``s0``).
    symbol : str
        How the paper writes it, in plain text (``k_3``, ``K_c``, ``s_0``).
    si_factor : float
        The SI value of one edge unit: ``si = edge * si_factor``.
    unit : str
        The unit at the edges (files, JSON, reports).
    description : str
        What it is, in a few words.
    published : tuple of float or None
        ``(value, ±3σ half-width)`` in ``unit`` from the cell's reference table; None when it lists none.
    """

    name: str
    symbol: str
    si_factor: float
    unit: str
    description: str
    published: tuple[float, float] | None = None

    def to_edge(self, value):
        """An SI value (float or array) in the edge unit."""
        return value / self.si_factor

    def to_si(self, value):
        """An edge-unit value (float or array) in SI."""
        return value * self.si_factor


GEOMETRY_PARAMETERS = (
    Parameter("L", "L", MM, "mm", "length of the compensator's lever P2-P1 (eq 10)"),
    Parameter("a_x", "a_x", MM, "mm", "x of the cylinder's pivot P0 from the joint-2 axis (Table II)"),
    Parameter("a_y", "a_y", MM, "mm", "y of the cylinder's pivot P0 from the joint-2 axis (Table II)"),
    Parameter("phi", "φ", DEG, "deg", "angle of the lever at q2 = 0"),
)
"""The compensator geometry a saved posterior carries (``bayescal geometry``, and the elastostatic
posterior that propagated it), in the order of :class:`~bayescal.robot.compensator.CompensatorGeometry`."""


@dataclass(frozen=True)
class ParameterRegistry:
    """The identified parameters of one robot.

    Parameters
    ----------
    n_joints
        Joints of the identified chain.
    prismatic
        Which joints are prismatic; empty: all revolute.
    compensated_joint
        0-based index of the joint the compensator acts on; None without a compensator.
    published
        ``{name: (value, ±3σ half-width)}`` in edge units from the cell's reference table; None when it names none.
    law
        The identified parameters of the compensator's law (the spring's ``K_c`` and ``s0`` by default).
    """

    n_joints: int
    prismatic: tuple[bool, ...] = ()
    compensated_joint: int | None = DEFAULT_COMPENSATED_JOINT
    published: MappingProxyType | None = None
    law: tuple[LawParameter, ...] = Compensator.PARAMETERS

    @classmethod
    def of_cell(cls, cell) -> ParameterRegistry:
        """The registry of a :class:`~bayescal.cell.config.Cell`: its robot's joints, its compensator and its reference table."""
        published = None
        if cell.reference is not None:
            from bayescal.reference import published_in

            published = MappingProxyType(published_in(cell.reference, "IV"))
        prismatic = tuple(bool(p) for p in cell.robot.prismatic) if cell.robot.prismatic.any() else ()
        law = Compensator.PARAMETERS if cell.compensator is None else cell.compensator.PARAMETERS
        return cls(cell.robot.nq, prismatic, cell.compensated_joint, published, law)

    @property
    def compensated(self) -> bool:
        """Whether the robot has a compensator (and so its law's parameters and per-angle compliances)."""
        return self.compensated_joint is not None

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        """Every parameter, joints first, then the compensator law's."""
        published = self.published or {}
        out = []
        for j in range(self.n_joints):
            linear = j < len(self.prismatic) and self.prismatic[j]
            own = " without its compensator" if j == self.compensated_joint else ""
            out.append(
                Parameter(
                    f"k{j + 1}",
                    f"k_{j + 1}",
                    URAD_PER_NM,
                    PRISMATIC_COMPLIANCE_UNIT if linear else COMPLIANCE_UNIT,
                    f"compliance of {'prismatic ' if linear else ''}joint {j + 1}{own}",
                    published.get(f"k{j + 1}"),
                )
            )
        if self.compensated:
            out.extend(Parameter(p.name, p.symbol, p.si_factor, p.unit, p.description, published.get(p.name)) for p in self.law)
        return tuple(out)

    @property
    def law_names(self) -> list[str]:
        """The compensator law's parameters' names (``K_c``, ``s0`` for the spring); empty without a compensator."""
        return [p.name for p in self.law] if self.compensated else []

    @property
    def names(self) -> list[str]:
        """The parameters' names, in order."""
        return [p.name for p in self.parameters]

    @property
    def units(self) -> dict[str, str]:
        """``{name: edge unit}``."""
        return {p.name: p.unit for p in self.parameters}

    def edge_values(self, compliances, spring=None) -> dict:
        """SI values by name in the edge units: ``{k1: …, k<n>: …}`` and, given them, the compensator law's.

        Parameters
        ----------
        compliances
            ``(n_joints,)`` joint compliances, rad/(N·m) or m/N for a prismatic joint.
        spring
            The law's identified values in SI (``(K_c, s0)`` in N/m and m for the spring), or None.
        """
        values = {parameter.name: parameter.to_edge(value) for parameter, value in zip(self.parameters[: self.n_joints], compliances)}
        if spring is not None:
            values |= {p.name: self[p.name].to_edge(value) for p, value in zip(self.law, spring)}
        return values

    def __getitem__(self, name: str) -> Parameter:
        for parameter in self.parameters:
            if parameter.name == name:
                return parameter
        raise KeyError(name)

    def __contains__(self, name: object) -> bool:
        return name in self.names

    @property
    def per_angle_variable(self) -> str | None:
        """The posterior variable of the per-angle compliances (``k2_q2`` for the KR-270); None without a compensator."""
        return None if self.compensated_joint is None else f"k{self.compensated_joint + 1}_q{self.compensated_joint + 1}"

    @property
    def angle_dimension(self) -> str | None:
        """The dimension of :attr:`per_angle_variable`: the compensated joint's angle in degrees (``q2_deg``)."""
        return None if self.compensated_joint is None else f"q{self.compensated_joint + 1}_deg"

    def angle_label(self, angle: float) -> str:
        """The per-angle name at the compensated joint's ``angle`` (rad): :func:`angle_label`."""
        if self.compensated_joint is None:
            raise ValueError("a robot without a compensator has no per-angle compliance")
        return angle_label(angle, self.compensated_joint)


def angle_label(angle: float, joint: int = DEFAULT_COMPENSATED_JOINT) -> str:
    """Name of the compensated joint's equivalent compliance at ``angle`` (rad): ``k2_q2[-25.240]`` (deg) for ``joint`` 1 (0-based)."""
    return f"k{joint + 1}_q{joint + 1}[{ANGLE_FORMAT.format(math.degrees(angle))}]"


def label_angle(name: str) -> float | None:
    """The angle (deg) of a per-angle name made by :func:`angle_label`; ``None`` for any other parameter name."""
    match = _LABEL.match(name)
    return None if match is None else float(match.group(2))


def label_joint(name: str) -> int | None:
    """The 0-based joint of a per-angle name made by :func:`angle_label`; ``None`` for any other parameter name."""
    match = _LABEL.match(name)
    return None if match is None else int(match.group(1)) - 1


def is_per_angle_variable(name: str) -> bool:
    """Whether a posterior variable holds per-angle compliances (``k2_q2``, ``k3_q3`` …)."""
    return _VARIABLE.match(name) is not None
