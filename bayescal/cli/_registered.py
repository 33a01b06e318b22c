"""``--registration REG.json``: the option shared by the commands that read tracker-frame files.

With it, a campaign is read in the tracker frame and moved into the
registration's base frame, and compensator arcs into its paper frame
(:mod:`bayescal.registration.transfer`); without it, the files are taken as
already in those frames.
"""

from __future__ import annotations

import argparse

__all__ = ["add_registration_option", "read_campaign_in_base", "read_arcs_in_paper_frame", "registration_lines"]


def add_registration_option(parser: argparse.ArgumentParser, what: str) -> None:
    """Add ``--registration``; ``what`` names the files it moves."""
    parser.add_argument(
        "--registration",
        metavar="REG.json",
        help=f"registration from `bayescal axes -o`: {what} are in the tracker frame and are moved into the robot's "
        "frame, the registration's rotation uncertainty added to each reading",
    )


def read_campaign_in_base(args: argparse.Namespace, path: str, cell):
    """The campaign at ``path`` and the cell, moved by ``args.registration`` when given.

    Returns
    -------
    Campaign, Cell, CampaignTransfer or None
    """
    from bayescal.cell.campaign import read_campaign

    if not args.registration:
        return read_campaign(path, cell=cell), cell, None
    from bayescal.registration.transfer import read_registered_campaign

    transfer, moved = read_registered_campaign(path, cell, args.registration)
    return transfer.campaign, moved, transfer


def read_arcs_in_paper_frame(args: argparse.Namespace, path: str):
    """The arc points at ``path``, moved into the paper's frame by ``args.registration`` when given.

    Returns
    -------
    MarkerPoints, ArcTransfer or None
    """
    from bayescal.geometry.arcs import read_arc_points

    if not args.registration:
        return read_arc_points(path), None
    # Only now: the registration brings Pinocchio and SciPy, which the geometry command otherwise never loads.
    from bayescal.registration.transfer import read_registered_arcs

    transfer = read_registered_arcs(path, args.registration)
    return transfer.points, transfer


def registration_lines(transfer, source: str, lever_mm: float | None = None) -> list[str]:
    """The lines a command's text gives a transfer: the frame, what it added, where the tracker stood.

    ``lever_mm``: the compensator's |a| (arcs), which the paper frame's turn about axis 2 turns.
    """
    if transfer is None:
        return []
    d = transfer.diagnostics()
    if "tracker_position_mm" in d:
        where = ", ".join(f"{v:.1f}" for v in d["tracker_position_mm"])
        return [f"registration {source}: positions moved from the tracker frame into the base frame; the tracker "
                f"stood at ({where}) mm; the rotation's uncertainty adds at most {d['deflection_sd_added_max_um']:.2g} μm "
                f"to a deflection ({100 * d['added_over_tracker_max']:.2g} % of the tracker's noise)"]
    lines = [f"registration {source}: points moved from the tracker frame into the paper's frame; the frame's "
             f"uncertainty adds {d['sd_added_median_um']:.2g} μm (median, at most {d['sd_added_max_um']:.2g} μm) to a point"]
    if lever_mm is not None:
        lines.append(f"its turn about axis 2 (sd {d['turn_about_z_sd_mrad']:.2g} mrad) turns (a_x, a_y) by "
                     f"{d['turn_about_z_sd_mrad'] * 1e-3 * lever_mm:.2g} mm (sd), which the intervals above leave out")
    return lines
