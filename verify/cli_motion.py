"""`stepramp plan`, `simulate` and `compare`: the motion side of the CLI."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from typing import Any

from profiles.errors import FormatError


def register(sub: Any) -> None:
    from verify.cli import _positive_int

    p = sub.add_parser("plan", help="plan the fastest stall-safe free-curve table for a motor")
    p.add_argument("--motor", required=True, metavar="M.json")
    p.add_argument("--clock", help="8MHz, 1MHz, 500kHz, 250kHz, 62.5kHz or 15.625kHz "
                                   "(default: the finest that fits the motor)")
    p.add_argument("--max-stages", type=_positive_int, default=127)
    p.add_argument("--pulses", type=_positive_int, help="plan for a move of N pulses")
    p.add_argument("--separate-decel", action=argparse.BooleanOptionalAction, default=None,
                   help="separate decel counts (LE=1); default: whichever is faster")
    p.add_argument("--from", dest="source", choices=("ruckig", "toppra"),
                   help="quantise this continuous reference instead of optimising the staircase")
    p.add_argument("--format", choices=("text", "json"), default="text",
                   help="the summary's format (the table itself is always JSON)")
    p.add_argument("-o", "--output", metavar="TABLE", help="write the table here (default stdout)")
    p.set_defaults(func=cmd_plan)

    s = sub.add_parser("simulate", help="what the chip runs for an accel/decel move")
    s.add_argument("table", metavar="TABLE")
    s.add_argument("--pulses", type=_positive_int, required=True)
    s.add_argument("--high-rate", type=_positive_int, default=0)
    s.add_argument("--format", choices=("text", "json"), default="text")
    s.add_argument("--csv", metavar="OUT", help="write the per-stage timeline as CSV")
    s.add_argument("--pulse-times", metavar="OUT",
                   help="write every pulse's time [s] as CSV (pulse,time_s); ≤ 10 M pulses")
    s.add_argument("--samples", metavar="OUT",
                   help="write the staircase sampled at 1000 points as CSV (t_s,x,v_pps,a_pps2)")
    s.set_defaults(func=cmd_simulate)

    c = sub.add_parser("compare", help="a table against the continuous time optimum")
    c.add_argument("table", metavar="TABLE")
    c.add_argument("--motor", required=True, metavar="M.json")
    c.add_argument("--pulses", type=_positive_int, required=True)
    c.add_argument("--format", choices=("text", "json"), default="text")
    c.add_argument("--plot", metavar="OUT.png", help="write a figure (PNG or SVG by extension)")
    c.add_argument("--references", default="toppra,ruckig,casadi",
                   help="comma-separated references to compute (default: all three)")
    c.add_argument("--physics", action="store_true", help="also run the load-angle simulation")
    c.set_defaults(func=cmd_compare)


def cmd_plan(args: argparse.Namespace) -> int:
    from profiles.motor import load_motor
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.table import dump_table
    from verify.cli import EXIT_OK
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


def cmd_simulate(args: argparse.Namespace) -> int:
    from profiles.ppmc312.execution import simulate_move, to_csv
    from profiles.ppmc312.table import load_table
    from verify.cli import EXIT_OK
    from verify.output import write_output

    execution = simulate_move(load_table(args.table), args.pulses, high_rate=args.high_rate)
    if args.csv:
        write_output(args.csv, to_csv(execution))
    if args.pulse_times:
        import numpy as np

        times = execution.pulse_times_s()
        rows = np.column_stack([np.arange(1, len(times) + 1), times])
        write_output(args.pulse_times, "pulse,time_s\n" + "".join(
            f"{int(i)},{t:.9f}\n" for i, t in rows))
    if args.samples:
        t, x, v, a = execution.sample(1000)
        write_output(args.samples, "t_s,x_pulses,v_pps,a_pps2\n" + "".join(
            f"{ti:.9f},{xi:.6f},{vi:.6f},{ai:.6f}\n" for ti, xi, vi, ai in zip(
                t, x, v, a, strict=True)))
    if args.format == "json":
        write_output(None, json.dumps(execution.to_json(), indent=1) + "\n")
    else:
        lines = [f"shape: {execution.shape} (status 0x{execution.status:02X})",
                 f"pulses: {execution.pulses}",
                 f"ticks: {execution.ticks}",
                 f"duration: {execution.duration_s:.6f} s "
                 f"(+ {execution.first_pulse_latency_s * 1e6:.0f} µs to the first pulse)",
                 f"segments: {len(execution.segments)}"]
        write_output(None, "\n".join(lines) + "\n")
    return EXIT_OK


def cmd_compare(args: argparse.Namespace) -> int:
    from profiles.motor import load_motor
    from profiles.ppmc312.table import load_table
    from verify.cli import EXIT_OK
    from verify.compare import compare_table
    from verify.output import write_output
    from verify.references import SOLVERS

    if args.plot and not args.plot.lower().endswith((".png", ".svg")):
        raise FormatError(f"--plot {args.plot}: the figure format is taken from the "
                          "extension: .png or .svg")
    names = tuple(n.strip() for n in args.references.split(",") if n.strip())
    unknown = set(names) - set(SOLVERS)
    if unknown:  # refused before any table is read or solver run
        raise FormatError(f"--references: unknown {', '.join(sorted(unknown))} "
                          f"(choose from {', '.join(SOLVERS)})")
    result = compare_table(load_table(args.table), load_motor(args.motor), args.pulses,
                           include=names, physics=args.physics)
    if args.plot:
        result.plot(args.plot)
    if args.format == "json":
        write_output(None, json.dumps(result.to_json(), indent=1) + "\n")
    else:
        write_output(None, result.to_text())
    return EXIT_OK


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)
