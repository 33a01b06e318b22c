"""The linear compliance map of a pose and the spread of the posterior draws through it (eqs 31, 38).

At a pose ``q`` with a wrench ``w`` at the flange origin the tool point's
deflection is, to first order, ``A k`` with ``A[:, j] = J_p[:, j] (J_F[:, j]·w)``
(eq 31) and ``k`` the joints' equivalent compliances (the compensator included,
eq 8).  Compensation applies one prediction (the draws' medians,
:mod:`bayescal.compensation.budget`); a draw ``k_s`` would have deflected the tool by
``A (k_s - k_applied)`` more: the error left.  With
``A`` computed once per pose, every draw is applied by one matrix product.
Both the test-pose prediction (eq 38) and the program compensation use these
functions: one code path.
"""

from __future__ import annotations

import numpy as np

from bayescal.robot.batched import BatchedChain, Poses

__all__ = ["THREE_SIGMA", "designs", "deflection_draws", "error_quantiles"]

THREE_SIGMA = 0.9973
"""Two-sided probability of ±3σ of a normal distribution (the paper's interval)."""


def designs(chain: BatchedChain, q: np.ndarray, points: np.ndarray, wrenches: np.ndarray, *, poses: Poses | None = None) -> np.ndarray:
    """``(P, 3, n)`` matrices ``A`` of eq 31, one per pose, all poses at once.

    Parameters
    ----------
    chain
        The robot's batched chain (:meth:`BatchedChain.of <bayescal.robot.batched.BatchedChain.of>`).
    q
        ``(P, n)`` joint angles, rad.
    points
        ``(P, 3)`` tool points in the flange frame, m.
    wrenches
        ``(P, 6)`` wrenches at the flange origin, base axes, N and N·m.
    poses
        ``chain.poses(q)``, when already computed.
    """
    poses = chain.poses(q) if poses is None else poses
    flange_linear, flange_angular = chain.point_jacobian(poses, poses.flange_origin)
    torques = np.einsum("pjc,pc->pj", flange_linear, wrenches[:, :3]) + np.einsum("pjc,pc->pj", flange_angular, wrenches[:, 3:])
    linear, _ = chain.point_jacobian(poses, poses.points(points))
    return np.swapaxes(linear, 1, 2) * torques[:, np.newaxis, :]


def deflection_draws(design: np.ndarray, compliances: np.ndarray, varying: np.ndarray | None = None, joint: int | None = None) -> np.ndarray:
    """``(P, 3, S)`` deflections ``A_p k_s`` (m) of ``S`` compliance draws through ``(P, 3, n)`` designs.

    Parameters
    ----------
    design
        ``(P, 3, n)`` eq-31 matrices.
    compliances
        ``(S, n)`` joint compliances of each draw, rad/(N·m).
    varying
        ``(P, S)`` compliance of joint ``joint`` that varies from pose to pose (the compensated
        joint's, eq 8); it replaces that column of ``compliances``.
    joint
        The joint of ``varying``.

    The draws are the last axis, so that a pose's draws are contiguous for the quantiles.
    """
    P, _, n = design.shape
    if varying is not None:
        compliances = compliances.copy()
        compliances[:, joint] = 0.0
    out = (design.reshape(P * 3, n) @ compliances.T).reshape(P, 3, -1)
    if varying is not None:
        out += design[:, :, joint, None] * varying[:, None, :]
    return out


def error_quantiles(errors: np.ndarray) -> dict[str, np.ndarray]:
    """Root-mean-square, 95 % and 99.73 % quantiles over the draws (last axis) of error lengths (m)."""
    q95, q9973 = np.quantile(errors, [0.95, THREE_SIGMA], axis=-1)
    return {"rms": np.sqrt(np.mean(errors**2, axis=-1)), "q95": q95, "q9973": q9973}
