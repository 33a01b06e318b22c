"""``bayescal plan``: design a calibration plan (eqs 36-41), or score a given one."""

from __future__ import annotations

import argparse

from bayescal.output import guard_outputs, write_atomically

from ._command import CommandOutput, add_common_options, options_for, whole_number

__all__ = ["add_parser", "run"]

FLAGS = {"angles": "--angles", "repeats": "--repeats", "model": "--model", "criterion": "--criterion", "mass_range": "--mass-kg"}
"""The library's argument names and this command's options."""


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "plan",
        help="design a calibration plan for a cell, or score a given plan",
        description=(
            "Find the configurations and loads that make the robot most accurate at the cell's test pose "
            "(Klimchik et al., eqs 38-41), or identify the compensator best, or maximise the information's "
            "determinant; write the plan CSV and print the predicted rms error left at the test pose and "
            "the predicted ±3σ width of every parameter. With --evaluate, score a given plan the same way."
        ),
    )
    parser.add_argument("--config", required=True, help="cell TOML file (robot, stiffness, compensator, tool, tracker, test pose)")
    parser.add_argument("--angles", type=whole_number(1), default=5, help="distinct q2 angles (default 5, as Table III)")
    parser.add_argument("--per-angle", type=whole_number(1), default=3, help="configurations per q2 angle (default 3)")
    parser.add_argument("--repeats", type=whole_number(1), default=3, help="measurements of each configuration (default 3)")
    parser.add_argument(
        "--criterion",
        choices=("test-pose", "compensator", "d-optimal"),
        default="test-pose",
        help="what to optimise: the rms error at the test pose (eqs 38-40), the ±3σ of K_c and s0, or log det of the information",
    )
    parser.add_argument(
        "--model",
        choices=("linear", "exact"),
        default="exact",
        help="model the search scores plans with: exact (default, the identification's, about 100 s) or linear (eq 31, about 25 s)",
    )
    parser.add_argument("--mass-kg", type=float, nargs=2, metavar=("LOW", "HIGH"), help="range of the hanging load (default: the cell's [design] mass_kg)")
    parser.add_argument("--starts", type=whole_number(1), default=None, help="random starts of the exchange algorithm (default 3)")
    parser.add_argument("-o", "--output", help="plan CSV to write")
    parser.add_argument("--evaluate", metavar="PLAN.csv", help="score this plan instead of designing one")
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    from bayescal.cell.config import load_cell
    from bayescal.errors import InputError

    inputs = {"the config": args.config, "the --evaluate plan": args.evaluate}
    if args.evaluate is None and args.output is None:
        raise InputError("expected -o PLAN.csv (the plan to write) or --evaluate PLAN.csv", source="--output")
    guard_outputs(inputs, {"--output": None if args.evaluate is not None else args.output})
    cell = load_cell(args.config)
    guard_outputs(inputs | {"the robot URDF": cell.robot.source}, {"--output": None if args.evaluate is not None else args.output})
    _check_masses(args.mass_kg, cell)
    with options_for(FLAGS):
        payload, table = _design_or_evaluate(args, cell)
    criterion = payload["criterion"]
    lines = [
        f"predicted rms error at the test pose after compensation: {'not predictable' if criterion is None else f'{criterion:.5f} mm'}",
        table.to_string(float_format=lambda v: f"{v:.4g}"),
    ]
    for violation in payload.get("violations", []):
        lines.append(f"configuration {violation['config']}: {violation['reason']}")
    if "output" in payload:
        loads = f", forces of {payload['force_max_N']:.0f} N in directions of the design" if "force_max_N" in payload else ""
        lines.insert(0, f"wrote {payload['output']}: {payload['configurations']} configurations at q2 = {', '.join(f'{v:g}' for v in payload['q2_deg'])} deg{loads}")
    return CommandOutput(payload=payload, text="\n".join(lines))


def _design_or_evaluate(args: argparse.Namespace, cell) -> tuple[dict, pd.DataFrame]:
    """Design the plan and write it, or score the --evaluate plan: the JSON payload and the table of predicted widths."""
    from bayescal.design.constraints import load_design_space
    from bayescal.design.optimise import STARTS, PlanDesigner

    space = load_design_space(cell, mass_range=None if args.mass_kg is None else tuple(args.mass_kg))
    designer = PlanDesigner(cell, space, repeats=args.repeats, model=args.model)
    if args.evaluate is not None:
        plan = _read_evaluated_plan(args.evaluate, cell)
        prediction = designer.evaluate(plan, "exact")
        payload = prediction.to_json() | {
            "model": "exact",
            "linear_model": designer.evaluate(plan, "linear").to_json(),
            "plan": args.evaluate,
            "configurations": len(plan),
            "repeats": args.repeats,
            "violations": designer.violations(plan),
        }
        table = prediction.summary()
    else:
        starts = STARTS if args.starts is None else args.starts
        design = designer.optimise(args.angles, args.per_angle, args.criterion, rng=args.seed, starts=starts, progress=not args.json)
        comments = (_command(args, starts),)
        write_atomically("--output", args.output, lambda path: design.save(path, comments=comments))
        payload = design.to_json() | {"output": str(args.output)}
        table = design.summary()
    return payload, table


def _command(args: argparse.Namespace, starts: int) -> str:
    """The command line that makes this plan again, every option that shapes it spelt out."""
    words = [
        f"bayescal plan --config {args.config} --angles {args.angles} --per-angle {args.per_angle} --repeats {args.repeats}",
        f"--criterion {args.criterion} --model {args.model} --starts {starts} --seed {args.seed}",
    ]
    if args.mass_kg is not None:
        words.append(f"--mass-kg {args.mass_kg[0]:g} {args.mass_kg[1]:g}")
    return " ".join(words)


def _check_masses(mass_kg: list[float] | None, cell) -> None:
    """Refuse a --mass-kg range that is not finite and positive, or that simulate would refuse as too heavy."""
    import math

    from bayescal.errors import InputError

    if mass_kg is None:
        return
    low, high = mass_kg
    if not all(math.isfinite(value) for value in mass_kg) or not 0 < low <= high:
        raise InputError(f"expected a mass range 0 < LOW <= HIGH in kg, got {low:g} {high:g}", source="--mass-kg")
    heaviest = cell.max_force / cell.gravity
    if high > heaviest:
        raise InputError(
            f"a load of {high:g} kg is more than the {heaviest:.0f} kg the arm of {cell.source} can plausibly carry "
            "(the limit simulate applies to a plan's load_kg)",
            source="--mass-kg",
        )


def _read_evaluated_plan(path: str, cell):
    """The --evaluate plan, refused when it is a campaign or has too few q2 angles to identify the compensator."""
    import numpy as np
    import pandas as pd

    from bayescal.cell.campaign import POSITION_COLUMNS
    from bayescal.cell.plan import read_plan
    from bayescal.errors import InputError

    try:
        header = pd.read_csv(path, comment="#", nrows=0).columns
    except (OSError, ValueError, UnicodeDecodeError):
        header = ()
    if set(POSITION_COLUMNS) & set(header):
        raise InputError(
            "this is a campaign (it has tracker position columns); --evaluate expects a plan CSV of joint angles "
            "(bayescal plan -o writes one)",
            source=path,
        )
    plan = read_plan(path, cell.robot, max_load_kg=cell.max_force / cell.gravity, loading=cell.loading)
    joint = cell.compensated_joint
    if joint is not None:
        angles = len(np.unique(np.round(plan.q[:, joint], 9)))
        if angles < 3:
            raise InputError(
                f"the plan has {angles} distinct q{joint + 1} angle(s); the compensator's stiffness, K_c and s0 need at "
                "least 3 to be predicted at all",
                source=path,
            )
    return plan
