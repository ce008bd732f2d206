"""`stepramp plan`: the fastest stall-safe table for a motor."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from typing import Any

from ._common import EXIT_OK, positive_int


def add_subparser(sub: Any) -> None:
    p = sub.add_parser("plan", help="plan the fastest stall-safe free-curve table for a motor")
    p.add_argument("--motor", required=True, metavar="M.json")
    p.add_argument("--clock", help="8MHz, 1MHz, 500kHz, 250kHz, 62.5kHz or 15.625kHz "
                                   "(default: the finest that fits the motor)")
    p.add_argument("--max-stages", type=positive_int, default=127)
    p.add_argument("--pulses", type=positive_int, help="plan for a move of N pulses")
    p.add_argument("--separate-decel", action=argparse.BooleanOptionalAction, default=None,
                   help="separate decel counts (LE=1); default: whichever is faster")
    p.add_argument("--from", dest="source", choices=("ruckig", "toppra"),
                   help="quantise this continuous reference instead of optimising the staircase")
    p.add_argument("--format", choices=("text", "json"), default="text",
                   help="the summary's format (the table itself is always JSON)")
    p.add_argument("-o", "--output", metavar="TABLE", help="write the table here (default stdout)")
    p.set_defaults(func=_do_plan)


def _do_plan(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.motor import load_motor
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.table import dump_table
    from verify.output import write_output

    motor = load_motor(args.motor)
    clock = Clock.internal(args.clock) if args.clock else None
    if args.source:
        from profiles.ppmc312.planner import choose_clock
        from profiles.ppmc312.quantise import quantise_reference
        from verify import references

        if args.pulses is None:
            raise FormatError("--from needs --pulses: a reference is a move of N pulses")
        makers: dict[str, Callable[..., Any]] = {"ruckig": references.ruckig_reference,
                                                 "toppra": references.toppra_reference}
        make = makers[args.source]
        ref = make(motor, args.pulses)
        q = quantise_reference(ref.t_s, ref.x_pulses, ref.v_pps,
                               clock=clock or choose_clock(motor), max_stages=args.max_stages)
        table = q.table
        summary = {"source": args.source, "reference_s": ref.duration_s,
                   "stages": len(table.rates), "clock": table.clock.name,
                   "max_step_error_us": q.max_step_error_us,
                   "mean_step_error_us": q.mean_step_error_us, "info": q.info}
    else:
        from profiles.ppmc312.planner import plan_free_curve

        plan = plan_free_curve(motor, clock=clock, max_stages=args.max_stages,
                               pulses=args.pulses, separate_decel=args.separate_decel)
        table = plan.table
        summary = {"stages": len(table.rates), "clock": table.clock.name,
                   "separate_decel": table.separate, "pulses": plan.pulses,
                   "move_time_s": plan.move_time_s, "solve_s": plan.solve_s, "info": plan.info}
    write_output(args.output, dump_table(table))
    # The table owns stdout when no -o is given; the summary then goes to stderr.
    stream = sys.stdout if args.output else sys.stderr
    if args.format == "json":
        print(json.dumps(summary), file=stream)
    else:
        print(", ".join(f"{k}: {_fmt(v)}" for k, v in summary.items() if v not in (None, "")),
              file=stream)
    return EXIT_OK


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)
