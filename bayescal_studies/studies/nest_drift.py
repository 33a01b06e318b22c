"""The tracker's drift measured from reference nests or repeats, and the calibration after its removal, on planted drifts.

:func:`nest_drift_coverage` plants the independent generator's ``thermal_drift`` (a steady
translation, a 30 min cycle and a turn about the tracker) in random-plan campaigns read with
the generator's reference nests (:data:`~bayescal.twin.independent.generator.NESTS`), or the
twin's drift (:mod:`bayescal.twin.drift`) in Table III campaigns read with its nests, fits the
drift (:mod:`bayescal.registration.repeats`) to the nests and the repeat groups together, or to
the repeat groups alone (the twin's campaigns then measured in passes, the plan once per repeat;
the independent generator's repeats stay back to back), and measures

* the drift at every reading (unloaded and loaded) and in every deflection against the planted
  one, in the estimate's own sd (the planted drift taken relative to the first reading of the
  walk, the estimate's gauge);
* the identifiable compliances calibrated after the drift's removal (its variance added per
  row), integrated over draws of the drift as ``calibrate`` integrates it (one calibration per
  draw removed, their draws pooled), and without any removal, in their posterior sd against the
  generator's truth.
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
    """Fractions of ``|z|`` within 1, 2 and 3 (the gauge's reading, of zero error and sd, left out)."""
    z = np.abs(np.ravel(z))
    z = z[np.isfinite(z)]
    return {f"within_{k}sd": float(np.mean(z <= k)) for k in (1, 2, 3)}


def _posterior(campaign, cell, rng) -> dict:
    """The identifiable compliances' posterior (mean, sd) by name, in the parameters' units."""
    from bayescal.inference.elastostatic import EXTENSIONS, ElastostaticModel
    from bayescal.inference.samplers import elastostatic_sampler

    model = ElastostaticModel.from_cell(cell, None, model="exact", sampler=elastostatic_sampler("collapsed"), extensions=EXTENSIONS)
    parameters = model.fit(campaign, rng).parameters()
    return {name: (entry["mean"], entry["sd"]) for name, entry in parameters.items() if name[0] == "k" and "mean" in entry}


def _compliance_z(posterior: dict, compliances: np.ndarray) -> dict:
    """The identifiable compliances' errors in posterior sd, by name."""
    from bayescal.units import URAD_PER_NM

    true = {f"k{j + 1}": value for j, value in enumerate(compliances / URAD_PER_NM)}
    return {name: (mean - true[name]) / sd for name, (mean, sd) in posterior.items() if name in true}


def _integrated(track, campaign, cell, rng, n_draws: int) -> dict:
    """The compliances' posterior integrated over draws of the drift as ``calibrate`` integrates it
    (:func:`~bayescal.inference.mixture.fit_integrated`: one calibration per draw removed, the fits' draws pooled), for
    the first 2, 4, … and all ``n_draws`` draws of the same fits, by count."""
    from bayescal.inference.elastostatic import EXTENSIONS, ElastostaticModel
    from bayescal.inference.samplers import elastostatic_sampler
    from bayescal.sampling.summary import pooled_tree, summarize

    model = ElastostaticModel.from_cell(cell, None, model="exact", sampler=elastostatic_sampler("collapsed"), extensions=EXTENSIONS)
    fits = [model.fit(draw, rng, checks=False) for draw in track.removed_draws(campaign, rng, n_draws)]
    names = [name for name, entry in fits[0].parameters().items() if name[0] == "k" and "mean" in entry]
    counts = sorted({*(2 ** np.arange(1, int(np.log2(n_draws)) + 1)), n_draws})
    out = {}
    for count in counts:
        summary = summarize(pooled_tree([fit.tree for fit in fits[:count]]))
        out[count] = {name: (float(summary.loc[name, "mean"]), float(summary.loc[name, "sd"])) for name in names}
    return out


def _independent(magnitude: float, rng: np.random.Generator, cell):
    """A random-plan campaign of the independent generator with ``thermal_drift``, its nests, the planted drift
    (a function of points and times) and the true compliances."""
    from bayescal.twin.independent import IndependentGenerator, random_plan

    campaign, truth = IndependentGenerator(cell, rng).simulate(random_plan(cell, rng), 3, "thermal_drift", magnitude, nests=True)
    drift = truth.world.drift
    return campaign, truth.nests, lambda points, times: drift.apply(points, times, cell.tracker.position) - points, truth.world.compliances


def _twin(magnitude: float, rng: np.random.Generator, cell, plan, passes: bool):
    """A campaign of the twin on ``plan`` (measured in passes if asked) with its drift at ``magnitude`` times the
    default, its nests, the planted drift at the campaign's readings and the cell's compliances."""
    from bayescal.twin.drift import TrackerDrift
    from bayescal.twin.simulator import DigitalTwin

    state = rng.bit_generator.state
    drift = TrackerDrift(TrackerDrift.default * magnitude)
    campaign, nests = DigitalTwin(cell, drift=drift, passes=passes).simulate_with_nests(plan, 3, rng)
    rng.bit_generator.state = state
    # the same draws without the drift: the difference is the planted drift at each reading
    still, _ = DigitalTwin(cell, passes=passes).simulate_with_nests(plan, 3, rng)
    moved = {0: campaign.p0 - still.p0, 1: campaign.p1 - still.p1}
    return campaign, nests, moved, cell.compliances


def _planted(drift, campaign, track) -> tuple[np.ndarray, np.ndarray]:
    """The planted drift at each row's unloaded and loaded reading (N, 3) m, relative to the walk's gauge (its first
    knot)."""
    readings = ((campaign.p0, campaign.times[:, 0]), (campaign.p1, campaign.times[:, 1]))
    if callable(drift):
        return tuple(drift(p, t) - drift(p, np.full(len(t), track.knots[0])) for p, t in readings)
    # The twin's drift is known at the readings only: the gauge is a reading's time (repeats alone; the planted drift
    # at that reading is then taken from all, the turn over the markers' spread neglected, nanometres) or a nest
    # reading's 45 s after time 0, where the twin's frame is zero (its walk's sd over 45 s is 1.9 μm at 0.2 mm/h).
    at = np.flatnonzero(np.concatenate([campaign.times[:, 0], campaign.times[:, 1]]) == track.knots[0])
    offset = np.concatenate([drift[0], drift[1]])[at[0]] if at.size else 0.0
    return drift[0] - offset, drift[1] - offset


def _one(case: tuple, rng: np.random.Generator, cell, plan, n_draws: int) -> dict:
    """One campaign (a task of :func:`~bayescal.design.parallel.seeded_map`)."""
    from bayescal.registration.repeats import fit_drift

    generator, magnitude, seed, evidence = case
    if generator == "independent":
        campaign, nests, drift, compliances = _independent(magnitude, rng, cell)
    else:
        campaign, nests, drift, compliances = _twin(magnitude, rng, cell, plan, passes=evidence == "repeats")
    track = fit_drift(campaign, cell.tracker, None if evidence == "repeats" else nests, repeats=evidence != "nests")
    planted = _planted(drift, campaign, track)
    readings = []
    for state, (p, t) in enumerate(((campaign.p0, campaign.times[:, 0]), (campaign.p1, campaign.times[:, 1]))):
        mean, cov = track.motion(p, t)
        with np.errstate(invalid="ignore"):
            readings.append((mean - planted[state]) / np.sqrt(np.einsum("kii->ki", cov)))
    mean, cov = track.deflection(campaign)
    truth_deflection = planted[1] - planted[0]
    deflection = (mean - truth_deflection) / np.sqrt(np.einsum("kii->ki", cov))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        fits = {"removed": _posterior(track.remove(campaign), cell, rng), "kept": _posterior(campaign, cell, rng)}
        if n_draws:
            for count, posterior in _integrated(track, campaign, cell, rng, n_draws).items():
                fits["integrated" if count == n_draws else f"integrated{count}"] = posterior
    row = {"generator": generator, "evidence": evidence, "magnitude": magnitude, "seed": seed,
           "diffusion_m2_per_s": track.diffusion, "planted_deflection_rms_um": float(np.sqrt(np.mean(truth_deflection**2)) * 1e6)}
    row |= {f"reading_{k}": v for k, v in _within(np.concatenate(readings)).items()}
    row |= {f"deflection_{k}": v for k, v in _within(deflection).items()}
    for kind, posterior in fits.items():
        row |= {f"{kind}_z_{name}": v for name, v in _compliance_z(posterior, compliances).items()}
    return row


def nest_drift_coverage(
    config: str | PathLike[str],
    magnitudes: Sequence[float] = (1.0,),
    *,
    generator: str = "independent",
    plan_path: str | PathLike[str] = "data/table3_plan.csv",
    evidence: str = "nests",
    n_seeds: int = 100,
    n_draws: int = 0,
    first_seed: int = NEST_DRIFT_FIRST_SEED,
    executor: Executor | None = None,
    progress: str | None = None,
) -> pd.DataFrame:
    """The drift measured from nests or repeats, and the compliances after its removal, on ``n_seeds`` campaigns per
    magnitude.

    Parameters
    ----------
    config
        The cell TOML around which the generator draws its truths.
    magnitudes
        Multiples of the drift's default (0.2 mm/h on both generators).
    generator
        ``"independent"``: :mod:`bayescal.twin.independent`'s ``thermal_drift`` on random plans; ``"twin"``: the
        twin's :class:`~bayescal.twin.drift.TrackerDrift` on the plan of ``plan_path``.
    evidence
        ``"nests"``: the walk fitted to the nests alone (as ``calibrate --nests``); ``"both"``: to the nests and the
        repeat groups (``--nests --drift-from-repeats``); ``"repeats"``: to the repeat groups alone
        (``--drift-from-repeats``), the twin's campaigns then measured in passes.
    n_draws
        Draws of the drift the calibration is integrated over (0: not integrated; that many calibrations more), the
        posteriors of their first 2, 4, … draws pooled as well.
    executor, progress
        As :func:`~bayescal.design.parallel.seeded_map` takes them.

    Returns
    -------
    pandas.DataFrame
        One row per campaign: ``generator, evidence, magnitude, seed``, the diffusion chosen (m²/s), the planted drift's rms in the
        deflections (μm); ``reading_within_{1,2,3}sd`` and ``deflection_within_{1,2,3}sd``, the fractions of the
        readings' and the deflections' coordinates whose drift lies within 1, 2, 3 sd of the estimate; and
        ``removed_z_k<j>`` / ``integrated_z_k<j>`` / ``kept_z_k<j>``, each identifiable compliance's error in
        posterior sd, calibrated after the drift's removal (its variance added per row), integrated over its
        ``n_draws`` draws and without it; ``integrated<D>_z_k<j>``: integrated over the first D of the draws.
    """
    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import read_plan
    from bayescal.design.parallel import seeded_map

    cell = load_cell(config)
    plan = read_plan(plan_path, cell.robot) if generator == "twin" else None
    tasks = [(generator, float(m), first_seed + k, evidence) for m in magnitudes for k in range(n_seeds)]
    streams = [np.random.SeedSequence(seed) for *_, seed, _ in tasks]
    rows = seeded_map(_one, tasks, streams, executor=executor, progress=progress, cell=cell, plan=plan, n_draws=n_draws)
    return pd.DataFrame.from_records(rows)
