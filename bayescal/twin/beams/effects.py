"""The effects the generator can plant, one per campaign, each scaled by a ``magnitude`` (1 = the default, 0 = none).

Physical effects change the robot (:func:`plant`); ``outliers`` and ``drift`` change the
readings (``bayescal.twin.beams.campaign``).  What each default does to a Table III
campaign, measured on this generator, is in ``docs/generators.md``.

* ``compensator``: the coil spring is blended, by the magnitude (1: wholly), into a
  hydropneumatic one with the same force when the arm is horizontal and :data:`GAS_RATE`
  times its rate there, progressive with the rod's draw
  (:class:`~bayescal.twin.beams.robot.Compensator`).
* ``link_compliance``: the upper arm's and forearm's beams ``1 + LINK_SOFTENING × magnitude``
  times as compliant (a lighter casting, or cracks).
* ``tool_compliance``: the tool mount's hinge ``1 + HINGE_SOFTENING × magnitude`` times as compliant
  (loose bolts, a worn tool changer).
* ``lost_motion``: every gear has a play band (:data:`PLAY_URAD` × magnitude) in which friction
  holds the joint; a torque above :data:`FRICTION_FRACTION` of the gear's rated torque pushes it
  to the band's edge on its side, a move leaves it at the edge lagging the motion.
* ``nonlinear_stiffness``: every gear stiffens with its torque, ``(1 + α|τ|/τ_rated)`` times its
  stiffness at rest, α = :data:`HARDENING` × magnitude.
* ``outliers``: :data:`OUTLIER_COUNT` readings of a campaign each off by a gross error in a random
  direction, of length drawn in :data:`OUTLIER_MM` × magnitude (a reflector lifted off its nest,
  a beam re-acquired on the prism's edge).
* ``drift``: the tracker frame's drift (:class:`~bayescal.twin.beams.tracker.Drift`) × magnitude.
"""

from __future__ import annotations

import numpy as np

from bayescal.errors import InputError
from bayescal.twin.beams.robot import Robot

__all__ = ["EFFECTS", "plant", "GAS_RATE", "LINK_SOFTENING", "HINGE_SOFTENING", "PLAY_URAD", "FRICTION_FRACTION", "HARDENING", "OUTLIER_COUNT", "OUTLIER_MM"]

EFFECTS = ("none", "compensator", "link_compliance", "tool_compliance", "lost_motion", "nonlinear_stiffness", "outliers", "drift")
"""The effects, in the order the documentation lists them."""

GAS_RATE = 2.0
"""The hydropneumatic spring's rate with the arm horizontal, in the coil spring's: twice it."""
LINK_SOFTENING = 1.0
"""Extra compliance of the beams at magnitude 1: twice as compliant."""
HINGE_SOFTENING = 3.0
"""Extra compliance of the tool mount at magnitude 1: four times as compliant."""
PLAY_URAD = np.array([40.0, 40.0, 40.0, 150.0, 150.0, 150.0])
"""Each gear's lost-motion band at magnitude 1 (μrad): 8 and 31 arcsec, within a reducer's 1 arcmin
lost-motion rating (which includes its elastic wind-up at 3 % of rated torque)."""
FRICTION_FRACTION = 0.02
"""Torque that moves a joint across its play, as a fraction of its rated torque (an ESTIMATE)."""
HARDENING = 0.10
"""α of the gears' stiffening at magnitude 1: 10 % stiffer at the rated torque than at rest."""
OUTLIER_COUNT = 3
"""Gross reading errors in a campaign (3 of 270 readings of Table III with three repeats)."""
OUTLIER_MM = (0.3, 1.0)
"""Range (mm) of each gross error's length at magnitude 1."""


def check_effect(effect: str, magnitude: float) -> None:
    """Refuse an unknown effect or a magnitude that is negative or not finite."""
    if effect not in EFFECTS:
        raise InputError(f"unknown effect '{effect}'; expected one of {', '.join(EFFECTS)}", column="effect")
    if not (np.isfinite(magnitude) and magnitude >= 0):
        raise InputError(f"the magnitude must be a finite number >= 0 (1 is the default size), got {magnitude}", column="magnitude")


def plant(robot: Robot, effect: str, magnitude: float) -> tuple[Robot, dict]:
    """The robot with a physical ``effect`` of ``magnitude`` planted, and what was planted (units in the keys).

    ``outliers``, ``drift`` and ``none`` leave the robot as it is.
    """
    check_effect(effect, magnitude)
    if effect == "compensator":
        c = robot.compensator
        length = c.polytropic * c.e_ref / GAS_RATE
        planted = robot.with_compensator(gas=float(magnitude), gas_length=length)
        return planted, {"gas_blend": float(magnitude), "gas_length_mm": length * 1e3, "polytropic_exponent": c.polytropic, "rate_factor_at_q2_0": GAS_RATE}
    if effect == "link_compliance":
        factor = 1 + LINK_SOFTENING * magnitude
        names = tuple(item.name for item in robot.items if item.kind == "elastic" and item.name != "tool mount hinge")
        return robot.with_elastic(names, factor), {"beam_compliance_factor": factor, "beams": list(names)}
    if effect == "tool_compliance":
        factor = 1 + HINGE_SOFTENING * magnitude
        return robot.with_elastic(("tool mount hinge",), factor), {"hinge_compliance_factor": factor}
    if effect == "lost_motion":
        play = PLAY_URAD * 1e-6 * magnitude
        friction = FRICTION_FRACTION * robot.joints.rated
        planted = robot.with_joints(play=play, friction=friction)
        return planted, {"play_urad": (play * 1e6).tolist(), "friction_Nm": friction.tolist()}
    if effect == "nonlinear_stiffness":
        alpha = HARDENING * magnitude
        return robot.with_joints(hardening=alpha), {"hardening_at_rated_torque": alpha, "rated_torque_Nm": robot.joints.rated.tolist()}
    return robot, {}
