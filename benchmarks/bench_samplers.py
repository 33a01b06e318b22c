"""Effective samples per second: the partially collapsed Gibbs sampler against emcee on one posterior.

The posterior is the compensated model (eq 8) of the linear deflection model
for a Table III campaign simulated on the digital twin (seed 1), with the
compensator geometry sampled from its Table II prior.  Both samplers run in
this process, one after the other; ESS is ArviZ's bulk ESS over all chains,
and the figure of merit is the smallest ESS over the parameters divided by
the sampler's wall time.
"""

from __future__ import annotations

import time
import warnings

import arviz as az
import numpy as np

from bayescal.cell.config import load_cell
from bayescal.inference.elastostatic import closed_form, config_geometry, deflection_equations
from bayescal.sampling.gibbs import GibbsSampler
from bayescal.inference.identifiability import analyse
from bayescal.inference.likelihood import CompensatedPosterior
from bayescal.robot.compensator import COMPENSATED_JOINT
from bayescal.cell.plan import read_plan
from bayescal.sampling.ensemble import EnsembleSampler
from bayescal.twin.simulator import DigitalTwin


def build_posterior():
    cell = load_cell("data/kr270.toml")
    plan = read_plan("data/table3_plan.csv", cell.robot)
    campaign = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(1))
    equations, torque, _ = deflection_equations(cell.robot, campaign, tracker=cell.tracker)
    equations = equations.whitened()
    configs = np.unique(campaign.config, return_index=True)[1]
    ident = analyse(equations.per_angle_design(), equations.per_angle_columns(), equations.q2, torque[configs], equations.angle[3 * configs])
    geometry = config_geometry(cell.compensator)
    cf = closed_form(equations, ident, geometry.mean)
    joints = tuple(j for j in range(6) if j != COMPENSATED_JOINT and f"k{j + 1}" not in ident.reasons)
    posterior = CompensatedPosterior(equations, joints, geometry)
    spring = cf.spring
    if not np.isfinite(posterior.log_prob(posterior.start(cf.compliances[list(joints)], spring, cf.sigma))):
        spring = np.array([1.0 / cell.compliances[COMPENSATED_JOINT], cell.compensator.K_c, cell.compensator.s0])
    start = posterior.start(cf.compliances[list(joints)], spring, cf.sigma)
    sd = np.sqrt(np.diag(cf.cov))
    columns = [c for c, keep in zip(equations.per_angle_columns(), ident.identifiable) if keep]
    scale = np.concatenate(
        [
            [sd[columns.index((j, None))] for j in joints],
            np.abs(spring) * [0.005, 0.05, 0.02],
            np.sqrt(np.diag(geometry.cov)),
            np.full(cf.sigma.size, 0.05),
        ]
    )
    return posterior, start, scale


def measure(name, run, names):
    began = time.perf_counter()
    draws = run()
    seconds = time.perf_counter() - began
    ess = np.array([float(az.ess(draws[:, :, i], method="bulk")) for i in range(draws.shape[-1])])
    worst = int(np.argmin(ess))
    print(f"{name:<7} {seconds:8.1f} s  {draws.shape[0]} chains x {draws.shape[1]} draws  "
          f"min ESS {ess[worst]:7.0f} ({names[worst]})  ESS/s {ess[worst] / seconds:8.1f}")
    return ess[worst] / seconds


def main() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        posterior, start, scale = build_posterior()
    names = posterior.names()
    print(f"posterior: {posterior.ndim} parameters ({', '.join(names)}), {posterior.equations.n} equations")
    rng = np.random.default_rng(0)
    gibbs = measure("gibbs", lambda: GibbsSampler(n_chains=4, n_tune=500, n_draws=1500).sample_compensated(posterior, start, rng), names)
    emcee = measure(
        "emcee", lambda: EnsembleSampler(n_chains=4, n_tune=2000, n_draws=500).sample(posterior.log_prob, start, scale, rng), names
    )
    print(f"Gibbs / emcee ESS per second: {gibbs / emcee:.1f}")


if __name__ == "__main__":
    main()
