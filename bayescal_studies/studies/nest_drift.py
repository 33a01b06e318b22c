"""The tracker's drift measured from reference nests, and the calibration after its removal, on planted drifts.

:func:`nest_drift_coverage` plants the independent generator's ``thermal_drift`` (a steady
translation, a 30 min cycle and a turn about the tracker) in random-plan campaigns read with
the generator's reference nests (:data:`~bayescal.twin.independent.generator.NESTS`), or the
twin's drift (:mod:`bayescal.twin.drift`) in Table III campaigns read with its nests, fits the
drift to the nests alone (:mod:`bayescal.registration.nest_drift`) and measures

* the drift at every reading (unloaded and loaded) and in every deflection against the planted
  one, in the estimate's own sd (the planted drift taken relative to the first nest reading,
  the estimate's gauge);
* the identifiable compliances calibrated after the drift's removal, and without it, in their
  posterior sd against the generator's truth.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from concurrent.futures import Executor
from os import PathLike

import numpy as np
import pandas as pd

__all__ = ["nest_drift_coverage", "NEST_DRIFT_FIRST_SEED"]

NEST_DRIFT_FIRST_SEED = 9000
"""Campaign ``k`` is seeded ``NEST_DRIFT_FIRST_SEED + k``, as the independent generator's other studies."""


def _within(z: np.ndarray) -> dict:
    """Fractions of ``|z|`` within 1, 2 and 3."""
    z = np.abs(np.ravel(z))
    return {f"within_{k}sd": float(np.mean(z <= k)) for k in (1, 2, 3)}


def _compliance_z(campaign, compliances: np.ndarray, cell, rng) -> dict:
    """The identifiable compliances' errors in posterior sd, by name."""
    from bayescal.inference.elastostatic import EXTENSIONS, ElastostaticModel
    from bayescal.inference.samplers import elastostatic_sampler
    from bayescal.units import URAD_PER_NM

    model = ElastostaticModel.from_cell(cell, None, model="exact", sampler=elastostatic_sampler("collapsed"), extensions=EXTENSIONS)
    parameters = model.fit(campaign, rng).parameters()
    z = {}
    for j, true in enumerate(compliances / URAD_PER_NM):
        entry = parameters.get(f"k{j + 1}", {})
        if "mean" in entry:
            z[f"k{j + 1}"] = (entry["mean"] - true) / entry["sd"]
    return z


def _independent(magnitude: float, rng: np.random.Generator, cell):
    """A random-plan campaign of the independent generator with ``thermal_drift``, its nests, the planted drift
    (a function of points and times) and the true compliances."""
    from bayescal.twin.independent import IndependentGenerator, random_plan

    campaign, truth = IndependentGenerator(cell, rng).simulate(random_plan(cell, rng), 3, "thermal_drift", magnitude, nests=True)
    drift = truth.world.drift
    return campaign, truth.nests, lambda points, times: drift.apply(points, times, cell.tracker.position) - points, truth.world.compliances


def _twin(magnitude: float, rng: np.random.Generator, cell, plan):
    """A campaign of the twin on ``plan`` with its drift at ``magnitude`` times the default, its nests, the planted drift
    at the campaign's readings and the cell's compliances."""
    from bayescal.twin.drift import TrackerDrift
    from bayescal.twin.simulator import DigitalTwin

    state = rng.bit_generator.state
    campaign, nests = DigitalTwin(cell, drift=TrackerDrift(TrackerDrift.default * magnitude)).simulate_with_nests(plan, 3, rng)
    rng.bit_generator.state = state
    # the same draws without the drift: the difference is the planted drift at each reading
    still, _ = DigitalTwin(cell).simulate_with_nests(plan, 3, rng)
    moved = {0: campaign.p0 - still.p0, 1: campaign.p1 - still.p1}
    return campaign, nests, moved, cell.compliances


def _one(case: tuple, rng: np.random.Generator, cell, plan) -> dict:
    """One campaign (a task of :func:`~bayescal.design.parallel.seeded_map`)."""
    from bayescal.registration.nest_drift import fit_nest_drift

    generator, magnitude, seed = case
    if generator == "independent":
        campaign, nests, drift, compliances = _independent(magnitude, rng, cell)
    else:
        campaign, nests, drift, compliances = _twin(magnitude, rng, cell, plan)
    track = fit_nest_drift(nests, cell.tracker)

    def planted(state: int) -> np.ndarray:
        """The planted drift at each row's reading, relative to the first nest reading (the estimate's gauge)."""
        points, times = (campaign.p0, campaign.times[:, 0]) if state == 0 else (campaign.p1, campaign.times[:, 1])
        if callable(drift):
            return drift(points, times) - drift(points, np.full(len(times), track.knots[0]))
        # the twin's drift is zero at time 0, 45 s before the first nest reading's time, where the frame has moved by less than
        # a micrometre at the default rate (its random walk's sd over 45 s is 1.9 μm at 0.2 mm/h)
        return drift[state] - track.motion(points, np.full(len(times), track.knots[0]))[0]

    readings = []
    for state, (p, t) in enumerate(((campaign.p0, campaign.times[:, 0]), (campaign.p1, campaign.times[:, 1]))):
        mean, cov = track.motion(p, t)
        readings.append((mean - planted(state)) / np.sqrt(np.einsum("kii->ki", cov)))
    mean, cov = track.deflection(campaign)
    truth_deflection = planted(1) - planted(0)
    deflection = (mean - truth_deflection) / np.sqrt(np.einsum("kii->ki", cov))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        removed = _compliance_z(track.remove(campaign), compliances, cell, rng)
        kept = _compliance_z(campaign, compliances, cell, rng)
    row = {"generator": generator, "magnitude": magnitude, "seed": seed, "diffusion_m2_per_s": track.diffusion,
           "planted_deflection_rms_um": float(np.sqrt(np.mean(truth_deflection**2)) * 1e6)}
    row |= {f"reading_{k}": v for k, v in _within(np.concatenate(readings)).items()}
    row |= {f"deflection_{k}": v for k, v in _within(deflection).items()}
    row |= {f"removed_z_{name}": v for name, v in removed.items()} | {f"kept_z_{name}": v for name, v in kept.items()}
    return row


def nest_drift_coverage(
    config: str | PathLike[str],
    magnitudes: Sequence[float] = (1.0,),
    *,
    generator: str = "independent",
    plan_path: str | PathLike[str] = "data/table3_plan.csv",
    n_seeds: int = 100,
    first_seed: int = NEST_DRIFT_FIRST_SEED,
    executor: Executor | None = None,
    progress: str | None = None,
) -> pd.DataFrame:
    """The drift measured from the nests, and the compliances after its removal, on ``n_seeds`` campaigns per magnitude.

    Parameters
    ----------
    config
        The cell TOML around which the generator draws its truths.
    magnitudes
        Multiples of the drift's default (0.2 mm/h on both generators).
    generator
        ``"independent"``: :mod:`bayescal.twin.independent`'s ``thermal_drift`` on random plans; ``"twin"``: the
        twin's :class:`~bayescal.twin.drift.TrackerDrift` on the plan of ``plan_path``.
    executor, progress
        As :func:`~bayescal.design.parallel.seeded_map` takes them.

    Returns
    -------
    pandas.DataFrame
        One row per campaign: ``generator, magnitude, seed``, the diffusion chosen (m²/s), the planted drift's rms in the
        deflections (μm); ``reading_within_{1,2,3}sd`` and ``deflection_within_{1,2,3}sd``, the fractions of the
        readings' and the deflections' coordinates whose drift lies within 1, 2, 3 sd of the estimate; and
        ``removed_z_k<j>`` / ``kept_z_k<j>``, each identifiable compliance's error in posterior sd, calibrated after
        the drift's removal and without it.
    """
    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import read_plan
    from bayescal.design.parallel import seeded_map

    cell = load_cell(config)
    plan = read_plan(plan_path, cell.robot) if generator == "twin" else None
    tasks = [(generator, float(m), first_seed + k) for m in magnitudes for k in range(n_seeds)]
    streams = [np.random.SeedSequence(seed) for *_, seed in tasks]
    rows = seeded_map(_one, tasks, streams, executor=executor, progress=progress, cell=cell, plan=plan)
    return pd.DataFrame.from_records(rows)
