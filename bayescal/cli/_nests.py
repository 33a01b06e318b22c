"""``--nests NESTS.csv``: the option shared by the commands that read a campaign and can remove the tracker's drift.

The file's readings of fixed reference nests (:mod:`bayescal.cell.nests`) are read in the campaign's
frame, and moved with it by ``--registration``.
"""

from __future__ import annotations

import argparse

__all__ = ["add_nests_option", "read_nests_in_base", "nests_lines", "measured_drift", "fitted_drift"]


def add_nests_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--nests`` and ``--drift-from-repeats``."""
    parser.add_argument(
        "--drift-from-repeats",
        action="store_true",
        help="measure the tracker's drift from the campaign's repeats alone (a marker's readings of one state at one "
        "configuration taken at distinct times t0_s, t1_s; bayescal plan --order passes spreads them) and remove it "
        "as --nests does; with --nests, the repeats join the nests (without it, the nests alone: a walk fitted to the "
        "campaign's own readings takes up some of their noise)",
    )
    parser.add_argument(
        "--nests",
        metavar="NESTS.csv",
        help="readings of fixed reference nests (nest, t_s, x_mm, y_mm, z_mm) on the campaign's clock: the tracker's "
        "drift is measured from them and removed from the readings at their times (t0_s, t1_s), its uncertainty added to "
        "each deflection (calibrate integrates over draws of it instead: --drift-draws)",
    )


def read_nests_in_base(args: argparse.Namespace, campaign):
    """The nests of ``args.nests`` in the campaign's frame (moved by ``args.registration`` when given), or None."""
    if not args.nests:
        return None
    from bayescal.cell.nests import read_nests, require_times

    nests = read_nests(args.nests)
    require_times(campaign.times, campaign.source, nests=nests)
    if not args.registration:
        return nests
    from bayescal.registration import read_frame

    return nests.moved(read_frame(args.registration, "base").from_tracker)


def fitted_drift(args: argparse.Namespace, campaign, cell):
    """The random walk that ``--nests`` and the repeats (or ``--drift-from-repeats`` alone) measure
    (:class:`~bayescal.registration.nest_drift.NestDrift`); None without either option."""
    nests = read_nests_in_base(args, campaign)
    if nests is None and not args.drift_from_repeats:
        return None
    from bayescal.cell.nests import require_times
    from bayescal.critique.drift import MAKE_TESTABLE
    from bayescal.errors import InputError
    from bayescal.registration.repeats import fit_drift

    require_times(campaign.times, campaign.source, "--drift-from-repeats")
    track = fit_drift(campaign, cell.tracker, nests, repeats=args.drift_from_repeats)
    if track is None:
        raise InputError("--drift-from-repeats: no marker's state is read twice at different times: " + MAKE_TESTABLE,
                         source=campaign.source)
    return track


def measured_drift(args: argparse.Namespace, campaign, cell):
    """The campaign with the drift's posterior mean taken out (its variance added to each row) and what was removed
    (:meth:`~bayescal.registration.nest_drift.NestDrift.to_json`, with the file of ``--nests``); unchanged and None
    without ``--nests`` or ``--drift-from-repeats``."""
    track = fitted_drift(args, campaign, cell)
    if track is None:
        return campaign, None
    return track.remove(campaign), track.to_json(campaign) | ({"file": args.nests} if args.nests else {})


def nests_lines(drift: dict | None) -> list[str]:
    """The line a command's text gives the drift measured and removed (the registration, and SciPy's optimiser with it,
    imported only when there is one)."""
    if not drift:
        return []
    from bayescal.registration.nest_drift import removed_drift_sentence

    return [removed_drift_sentence(drift)]
