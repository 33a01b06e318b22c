"""Convert DLR's published Agile Justin measurements to a bayescal positions file.

The data set of Tenhumberg and Bäuml (Humanoids 2021, arXiv 2311.08333; public
repository ``dlr-alr/dlr-elastic-calibration``, file ``dataset/measurements.csv``)
holds per configuration the 19 commanded joint angles (rad, as a bracketed list:
torso 3, right arm 7, left arm 7, head 2) and the two hand markers (m, a bracketed
2 × 3 list, the right hand first) in the tracker's frame.  A positions file for
``data/robots/justin.toml`` has one row per hand per configuration:
``q1_deg..q19_deg, marker, x_mm, y_mm, z_mm``.

    python examples/justin_positions.py measurements.csv justin_positions.csv
"""

from __future__ import annotations

import csv
import math
import re
import sys

HANDS = ("right", "left")
"""The published file's marker rows, in order (docs/kinematics.md: the first is the right hand)."""


def _numbers(text: str) -> list[float]:
    return [float(x) for x in re.sub(r"[\[\]]", " ", text).split()]


def convert(source: str, target: str) -> int:
    """Write the positions file; returns the number of configurations."""
    count = 0
    with open(source, newline="", encoding="utf-8") as handle, open(target, "w", newline="", encoding="utf-8") as out:
        rows = csv.reader(line for line in handle if not line.startswith("#"))
        header = next(rows)
        if header[1:] != ["joints", "markers"]:
            raise SystemExit(f"{source}: expected the columns ',joints,markers' of the published file, got {header}")
        writer = csv.writer(out, lineterminator="\n")
        out.write(f"# Agile Justin (DLR), converted by examples/justin_positions.py from {source.rsplit('/', 1)[-1]}\n")
        writer.writerow([f"q{i + 1}_deg" for i in range(19)] + ["marker", "x_mm", "y_mm", "z_mm"])
        for number, row in enumerate(rows, start=2):
            joints, markers = _numbers(row[1]), _numbers(row[2])
            if len(joints) != 19 or len(markers) != 6:
                raise SystemExit(f"{source}: row {number}: expected 19 joint angles and 2 × 3 marker coordinates")
            angles = [f"{math.degrees(q):.10f}" for q in joints]
            for hand, start in zip(HANDS, (0, 3)):
                writer.writerow(angles + [hand] + [f"{1000 * x:.6f}" for x in markers[start : start + 3]])
            count += 1
    return count


if __name__ == "__main__":
    print(f"wrote {convert(sys.argv[1], sys.argv[2])} configurations to {sys.argv[2]}")
