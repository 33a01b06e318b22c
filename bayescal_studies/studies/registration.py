"""A campaign measured by a turned tracker, calibrated with and without its registration.

For each seed the twin measures the paper's Table III plan (the cell's tracker
where the cell puts it, its axes turned by ``turn_deg`` about a random
direction) and sweeps joints 1 and 2 with the same tracker
(:mod:`bayescal.twin.sweeps`).  The campaign is then calibrated four ways:

* ``base``: in the base frame, as the twin made it;
* ``rerun``: the same, with another sampler seed, to measure the Monte-Carlo
  error of a comparison of two fits;
* ``registered``: read in the tracker frame and moved into the base frame the
  sweeps' registration gives (:mod:`bayescal.registration.transfer`);
* ``unregistered``: the unloaded positions where they are (in the base frame)
  and the deflections read in the turned axes.  A campaign whose positions too
  are read in turned axes does not get that far: turned by more than about
  0.3°, markers 2-4 m from the tracker move by more than the 10 mm
  :data:`~bayescal.inference.equations.MARKER_TOLERANCE` from their place on
  the tool between configurations, and it is refused as mislabelled.  The
  deflections are what a turn biases unseen.

:func:`registration_transfer_study` gives one row per seed and identifiable
parameter; :func:`transfer_findings` summarises it.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from concurrent.futures import Executor
from dataclasses import replace

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.registration.register import register
from bayescal.registration.sweeps import read_sweeps
from bayescal.registration.transfer import campaign_to_frame
from bayescal.design.parallel import seeded_map
from bayescal.twin.simulator import DigitalTwin
from bayescal.twin.sweeps import TrackerPlacement, simulate_sweeps
from bayescal.units import DEG, UM

__all__ = ["TURN_DEG", "SWEEP_HOME_DEG", "registration_transfer_study", "transfer_findings"]

TURN_DEG = 5.4
"""Turn of the tracker's axes from the base frame's (deg): a tracker set down by eye."""
SWEEP_HOME_DEG = (0.0, -90.0, 90.0, 0.0, 45.0, 0.0)
"""Home pose of the simulated sweeps, the one of the registration's coverage study (docs/registration.md)."""


def _identified(results) -> dict[str, tuple[float, float]]:
    """(mean, sd) of each identifiable parameter, in its reported unit."""
    return {name: (entry["mean"], entry["sd"]) for name, entry in results.parameters().items() if "mean" in entry}


def _one(index: int, rng: np.random.Generator, *, cell: Cell, plan: Plan, turn_deg: float, repeats: int,
         sweep_file, fit_options: dict) -> list[dict]:
    """The four calibrations of one seed's campaign; one row per identifiable parameter."""
    axis = rng.normal(size=3)
    turn = Rotation.from_rotvec(turn_deg * DEG * axis / np.linalg.norm(axis)).as_matrix()
    placement = TrackerPlacement(turn, cell.tracker.position)
    campaign = DigitalTwin(cell).simulate(plan, repeats, rng)
    tracker = replace(campaign, p0=placement.to_tracker(campaign.p0), p1=placement.to_tracker(campaign.p1))
    path = sweep_file(index)
    simulate_sweeps(cell, placement, rng, home_deg=SWEEP_HOME_DEG).to_csv(path, index=False)
    registration = register(read_sweeps(path, cell.robot), cell, rng=rng)
    transfer, moved_cell = campaign_to_frame(tracker, registration.frames["base"], cell)
    unregistered = replace(campaign, p1=campaign.p0 + campaign.displacement @ turn)
    seed = int(rng.integers(2**31))
    base, moved = ElastostaticModel.from_cell(cell, **fit_options), ElastostaticModel.from_cell(moved_cell, **fit_options)
    with warnings.catch_warnings():
        # Every fit says k1, K_c and s0 are not identifiable from Table III; the study keeps the others.
        warnings.simplefilter("ignore")
        fits = {
            "base": _identified(base.fit(campaign, rng=seed)),
            "rerun": _identified(base.fit(campaign, rng=seed + 1)),
            "registered": _identified(moved.fit(transfer.campaign, rng=seed)),
            "unregistered": _identified(base.fit(unregistered, rng=seed)),
        }
    error = {
        "registered": np.linalg.norm(transfer.campaign.displacement - campaign.displacement, axis=1),
        "unregistered": np.linalg.norm(unregistered.displacement - campaign.displacement, axis=1),
    }
    rows = []
    for name, (mean, sd) in fits["base"].items():
        if not all(name in fit for fit in fits.values()):
            continue
        row = {"seed": index, "parameter": name, "base_mean": mean, "base_sd": sd}
        for kind in ("rerun", "registered", "unregistered"):
            row[f"{kind}_mean"], row[f"{kind}_sd"] = fits[kind][name]
        row |= {f"{kind}_deflection_error_max_um": float(e.max() / UM) for kind, e in error.items()}
        row["added_sd_max_um"] = transfer.diagnostics()["deflection_sd_added_max_um"]
        rows.append(row)
    return rows


def registration_transfer_study(cell: Cell, plan: Plan, seeds: Iterable[int] | int, folder, *, turn_deg: float = TURN_DEG,
                                repeats: int = 3, seed: int = 2026, executor: Executor | None = None,
                                fit_options: dict | None = None) -> pd.DataFrame:
    """One row per seed and identifiable parameter: the four calibrations' means and sds (μrad/(N·m) for compliances).

    Parameters
    ----------
    cell, plan
        The cell and the plan the twin measures (the paper's Table III in the documentation).
    seeds
        How many campaigns, or their indices.
    folder
        Where each campaign's sweep file is written (``sweeps_<index>.csv``).
    turn_deg
        The tracker's turn from the base frame's axes, deg.
    repeats
        Repeats of each configuration.
    seed, executor
        Root of the random streams, and where the campaigns run (:func:`~bayescal.design.parallel.seeded_map`).
    fit_options
        Keywords of :meth:`ElastostaticModel.from_cell` (``model``, ``sampler``); default: the command's.
    """
    items = range(seeds) if isinstance(seeds, int) else list(seeds)
    rows = seeded_map(_one, items, seed, executor=executor, cell=cell, plan=plan, turn_deg=turn_deg, repeats=repeats,
                      sweep_file=_SweepFile(str(folder)), fit_options=fit_options or {})
    return pd.DataFrame([row for batch in rows for row in batch])


class _SweepFile:
    """``folder/sweeps_<index>.csv``: a picklable path maker for the process pool."""

    def __init__(self, folder: str) -> None:
        self.folder = folder

    def __call__(self, index: int) -> str:
        return f"{self.folder}/sweeps_{index}.csv"


def transfer_findings(table: pd.DataFrame) -> dict:
    """The study's numbers.

    Returns
    -------
    dict
        ``registered_shift_in_sd`` and ``rerun_shift_in_sd``: the rms over rows of
        the difference from ``base`` in units of its sd (the rerun's is the
        Monte-Carlo error of such a comparison); ``registered_sd_ratio``: median
        and extreme ratios of the sds; ``unregistered_error_pct``: median and
        largest relative error of the unregistered means from the base ones;
        ``unregistered_shift_in_sd``: median shift in sd; the largest deflection
        errors (μm) and the largest sd the registration adds to one.
    """
    shift = {kind: (table[f"{kind}_mean"] - table["base_mean"]) / table["base_sd"] for kind in ("rerun", "registered", "unregistered")}
    ratio = table["registered_sd"] / table["base_sd"]
    relative = 100 * (table["unregistered_mean"] / table["base_mean"] - 1).abs()
    return {
        "campaigns": int(table["seed"].nunique()),
        "rows": len(table),
        "rerun_shift_in_sd": float(np.sqrt(np.mean(shift["rerun"] ** 2))),
        "registered_shift_in_sd": float(np.sqrt(np.mean(shift["registered"] ** 2))),
        "registered_shift_max_in_sd": float(shift["registered"].abs().max()),
        "registered_sd_ratio": [float(ratio.min()), float(ratio.median()), float(ratio.max())],
        "unregistered_shift_median_in_sd": float(shift["unregistered"].abs().median()),
        "unregistered_error_pct": [float(relative.median()), float(relative.max())],
        "registered_deflection_error_max_um": float(table["registered_deflection_error_max_um"].max()),
        "unregistered_deflection_error_max_um": float(table["unregistered_deflection_error_max_um"].max()),
        "added_sd_max_um": float(table["added_sd_max_um"].max()),
    }
