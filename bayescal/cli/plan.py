"""``bayescal plan``: design a calibration plan (eqs 36-41), or score a given one."""

from __future__ import annotations

import argparse

from bayescal.forked import available_cores
from bayescal.output import guard_outputs, record_read, write_atomically

from ._command import CommandOutput, add_common_options, options_for, whole_number

__all__ = ["add_parser", "run"]

SECONDS = {"exact": 2, "linear": 1}
"""Time of a default design (5 × 3 configurations, 3 starts), s: the search's CPU time in one process on this
project's machine (1.7 s exact, 0.7 s linear, ``benchmarks/bench_design.py`` at load average 10; the search runs on
one thread, so an idle core's wall time; the starts run in parallel on several cores, which shortens the wall time, not
the estimate).  Said before a design starts, since the command prints nothing else until it ends when stderr is not a
terminal."""
FLAGS = {"angles": "--angles", "per_angle": "--per-angle", "repeats": "--repeats", "model": "--model", "criterion": "--criterion", "mass_range": "--mass-kg", "between": "--between"}
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
    parser.add_argument(
        "--per-angle", type=whole_number(1), default=None, help="configurations per q2 angle (default 3; with --criterion discriminate, bayescal.design.discriminate.PER_ANGLE)"
    )
    parser.add_argument("--repeats", type=whole_number(1), default=3, help="measurements of each configuration (default 3)")
    parser.add_argument(
        "--criterion",
        choices=("test-pose", "compensator", "d-optimal", "discriminate"),
        default="test-pose",
        help="what to optimise: the rms error at the test pose (eqs 38-40), the ±3σ of K_c and s0, log det of the information, "
        "or (discriminate) the separation of the two --between candidates the --campaign cannot tell apart",
    )
    parser.add_argument("--between", metavar="A,B", help="with --criterion discriminate: the two candidates of the critique to separate")
    parser.add_argument("--campaign", metavar="CAMPAIGN.csv", help="with --criterion discriminate: the campaign on which they tie (sizes each)")
    parser.add_argument(
        "--model",
        choices=("linear", "exact"),
        default="exact",
        help=f"model the search scores plans with: exact (default, the identification's, about {SECONDS['exact']} s) "
        f"or linear (eq 31, about {SECONDS['linear']} s)",
    )
    parser.add_argument("--mass-kg", type=float, nargs=2, metavar=("LOW", "HIGH"), help="range of the hanging load (default: the cell's [design] mass_kg)")
    parser.add_argument("--starts", type=whole_number(1), default=None, help="random starts of the exchange algorithm (default 3)")
    parser.add_argument(
        "--workers", type=whole_number(1), default=None,
        help="processes the starts run in (default: one per start, up to twice the cores); the plan is the same for any number",
    )
    parser.add_argument("-o", "--output", help="plan CSV to write")
    parser.add_argument("--evaluate", metavar="PLAN.csv", help="score this plan instead of designing one")
    parser.add_argument(
        "--nests", type=whole_number(1), metavar="K",
        help="say in the plan where to read the reference nests: a column read_nests, 1 at every K-th configuration (read "
        "every nest while its load hangs and after it is removed, at each repeat), so that `calibrate --nests` can "
        "measure the tracker's drift; K = 1 reads them every 5-8 min at a hanging mass's pace",
    )
    parser.add_argument(
        "--order", choices=("together", "passes"), default="together",
        help="the order of measurement the plan says: together (default) a configuration's repeats one after another; "
        "passes: a column in_passes, the plan measured whole once per repeat, so that a configuration's repeats lie a "
        "pass apart in time and show the tracker's drift (`simulate --plan` follows it, `calibrate --drift-from-repeats` "
        "removes the drift they show)",
    )
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    from bayescal.cell.config import load_cell
    from bayescal.errors import InputError

    inputs = {"the config": args.config, "the --evaluate plan": args.evaluate, "the --campaign": args.campaign}
    if args.evaluate is None and args.output is None:
        raise InputError("expected -o PLAN.csv (the plan to write) or --evaluate PLAN.csv", source="--output")
    guard_outputs(inputs, {"--output": None if args.evaluate is not None else args.output})
    cell = load_cell(args.config)
    guard_outputs(inputs | {"the robot URDF": cell.robot.source}, {"--output": None if args.evaluate is not None else args.output})
    _check_masses(args.mass_kg, cell)
    with options_for(FLAGS):
        if args.criterion == "discriminate" or args.between is not None or args.campaign is not None:
            return _discriminate(args, cell)
        if args.per_angle is None:
            args.per_angle = 3
        payload, document = _design_or_evaluate(args, cell)
    return CommandOutput(payload=payload, text=document.as_text())


def _design_or_evaluate(args: argparse.Namespace, cell):
    """Design the plan and write it, or score the --evaluate plan: the JSON payload and the plan's document."""
    from bayescal.design.constraints import load_design_space
    from bayescal.design.optimise import STARTS, PlanDesigner
    from bayescal.errors import InputError

    space = load_design_space(cell, mass_range=None if args.mass_kg is None else tuple(args.mass_kg))
    designer = PlanDesigner(cell, space, repeats=args.repeats, model=args.model)
    if args.evaluate is not None:
        if args.workers is not None:
            raise InputError("--workers shares out a design's starts; --evaluate designs nothing", source="--workers")
        evaluation = designer.assess(_read_evaluated_plan(args.evaluate, cell), args.evaluate)
        payload, document = evaluation.to_json(), evaluation.document(hanging_only=cell.loading.hanging_only)
    else:
        import sys

        starts = STARTS if args.starts is None else args.starts
        designer.check_request(args.angles, args.per_angle, args.criterion)
        # The search's cost grows with the configurations and the starts; scaled from the default design's time.
        # Said to a person at a terminal, as the progress bar is: a log keeps one line per error.
        seconds = SECONDS[args.model] * (args.angles * args.per_angle / 15) * (starts / STARTS)
        if sys.stderr.isatty() and not args.json:
            print(
                f"bayescal plan: designing {args.angles} × {args.per_angle} configurations with the {args.model} model, "
                f"about {max(seconds, 1):.0f} s",
                file=sys.stderr,
                flush=True,
            )
        # One process per start, up to twice the cores: the starts cost alike, and 3 of them on 2 cores end together after
        # 1.5 starts' time, where 2 processes take 2 (0.60 s against 0.66 s of the linear search's 0.87 s in one process).
        workers = min(starts, 2 * available_cores()) if args.workers is None else args.workers
        design = designer.optimise(args.angles, args.per_angle, args.criterion, rng=args.seed, starts=starts, progress=not args.json, workers=workers)
        comments = (_command(args, starts),)
        write_atomically("--output", args.output, lambda path: _save(design, path, comments, args))
        payload = design.to_json() | {"output": str(args.output)} | ({} if args.nests is None else {"read_nests_every": args.nests})
        payload |= {} if args.order == "together" else {"order": args.order}
        document = design.document(str(args.output), cell.loading.hanging_only)
    return payload, document


def _discriminate(args: argparse.Namespace, cell) -> CommandOutput:
    """Design the plan that separates the --between candidates on the --campaign, write it, and say by how much."""
    from bayescal.cell.campaign import read_campaign
    from bayescal.design.constraints import load_design_space
    from bayescal.design.discriminate import PER_ANGLE, STARTS, DiscriminatingDesigner
    from bayescal.errors import InputError

    if args.criterion != "discriminate" or args.between is None or args.campaign is None:
        raise InputError("--between A,B and --campaign CAMPAIGN.csv go together with --criterion discriminate", source="--criterion")
    if args.evaluate is not None:
        raise InputError("--evaluate scores a plan for the test pose; it does not take --criterion discriminate", source="--evaluate")
    if args.workers is not None:
        raise InputError("--workers shares out the exchange's starts; --criterion discriminate runs its search in one process", source="--workers")
    between = tuple(name.strip() for name in args.between.split(","))
    campaign = read_campaign(args.campaign, cell=cell)
    space = load_design_space(cell, mass_range=None if args.mass_kg is None else tuple(args.mass_kg))
    starts = STARTS if args.starts is None else args.starts
    if args.per_angle is None:
        args.per_angle = PER_ANGLE
    design = DiscriminatingDesigner(cell, between, campaign, space, repeats=args.repeats).optimise(args.angles, args.per_angle, args.seed, starts=starts)
    comments = (_command(args, starts) + f" --between {args.between} --campaign {args.campaign}",)
    write_atomically("--output", args.output, lambda path: design.save(path, comments=comments))
    payload = design.to_json() | {"output": str(args.output)}
    return CommandOutput(payload=payload, text=design.document(str(args.output), args.campaign).as_text())


def _save(design, path, comments: tuple[str, ...], args: argparse.Namespace) -> None:
    """Write the designed plan, with the columns of the configurations at which to read the reference nests and of the
    order of measurement when asked."""
    from bayescal.cell.nests import NEST_PLAN_COLUMN, nest_plan_column
    from bayescal.cell.plan import PASSES_COLUMN, passes_column

    notes, extra = [], {}
    if args.nests is not None:
        note, extra[NEST_PLAN_COLUMN] = nest_plan_column(len(design.plan.q), args.nests)
        notes.append(note)
    if args.order == "passes":
        note, extra[PASSES_COLUMN] = passes_column(len(design.plan.q), args.repeats)
        notes.append(note)
    if extra:
        design.save(path, comments=comments + tuple(notes), extra=extra)
    else:
        design.save(path, comments=comments)


def _command(args: argparse.Namespace, starts: int) -> str:
    """The command line that makes this plan again, every option that shapes it spelt out."""
    words = [
        f"bayescal plan --config {args.config} --angles {args.angles} --per-angle {args.per_angle} --repeats {args.repeats}",
        f"--criterion {args.criterion} --model {args.model} --starts {starts} --seed {args.seed}",
    ]
    if args.mass_kg is not None:
        words.append(f"--mass-kg {args.mass_kg[0]:g} {args.mass_kg[1]:g}")
    if args.nests is not None:
        words.append(f"--nests {args.nests}")
    if args.order != "together":
        words.append(f"--order {args.order}")
    return " ".join(words)


def _check_masses(mass_kg: list[float] | None, cell) -> None:
    """Refuse a --mass-kg range by the rule the cell's ``[design] mass_kg`` is held to (:mod:`bayescal.cell.plausible`)."""
    from bayescal.cell.plausible import mass_range_violation
    from bayescal.errors import InputError

    if mass_kg is None:
        return
    reason = mass_range_violation(*mass_kg, cell.capacity_weight / cell.gravity)
    if reason is not None:
        raise InputError(reason, source="--mass-kg")


def _read_evaluated_plan(path: str, cell):
    """The --evaluate plan, refused when it is a campaign or has too few q2 angles to identify the compensator."""
    import numpy as np
    import pandas as pd

    from bayescal.cell.campaign import POSITION_COLUMNS
    from bayescal.cell.plan import read_plan
    from bayescal.errors import InputError
    from bayescal.robot.compensator import MIN_ANGLES

    record_read(path, "the --evaluate plan")
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
        if angles < MIN_ANGLES:
            raise InputError(
                f"the plan has {angles} distinct q{joint + 1} angle(s); the compensator's stiffness, "
                f"{' and '.join(p.name for p in cell.compensator.PARAMETERS)} need at "
                f"least {MIN_ANGLES} to be predicted at all",
                source=path,
            )
    return plan
