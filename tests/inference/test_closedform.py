"""Tests of bayescal.inference.closedform: eqs 33-34 recover what noiseless linear equations were built from."""

from __future__ import annotations

import dataclasses

import numpy as np

from bayescal.inference.closedform import closed_form
from bayescal.inference.equations import deflection_equations
from bayescal.inference.identifiability import analyse


def _equations(cell, campaign):
    equations, torque, _ = deflection_equations(cell.robot, campaign, tracker=cell.tracker, joint=cell.compensated_joint)
    configs = np.unique(campaign.config, return_index=True)[1]
    ident = analyse(
        equations.whitened().per_angle_design(), equations.per_angle_columns(), equations.compensated_angles, torque[configs], equations.angle[3 * configs]
    )
    return equations, ident


def test_noiseless_linear_deflections_give_back_the_compliances_and_the_spring(cell, twin_campaign):
    campaign = twin_campaign(seed=3, repeats=1)
    equations, ident = _equations(cell, campaign)
    geometry = cell.compensator.geometry
    K0, K_c, s0 = 1.0 / cell.compliances[equations.joint], cell.compensator.K_c, cell.compensator.s0
    # the per-angle joint-2 compliances of eq 8 at the campaign's angles, from a spring 20 times the cell's
    w = np.array([K0, 20 * K_c, 20 * K_c * s0])
    k2 = 1.0 / (geometry.regressor(equations.compensated_angles) @ w)
    truth = np.array([k2[angle] if angle is not None else cell.compliances[joint] for joint, angle in equations.per_angle_columns()])
    keep = ident.identifiable
    noiseless = dataclasses.replace(equations, y=equations.per_angle_design()[:, keep] @ truth[keep])
    cf = closed_form(noiseless, ident, np.array([geometry.L, geometry.a_x, geometry.a_y, geometry.phi]))
    np.testing.assert_allclose(cf.per_angle, truth[keep], rtol=1e-9)
    np.testing.assert_allclose(cf.k2, k2, rtol=1e-9)
    identified = [joint for (joint, angle), k in zip(equations.per_angle_columns(), keep) if k and angle is None]
    np.testing.assert_allclose(cf.compliances[identified], cell.compliances[identified], rtol=1e-9)
    assert ident.compensator
    np.testing.assert_allclose(cf.spring, [K0, 20 * K_c, s0], rtol=1e-6)
    # no residual: the covariance of eq 37 collapses
    assert np.all(np.diag(cf.cov) < 1e-20 * np.abs(cf.per_angle) ** 2 + 1e-40)


def test_the_covariance_scales_with_the_noise(cell, twin_campaign):
    campaign = twin_campaign(seed=4, repeats=1)
    equations, ident = _equations(cell, campaign)
    geometry = cell.compensator.geometry
    g = np.array([geometry.L, geometry.a_x, geometry.a_y, geometry.phi])
    noise = np.random.default_rng(0).standard_normal(equations.n) * 1e-6
    base = closed_form(dataclasses.replace(equations, y=equations.y + noise), ident, g)
    double = closed_form(dataclasses.replace(equations, y=equations.y + 2 * noise), ident, g)
    # the estimates move linearly with the data, their covariance with its square
    np.testing.assert_allclose(double.per_angle - base.per_angle, base.per_angle - closed_form(equations, ident, g).per_angle, rtol=1e-6, atol=1e-15)
    assert np.sqrt(np.diag(double.cov)).sum() > np.sqrt(np.diag(base.cov)).sum()
    assert base.sigma.shape == (len(equations.group_names),) and np.all(base.sigma > 0)
