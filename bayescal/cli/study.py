"""``bayescal study q2-angles``: what each extra q2 angle buys, and what K_c and s0 would cost."""

from __future__ import annotations

import argparse

from bayescal.output import guard_outputs, write_atomically

from ._command import CommandOutput, add_common_options, options_for, whole_number

__all__ = ["add_parser", "run"]

CPU_SECONDS_PER_PLAN = 0.17
"""CPU seconds per plan of the study, the shared candidate set included: the default study's 50 plans took 8.5-8.9 s of
CPU (user + system, its two worker processes included) on the 2-core development machine, 4.9-5.2 s wall at load
average 1.4-1.6 (three runs)."""


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "study",
        help="design studies: the predicted widths against the number of q2 angles",
        description=(
            "q2-angles: design a plan for 3 to 12 distinct q2 angles and 1 to 5 configurations per angle, "
            "tabulate the predicted ±3σ widths of every parameter and the rms error at the test pose, at the "
            "cell's tracker noise and at 1/10 of it, and say what would identify K_c and s0 to Table IV's "
            "widths and to 5 %. The default study took 5 s on 2 cores (8.5-8.9 s of CPU); a progress bar shows the time left."
        ),
    )
    parser.add_argument("name", choices=("q2-angles",), help="the study")
    parser.add_argument("--config", required=True, help="cell TOML file")
    parser.add_argument("--repeats", type=whole_number(1), default=3, help="measurements of each configuration (default 3)")
    parser.add_argument("--max-angles", type=whole_number(3), default=12, help="largest number of q2 angles, at least 3 (default 12)")
    parser.add_argument(
        "--max-per-angle", type=whole_number(1), default=5, help="largest number of configurations per angle (default 5)"
    )
    parser.add_argument("-o", "--output", help="CSV file for the table")
    parser.add_argument("--markdown", help="Markdown file for the table and the answer")
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    import sys

    from bayescal.cell.config import load_cell
    from bayescal.design.optimise import PlanDesigner
    from bayescal.errors import InputError
    from bayescal.jsonsafe import json_safe
    from bayescal.design.angles import identification_cost, q2_angle_study, width_targets

    outputs = {"--output": args.output, "--markdown": args.markdown}
    guard_outputs({"the config": args.config}, outputs)
    cell = load_cell(args.config)
    guard_outputs({"the config": args.config, "the robot URDF": cell.robot.source}, outputs)
    designer = PlanDesigner(cell, repeats=args.repeats, model="linear")
    if args.max_angles > designer.max_angles():
        raise InputError(
            f"expected at most {designer.max_angles()} q2 angles (the joint range of {cell.source} at the design's "
            f"separation), got {args.max_angles}",
            source="--max-angles",
        )
    plans = (args.max_angles - 2) * args.max_per_angle
    # Measured (CPU_SECONDS_PER_PLAN), scaled by the plans; the progress bar then measures the time left on the plans done.  Said to a person at a terminal: a log
    # keeps one line per error.
    if sys.stderr.isatty() and not args.json:
        print(f"bayescal study: designing {plans} plans, about {max(5, round(CPU_SECONDS_PER_PLAN * plans))} s of CPU", file=sys.stderr, flush=True)
    with options_for({"angles": "--max-angles", "per_angle": "--max-per-angle", "repeats": "--repeats"}):
        table = q2_angle_study(
            cell, angles=range(3, args.max_angles + 1), per_angle=range(1, args.max_per_angle + 1), repeats=args.repeats,
            seed=args.seed, progress=not args.json,
        )
    cost = identification_cost(table, targets=width_targets(cell), repeats=args.repeats)
    text = _shown(table, cost)
    if args.output is not None:
        write_atomically("--output", args.output, lambda path: table.to_csv(path, index=False))
    if args.markdown is not None:
        write_atomically("--markdown", args.markdown, lambda path: path.write_text(text + "\n", encoding="utf-8"))

    payload = {
        "table": table.to_dict(orient="records"),
        "identification_cost": cost.to_dict(orient="records"),
        "repeats": args.repeats,
        "seed": args.seed,
    }
    return CommandOutput(payload=json_safe(payload), text=text)


def _shown(table, cost) -> str:
    """The study's two tables as Markdown, each number as a person reads it: the error left in μm to 0.01, widths in %
    to 0.1, noise fractions to two significant digits (:mod:`bayescal.numbers`); the CSV keeps every digit."""
    from bayescal.numbers import fixed, table_texts
    from bayescal.tables import markdown_table

    columns = ["angles", "per_angle", "noise_fraction", "test_pose_rms_mm", "k2_width_3sd_pct", "K_c_width_3sd_pct", "s0_width_3sd_pct"]
    shown = table[columns].assign(test_pose_rms_mm=table["test_pose_rms_mm"] * 1000).rename(columns={"test_pose_rms_mm": "test_pose_rms_μm"})
    two_digits = lambda value: f"{value:.2g}"  # noqa: E731
    formats = {"noise_fraction": two_digits, "noise_fraction_needed": two_digits, "test_pose_rms_μm": fixed(2)}
    formats |= {column: fixed(1) for column in (*shown.columns, *cost.columns) if column.endswith("_pct")}
    texts = [table_texts(frame, {}, {c: f for c, f in formats.items() if c in frame.columns}) for frame in (shown, cost)]
    return "\n\n".join(markdown_table(list(frame.columns), [list(row) for row in frame.itertuples(index=False)]) for frame in texts)
