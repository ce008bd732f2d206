"""`stepramp plan`: the fastest stall-safe table for a motor (free curve or init)."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from typing import Any

from ._common import (
    CLOCK_NAMES,
    EXIT_OK,
    fields_as_options,
    internal_clock,
    positive_int,
    progress_bar,
)

OPTIONS = {"pulses": "--pulses", "max_stages": "--max-stages"}

KINDS = ("free", "linear", "s-curve")
MAX_STAGES_DEFAULT = 127


def add_subparser(sub: Any) -> None:
    p = sub.add_parser("plan", help="plan the fastest stall-safe table for a motor")
    p.add_argument("--motor", required=True, metavar="M.json", help="the motor file")
    p.add_argument("--kind", choices=KINDS, default="free",
                   help="free: a free-curve table (every stage given); linear / s-curve: an "
                        "init table the chip expands (needs --pulses); default free")
    p.add_argument("--clock", type=internal_clock,
                   help=f"{CLOCK_NAMES} (default: the finest that fits the motor)")
    p.add_argument("--max-stages", type=positive_int,
                   help=f"free curve: at most this many stages (default {MAX_STAGES_DEFAULT})")
    p.add_argument("--pulses", type=positive_int,
                   help="plan for a move of this many pulses [pulses] (free: default a long "
                        "reference move)")
    p.add_argument("--separate-decel", action=argparse.BooleanOptionalAction, default=None,
                   help="separate decel counts (LE=1); default: free curve whichever is "
                        "faster, init tables no (the ASCII init command has no LE=1 form)")
    p.add_argument("--from", dest="source", choices=("ruckig", "toppra"),
                   help="free curve: quantise this continuous reference instead of optimising "
                        "the staircase (needs --pulses)")
    p.add_argument("--format", choices=("text", "json"), default="text",
                   help="the summary's format (the table itself is always JSON)")
    p.add_argument("-o", "--output", metavar="TABLE", help="write the table here (default stdout)")
    p.set_defaults(func=_do_plan)


def _do_plan(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.motor import load_motor
    from profiles.ppmc312.table import dump_table
    from verify.output import write_output

    if args.kind != "free":
        for given, option in ((args.source, "--from"), (args.max_stages, "--max-stages")):
            if given is not None:
                raise FormatError(f"{option} plans free curves only, not --kind {args.kind}")
        if args.pulses is None:
            raise FormatError(f"--kind {args.kind} needs --pulses: an init table is chosen "
                              "for the move it runs")
    motor = load_motor(args.motor)
    with fields_as_options(OPTIONS):
        if args.kind != "free":
            table, summary = _init(args, motor)
        elif args.source:
            table, summary = _from_reference(args, motor)
        else:
            table, summary = _free(args, motor)
    write_output(args.output, dump_table(table))
    # The table owns stdout when no -o is given; the summary then goes to stderr.
    stream = sys.stdout if args.output else sys.stderr
    if args.format == "json":
        print(json.dumps(summary), file=stream)
    else:
        print(", ".join(f"{k}: {_fmt(v)}" for k, v in summary.items() if v not in (None, "")),
              file=stream)
    return EXIT_OK


def _free(args: argparse.Namespace, motor: Any) -> tuple[Any, dict[str, Any]]:
    from profiles.ppmc312.planner import plan_free_curve

    plan = plan_free_curve(motor, clock=args.clock, max_stages=_max_stages(args),
                           pulses=args.pulses, separate_decel=args.separate_decel)
    table = plan.table
    return table, {"stages": len(table.rates), "clock": table.clock.name,
                   "separate_decel": table.separate, "pulses": plan.pulses,
                   "move_time_s": plan.move_time_s, "solve_s": plan.solve_s, "info": plan.info}


def _from_reference(args: argparse.Namespace, motor: Any) -> tuple[Any, dict[str, Any]]:
    from profiles.errors import FormatError
    from profiles.ppmc312.planner import choose_clock
    from profiles.ppmc312.quantise import quantise_reference
    from verify import references

    if args.pulses is None:
        raise FormatError("--from needs --pulses: a reference is a move of N pulses")
    makers: dict[str, Callable[..., Any]] = {"ruckig": references.ruckig_reference,
                                             "toppra": references.toppra_reference}
    ref = makers[args.source](motor, args.pulses)
    q = quantise_reference(ref.t_s, ref.x_pulses, ref.v_pps,
                           clock=args.clock or choose_clock(motor),
                           max_stages=_max_stages(args))
    table = q.table
    return table, {"source": args.source, "reference_s": ref.duration_s,
                   "stages": len(table.rates), "clock": table.clock.name,
                   "max_step_error_us": q.max_step_error_us,
                   "mean_step_error_us": q.mean_step_error_us, "info": q.info}


def _init(args: argparse.Namespace, motor: Any) -> tuple[Any, dict[str, Any]]:
    from profiles.ppmc312.init_planner import Shape, plan_init

    shape: Shape = "s_curve" if args.kind == "s-curve" else "linear"
    # LE=0 by default: the table then exports to both interfaces (docs/manual-notes.md).
    separate = bool(args.separate_decel)
    with progress_bar(f"plan {args.kind}", unit="candidate") as progress:
        plan = plan_init(motor, shape, args.pulses, clock=args.clock,
                         separate_decel=separate, progress=progress)
    table = plan.table
    return table, {"kind": args.kind, "modelled_stages": len(plan.stages.rates),
                   "clock": table.clock.name, "separate_decel": table.separate,
                   "pulses": plan.pulses, "move_time_s": plan.move_time_s,
                   "run": plan.shape_run, "info": plan.info}


def _max_stages(args: argparse.Namespace) -> int:
    return MAX_STAGES_DEFAULT if args.max_stages is None else args.max_stages


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)
