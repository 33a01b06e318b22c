"""The models the critique compares: the classical VJM model and what can be added to it.

Every model here is linear in its parameters: the deflections are
``y = X @ beta + noise``, three equations per campaign row.  The base model is
the classical serial VJM of eq 30, one constant compliance per joint (joint 2
without a compensator).  Each :class:`Extension` adds columns, in physical
parameters where the physics allows:

``compensator``
    Joint 2's compliance varies with q2 as the spring compensator makes it (eq 8,
    linearised about a constant: ``k2(q2) ≈ k2 + c1 C1(q2) + c2 C2(q2)`` with
    ``C1, C2`` the columns of eq 35 for the cell's compensator geometry; a
    quadratic in q2 when the cell has none).
``link_compliance``
    Each long link is a 6-D virtual spring at its end (the VJM's compliant link),
    loaded by the load's wrench, with the compliance matrix of a uniform beam
    isotropic across its axis: an axial 1/EA, a bending 1/EI and a torsional
    1/GJ compliance per link; what lies beyond moves rigidly.
``tool_compliance``
    The tool's mount is a 6-D spring at the flange, transversely isotropic about
    the flange axis, under the load's wrench at the flange origin (five
    compliances: it shifts and turns, along and across the flange axis).
``backlash``
    Each joint's link moves by a lost motion ``δ_j`` toward the sign of the torque
    it carries: the deflection gains ``δ_j (sign τ_loaded - sign τ_unloaded)``, the
    sign smoothed over :data:`BACKLASH_PRELOAD` of the joint's largest load torque;
    and the same with memory (a joint whose torque stays within a friction hold keeps
    the side the previous state left it at, in the order of measurement), the hold
    tried at each of :data:`BACKLASH_HOLDS` of the joint's rated torque (the URDF's
    effort limit: a gear's breakaway torque follows the gear, not the plan's loads),
    the torques including the weighed tool's (``[tool] mass_kg``), a joint driven to a new configuration
    arriving on the side it was left at or on the side its servo drove it to, the
    compensated joint's unloaded torque taken as the cell's or a tenth of its largest
    load torque either side of it (:data:`BACKLASH_SETTINGS`, :meth:`Extension.variants`).
``nonlinear_stiffness``
    Each joint's deflection law gains a term in ``τ|τ|`` (a spring that stiffens
    or softens with torque), the torque being the weight's and the load's.
``outliers``
    Student-t tracker noise instead of Gaussian, one mixing weight per reading (no new columns); named only
    where that heavy tail predicts the held-out configurations better than the same tail shared by every
    marker of a state: a gross error puts one reading off, while an arm that is not where the model puts it
    (play on the side not predicted) moves every marker of that state together.
``drift``
    The tracker's frame moving between a row's unloaded and loaded reading, as the
    campaign's readings of one state repeated in time show it
    (:mod:`bayescal.critique.drift`; one column, its amplitude; not tried where the
    campaign holds no such readings).

:data:`PROBES` are not physics but the covariates of
:data:`~bayescal.critique.covariates.COVARIATES`, each in every base axis: a
residual that one of them explains and no extension does is a misfit the
catalogue cannot name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from bayescal.cell.config import Cell
from bayescal.critique.covariates import COVARIATES, PREDICTED_MARKER, REVERSED_MARKER, Rows
from bayescal.critique.drift import drift_deflection, drift_evidence

__all__ = ["Extension", "CATALOGUE", "PLANNABLE", "PROBES", "base_columns", "BEAM_MIN_LENGTH", "BACKLASH_PRELOAD", "BACKLASH_HOLDS", "BACKLASH_SHIFTS", "rated_torques", "BACKLASH_SETTINGS", "APPROACH_MOVE", "OUTLIER_DOF"]

BEAM_MIN_LENGTH = 0.5
"""Shortest link (m, between consecutive joint origins) modelled as a beam: shorter links of an
industrial arm (column offsets, wrist) are stocky castings whose bending is far below the joints'."""
BACKLASH_PRELOAD = 0.05
"""Torque, as a fraction of the largest load torque on the joint in the rows, over which a joint
crosses its dead band: a joint preloaded by much less than the loads (a wrist under a light tool)
does not sit firmly at one end of its lost motion, and ``sign τ`` would overstate its jump."""
BACKLASH_HOLDS = (0.01, 0.03, 0.1)
"""Friction holds tried for the lost motion with memory, as fractions of each joint's rated torque
(:func:`rated_torques`): the torque the other way beyond which a joint held in its play crosses it.
A reducer's breakaway torque follows its size, which its rating gives, not the loads a plan happens to
apply.  How hard it holds is not known beforehand (ESTIMATE: a few per cent of rated, as the twin and the
independent generator take it, 1-6 %), so the critique keeps the hold that predicts the held-out
configurations best, one per factor of about three from 1 % to 10 % of rated.  Chosen on the physics and
on the twin's and the independent generator's campaigns, not on the third generator's."""
APPROACH_MOVE = 1e-3
"""Smallest change of a commanded joint angle (rad, or m for a prismatic joint) between configurations
counted as a move: below it the joint was not driven and keeps its side."""
BACKLASH_SHIFTS = (0.0, -0.1, 0.1)
"""Errors tried in the compensated joint's unloaded torque, as fractions of its largest load torque in the
rows.  That torque is the small difference of the arm's weight and the compensator's pull, taken from the
cell's spring and link masses: a spring 15 % off the cell's moved it by up to 460 N·m on the independent
generator (``docs/critique.md``), against a largest load torque of 6,300-6,700 N·m on joint 2 in Table III's
twin campaign and the generator's campaigns seeded 9000-9002, and near the balance it decides the side of the
joint's play.  ESTIMATE: a tenth either way (630-670 N·m there) covers that."""
BACKLASH_SETTINGS = tuple(
    (hold, approached, shift) for shift in BACKLASH_SHIFTS for approached in (False, True) for hold in BACKLASH_HOLDS
)
"""The lost motion's variants: each friction hold, with the side on arriving at a configuration kept from
the previous state, or set by the direction the servo drove the joint (the link lags its motor:
a joint driven up arrives on the low side of its play), at each error of the compensated joint's
unloaded torque.  A controller approaches a pose along its own path, so either side can be true of a
robot; the held-out comparison chooses."""
OUTLIER_DOF = 4.0
"""Degrees of freedom of the Student-t noise of ``outliers``: 4 is the usual robust choice
(Lange, Little & Taylor 1989), heavy enough to discount gross errors, near-Gaussian otherwise."""


@dataclass(frozen=True)
class Extension:
    """A term that can be added to the base model.

    Attributes
    ----------
    name : str
    description : str
    columns : callable
        ``columns(rows, cell)`` -> (N, 3, m) regressors of its m new parameters (m may be 0).
        With a ``grid``, ``columns(rows, cell, setting)``.
    robust : bool
        Whether it replaces the Gaussian noise by Student-t noise, the three coordinates of a row (one marker's
        readings) sharing one mixing weight: a gross error puts one reading off in all three.
    per_state : bool
        With ``robust``, whether the mixing weight is shared by all rows of one state (a configuration's repeat,
        every marker read in it) instead: the heavy tail of the arm's state, not of the tracker's readings, which
        only the check of a robust candidate fits (``_shared_by_state`` in :mod:`bayescal.critique.model`).
    physical : bool
        Whether it is a physical term that predicts at other poses (probes are not).
    grid : tuple
        Values of a setting the columns are not linear in (the lost motion's friction hold, side on arrival and the compensated joint's unloaded torque),
        each a variant of the extension (:meth:`variants`); empty: none.
    setting : object
        The value a variant has (None: the extension has no setting).
    describe : callable or None
        ``describe(setting, rows, cell)`` -> dict: the setting in physical units.
    """

    name: str
    description: str
    columns: Callable[..., np.ndarray]
    robust: bool = False
    per_state: bool = False
    physical: bool = True
    grid: tuple = ()
    setting: object = None
    describe: Callable[[object, Rows, Cell], dict] | None = None

    def variants(self) -> list[Extension]:
        """The extension at each value of its ``grid`` (itself when it has none)."""
        return [replace(self, grid=(), setting=value) for value in self.grid] or [self]

    def reading(self, rows: Rows, cell: Cell) -> dict:
        """Its setting in physical units, for the rows it was chosen on."""
        return {"setting": self.setting} if self.describe is None else self.describe(self.setting, rows, cell)

    def regressors(self, rows: Rows, cell: Cell) -> np.ndarray:
        """(N, 3, m) the columns of its m parameters, at its setting."""
        return self.columns(rows, cell) if self.setting is None else self.columns(rows, cell, self.setting)


def base_columns(rows: Rows, cell: Cell) -> np.ndarray:
    """(N, 3, nq) the classical VJM model of eq 30: one constant compliance per joint."""
    return rows.design


def _compensator(rows: Rows, cell: Cell) -> np.ndarray:
    q2 = rows.q[:, rows.plan_joint]
    if cell.compensator is not None:
        shape = cell.compensator.regressor(q2)[:, 1:]
    else:
        shape = np.column_stack([q2, q2**2])
    return rows.design[:, :, rows.plan_joint, np.newaxis] * shape[:, np.newaxis, :]


def _beams(cell: Cell, rows: Rows) -> list[tuple[int, int]]:
    """(root, tip) joints, 0-based, of the links at least :data:`BEAM_MIN_LENGTH` long."""
    origins = rows.frames[0, :, :3, 3]
    lengths = np.linalg.norm(np.diff(origins, axis=0), axis=1)
    return [(j, j + 1) for j in np.flatnonzero(lengths >= BEAM_MIN_LENGTH)]


def _spring(frame: np.ndarray, centre: np.ndarray, force: np.ndarray, moment: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N, 3, 5) displacements of ``points`` by a 6-D virtual spring at ``centre``, per unit of each of its 5 compliances.

    The spring (the VJM's compliant link, Klimchik & Pashkevich) turns the wrench
    it carries, ``force`` and ``moment`` about ``centre`` (N, 3, base axes), into a
    small twist of what lies beyond it: a translation ``δ`` at ``centre`` and a
    rotation ``φ``.  Its 6 × 6 compliance matrix is taken transversely isotropic
    about the first axis of ``frame`` (N, 3, 3, columns the spring's axes in base
    axes), the symmetry of a tube, a box of near-equal walls or a round adaptor,
    which leaves five entries: axial (δ along the axis per axial force), shear
    (δ across per force across), torsion (φ about the axis per moment about it),
    bending (φ across per moment across) and the coupling of a force across with
    a rotation across (``δ_y ← M_z``, ``φ_z ← F_y`` and their mirror images; a
    cantilever's ``L²/2EI``).  A cantilever of length L, bending stiffness EI,
    torsional GJ and axial EA is ``(L/EA, L³/3EI, L/GJ, L/EI, L²/2EI)``.
    """
    f = np.einsum("nji,nj->ni", frame, force)
    m = np.einsum("nji,nj->ni", frame, moment)
    zero = np.zeros_like(f[:, 0])
    axial = (np.column_stack([f[:, 0], zero, zero]), np.zeros_like(f))
    shear = (np.column_stack([zero, f[:, 1], f[:, 2]]), np.zeros_like(f))
    torsion = (np.zeros_like(f), np.column_stack([m[:, 0], zero, zero]))
    bending = (np.zeros_like(f), np.column_stack([zero, m[:, 1], m[:, 2]]))
    # m × e_x across the axis, and e_x × f: the symmetric pair of the force-rotation coupling
    coupling = (np.column_stack([zero, m[:, 2], -m[:, 1]]), np.column_stack([zero, -f[:, 2], f[:, 1]]))
    lever = points - centre
    columns = []
    for delta, phi in (axial, shear, torsion, bending, coupling):
        delta, phi = np.einsum("nij,nj->ni", frame, delta), np.einsum("nij,nj->ni", frame, phi)
        columns.append(delta + np.cross(phi, lever))
    return np.stack(columns, axis=-1)


def _axis_frame(axis: np.ndarray) -> np.ndarray:
    """(N, 3, 3) orthonormal frames whose first axis is ``axis`` (N, 3, unit); the other two are any (the spring is isotropic across)."""
    helper = np.where(np.abs(axis[:, 2:3]) < 0.9, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    second = np.cross(helper, axis)
    second /= np.linalg.norm(second, axis=1, keepdims=True)
    return np.stack([axis, second, np.cross(axis, second)], axis=2)


def _link_compliance(rows: Rows, cell: Cell) -> np.ndarray:
    """Each long link a uniform beam's 6-D spring at its end, loaded by the load's wrench (3 columns per link: 1/EA, 1/EI, 1/GJ).

    The spring's compliance matrix is a cantilever's (:func:`_spring`): the
    shear, coupling and bending entries tied by one bending compliance 1/EI as
    ``L³/3, L²/2, L`` (Euler-Bernoulli), the axial and torsional ones ``L/EA`` and
    ``L/GJ``.  Left free, the five entries would cost the held-out comparison
    more than a beam's deflection gains: on the twin's Table III campaign of seed
    11 with its link compliance, five per link came out adequate.
    """
    blocks = []
    flange_origin = rows.flange[:, :3, 3]
    force = rows.wrench[:, :3]
    for root, tip in _beams(cell, rows):
        start, end = rows.frames[:, root, :3, 3], rows.frames[:, tip, :3, 3]
        L = np.linalg.norm(end - start, axis=1, keepdims=True)
        moment = rows.wrench[:, 3:] + np.cross(flange_origin - end, force)
        axial, shear, torsion, bending, coupling = np.moveaxis(_spring(_axis_frame((end - start) / L), end, force, moment, rows.position), -1, 0)
        blocks += [axial * L, shear * L**3 / 3 + coupling * L**2 / 2 + bending * L, torsion * L]
    return np.stack(blocks, axis=-1) if blocks else np.zeros((len(rows), 3, 0))


def _tool_compliance(rows: Rows, cell: Cell) -> np.ndarray:
    """A 6-D spring at the flange, about the flange axis, loaded by the load's wrench at the flange origin (5 columns)."""
    return _spring(rows.flange[:, :3, :3], rows.flange[:, :3, 3], rows.wrench[:, :3], rows.wrench[:, 3:], rows.position)


def rated_torques(rows: Rows, cell: Cell) -> np.ndarray:
    """(nq,) each joint's rated torque, N·m (N for a prismatic joint): the URDF's effort limit, as the twin takes it.

    A joint whose URDF gives no effort limit (none, zero or infinite) takes its largest load torque in the rows
    instead (1 where it carries none).
    """
    effort = np.array(cell.robot.model.effortLimit, dtype=float)
    largest = np.abs(rows.load_torque).max(axis=0)
    fallback = np.where(largest > 0, largest, 1.0)
    return np.where(np.isfinite(effort) & (effort > 0), effort, fallback)


def _backlash(rows: Rows, cell: Cell, setting: tuple[float, bool, float] = (BACKLASH_HOLDS[0], False, 0.0)) -> np.ndarray:
    """Lost motion per joint in its two first-order forms: without and with memory (2·nq columns).

    Without memory the joint sits at the side its torque pushes it to in every
    state.  With memory (gears held in their play by friction) a joint whose
    torque stays within the band does not move: it keeps the side the previous
    state left it at, in the order of measurement, so that a wrist carrying a
    light tool unloaded keeps the side the last load took it to, and only a load
    that pushes it the other way shows the lost motion.  Where a joint's torque
    always leaves the band the two forms are one column, and the fit keeps one.
    A pose to predict (a test pose, a plan's candidate) is taken as a repeat: with
    memory, a joint whose unloaded torque stays within the band does not move.  A
    plan's candidate at its first loading after a load that took the plan joint to
    the other side (rows marked :data:`~bayescal.critique.covariates.REVERSED_MARKER`)
    has that joint start from the far side.
    With memory the band is the friction hold (a fraction of the joint's rated
    torque, :func:`rated_torques`), which a gear held in its play must be pushed beyond,
    and a joint driven to a new configuration arrives either on the side the
    previous state left it at or on the side its servo drove it to: ``setting`` is
    ``(hold, approached, shift)`` (:data:`BACKLASH_SETTINGS`), ``shift`` the error of the
    compensated joint's unloaded torque (:data:`BACKLASH_SHIFTS`).
    """
    hold, approached, shift = setting
    scale = np.abs(rows.load_torque).max(axis=0)
    scale = np.where(scale > 0, scale, 1.0 / BACKLASH_PRELOAD)
    static = rows.static_torque.copy()
    if cell.compensated_joint is not None:
        static[:, cell.compensated_joint] += shift * scale[cell.compensated_joint]
    width = BACKLASH_PRELOAD * scale
    change = np.tanh((static + rows.load_torque) / width) - np.tanh(static / width)
    held = hold * rated_torques(rows, cell)
    # A pose to predict has no order of measurement: with memory it is taken as a repeat, whose joints
    # move only where the unloaded torque leaves the band, and a plan does not count on the others.
    steady = np.tanh((static + rows.load_torque) / held) - np.tanh(static / held)
    steady = np.where(np.abs(static) > held, steady, 0.0)
    # A plan's first loading after a load that took the plan joint the other way: unloaded, that joint stays
    # on the far side unless its own torque leaves the band, and loaded it crosses where the load's does.
    joint = rows.plan_joint
    loaded = static[:, joint] + rows.load_torque[:, joint]
    unloaded_side = np.where(np.abs(static[:, joint]) > held[joint], np.tanh(static[:, joint] / held[joint]), -np.sign(loaded))
    reversed_ = steady.copy()
    reversed_[:, joint] = np.where(np.abs(loaded) > held[joint], np.tanh(loaded / held[joint]), unloaded_side) - unloaded_side
    predicted = (rows.marker == PREDICTED_MARKER)[:, np.newaxis]
    after_reversal = (rows.marker == REVERSED_MARKER)[:, np.newaxis]
    remembered = np.where(
        predicted, steady, np.where(after_reversal, reversed_, _remembered_change(rows, static, held, approached))
    )
    return np.concatenate([rows.point_jacobian * change[:, np.newaxis, :], rows.point_jacobian * remembered[:, np.newaxis, :]], axis=2)


def _hold_reading(setting: tuple[float, bool, float], rows: Rows, cell: Cell) -> dict:
    """The lost motion's friction hold, as a fraction of each joint's rated torque and in N·m per joint,
    what sets a joint's side on arriving at a configuration, and the error tried in the compensated joint's
    unloaded torque: the fraction, and what it comes to in N·m on each joint, of which only the compensated
    joint's entry is applied (the reading does not know which joint that is)."""
    hold, approached, shift = setting
    largest = np.abs(rows.load_torque).max(axis=0)
    return {
        "arrival_side": "driven" if approached else "kept",
        "hold_fraction_of_rated_torque": hold,
        "hold_Nm": [round(float(v), 1) for v in hold * rated_torques(rows, cell)],
        "compensated_joint_torque_shift_fraction": shift,
        "compensated_joint_torque_shift_Nm": [round(float(v), 1) for v in shift * largest],
    }


def _remembered_change(rows: Rows, static: np.ndarray, width: np.ndarray, approached: bool = False) -> np.ndarray:
    """(N, nq) change of each joint's side (-1 to 1) from the unloaded to the loaded reading, with memory.

    A joint's side follows its torque beyond ``width`` (``static`` (N, nq) unloaded,
    plus the load's when loaded; smoothed as the memoryless form) and otherwise
    stays where the previous state left it; the states run unloaded, loaded, for
    each repeat of each configuration in the order of measurement.  The first state's side is taken from its torque alone.  With
    ``approached``, a joint whose commanded angle changed from the previous
    configuration by more than :data:`APPROACH_MOVE` arrives on the side opposite
    to its move (its link lagging the motor that drove it).
    """
    order = rows.order
    first = np.unique(order, return_index=True)[1]
    side = np.tanh(static[first[0]] / width)
    loaded_side, unloaded_side = np.empty((first.size, width.size)), np.empty((first.size, width.size))
    for k, i in enumerate(first):
        if approached and k > 0:
            move = rows.commanded[i] - rows.commanded[first[k - 1]]
            side = np.where(np.abs(move) > APPROACH_MOVE, -np.sign(move), side)
        for state, torque in ((unloaded_side, static[i]), (loaded_side, static[i] + rows.load_torque[i])):
            push = np.tanh(torque / width)
            side = np.where(np.abs(torque) > width, push, side)
            state[k] = side
    return (loaded_side - unloaded_side)[np.searchsorted(np.unique(order), order)]


def _nonlinear_stiffness(rows: Rows, cell: Cell) -> np.ndarray:
    loaded = rows.static_torque + rows.load_torque
    change = loaded * np.abs(loaded) - rows.static_torque * np.abs(rows.static_torque)
    # Scaled by the largest torque so that the parameter is a compliance change at that torque.
    scale = np.maximum(np.abs(loaded).max(axis=0), 1.0)
    return rows.point_jacobian * (change / scale)[:, np.newaxis, :]


def _drift(rows: Rows, cell: Cell) -> np.ndarray:
    """The tracker's frame moving between each row's unloaded and loaded reading, as the campaign's readings of one
    state repeated in time show it (:func:`~bayescal.critique.drift.drift_evidence`: the frame's steady rate and the
    walk of what it leaves, each repeat's rows from the drift fitted to the other repeats): one column, the drift's amplitude (1 where the evidence
    is right).

    Its direction comes from readings the deflections do not enter, so that it cannot take up a load-correlated
    misfit (the twelve free frame-motion columns fitted to the deflections did: they tied with every link and tool
    compliance on the independent generator).  Without that evidence there is no column, and the critique says the
    drift is not testable on the campaign.
    """
    evidence = drift_evidence(rows, cell)
    if not evidence.testable:
        return np.zeros((len(rows), 3, 0))
    return drift_deflection(evidence, rows)[0][:, :, np.newaxis]


def _no_columns(rows: Rows, cell: Cell) -> np.ndarray:
    return np.zeros((len(rows), 3, 0))


CATALOGUE: dict[str, Extension] = {
    e.name: e
    for e in (
        Extension("compensator", "joint 2's compliance varies with q2 as a spring compensator makes it (eq 8)", _compensator),
        Extension("link_compliance", "the long links bend and twist under the load", _link_compliance),
        Extension("tool_compliance", "the tool tilts on its mount at the flange", _tool_compliance),
        Extension("backlash", "lost motion in the joints where the load reverses their torque", _backlash, grid=BACKLASH_SETTINGS, describe=_hold_reading),
        Extension("nonlinear_stiffness", "joint stiffness that changes with the torque carried", _nonlinear_stiffness),
        Extension("outliers", "heavy-tailed (Student-t) tracker errors", _no_columns, robust=True),
        Extension("drift", "the tracker's frame moves between the unloaded and the loaded reading, as repeated readings show", _drift, physical=False),
    )
}
"""The physical extensions, named as the digital twin's effects."""

PLANNABLE: tuple[str, ...] = tuple(name for name, e in CATALOGUE.items() if e.physical and not e.robust)
"""The candidates a plan can separate (``plan --criterion discriminate``): physical deflections, not a noise model."""


def _per_axis(values: np.ndarray) -> np.ndarray:
    """(N, 3, 3m): each of the m covariates as an offset along each base axis."""
    values = np.asarray(values, dtype=float).reshape(len(values), -1)
    eye = np.eye(3)
    return (values[:, np.newaxis, :, np.newaxis] * eye[np.newaxis, :, np.newaxis, :]).reshape(len(values), 3, -1)


def _standardised(values: np.ndarray) -> np.ndarray:
    values = np.asarray(values, dtype=float).reshape(len(values), -1)
    spread = values.std(axis=0)
    return (values - values.mean(axis=0)) / np.where(spread > 0, spread, 1.0)


def _probe(covariate: Callable[[Rows], np.ndarray]) -> Callable[[Rows, Cell], np.ndarray]:
    def columns(rows: Rows, cell: Cell) -> np.ndarray:
        # Residual offsets in mm-sized units so that every probe column has the deflections' scale.
        return _per_axis(covariate(rows)) * np.abs(rows.y).mean()

    return columns


def _markers(rows: Rows) -> np.ndarray:
    names = np.unique(rows.marker)
    return (rows.marker[:, np.newaxis] == names[np.newaxis, :]).astype(float)


def _lever(rows: Rows) -> np.ndarray:
    """(N, 3) each marker's place on the tool, m: its mean over the campaign's rows.

    A row's own estimate comes from its unloaded reading, whose noise is also in
    its deflection; standardised, a coordinate the markers share (all 200 mm out
    on the KR-270 tool) would be that noise alone, and the probe would fit it
    (36 nats on a 30-configuration plan without any effect).
    """
    names, index = np.unique(rows.marker, return_inverse=True)
    means = np.array([rows.point[index == k].mean(axis=0) for k in range(len(names))])
    return means[index]


def _q2(rows: Rows) -> np.ndarray:
    q2 = rows.q[:, rows.plan_joint]
    return np.column_stack([q2, q2**2])


_COVARIATE_VALUES: dict[str, Callable[[Rows], np.ndarray]] = {
    "q2": _q2,
    "other joints": lambda rows: np.delete(rows.q, rows.plan_joint, axis=1),
    "torques": lambda rows: rows.load_torque,
    "torque signs": lambda rows: np.sign(rows.static_torque + rows.load_torque),
    "load": lambda rows: rows.wrench[:, :3],
    "reach": lambda rows: np.hypot(rows.position[:, 0], rows.position[:, 1]),
    "marker": _markers,
    "lever": _lever,
    "tracker distance": lambda rows: rows.tracker_distance,
    "order": lambda rows: np.column_stack([rows.order, rows.order**2]).astype(float),
}

PROBES: dict[str, Extension] = {
    name: Extension(name, f"residuals follow {COVARIATES[name]}", _probe(lambda rows, f=values: _standardised(f(rows))), physical=False)
    for name, values in _COVARIATE_VALUES.items()
}
"""Residual offsets along each base axis that follow one covariate (not physics: for naming an unexplained misfit)."""
