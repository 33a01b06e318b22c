"""``--nests NESTS.csv``: the option shared by the commands that read a campaign and can remove the tracker's drift.

The file's readings of fixed reference nests (:mod:`bayescal.cell.nests`) are read in the campaign's
frame, and moved with it by ``--registration``.
"""

from __future__ import annotations

import argparse

__all__ = ["add_nests_option", "read_nests_in_base", "nests_lines"]


def add_nests_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--nests``."""
    parser.add_argument(
        "--nests",
        metavar="NESTS.csv",
        help="readings of fixed reference nests (nest, t_s, x_mm, y_mm, z_mm) on the campaign's clock: the tracker's "
        "drift is measured from them and removed from the readings at their times (t0_s, t1_s), its uncertainty added",
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


def nests_lines(drift: dict | None) -> list[str]:
    """The line a command's text gives the drift the nests measured and removed."""
    from bayescal.registration.nest_drift import removed_drift_sentence

    return [removed_drift_sentence(drift)] if drift else []
