"""`stepramp plan`: the fastest stall-safe table for a motor (free curve or init)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import Any

from profiles.motor.angles import AIM_DEG

from ._common import (
    CLOCK_NAMES,
    EXIT_FINDINGS,
    EXIT_OK,
    fields_as_options,
    internal_clock,
    number,
    positive_int,
    progress_bar,
)

OPTIONS = {"pulses": "--pulses", "max_stages": "--max-stages",
           "load angle target [°]": "--load-angle"}

KINDS = ("free", "linear", "s-curve")
MAX_STAGES_DEFAULT = 127


def add_subparser(sub: Any) -> None:
    p = sub.add_parser("plan", help="plan the fastest stall-safe table for a motor")
    p.add_argument("--motor", required=True, metavar="MOTOR",
                   help="the motor: a motor file or a name from `stepramp motor list`")
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
    p.add_argument("--moves", metavar="MIX.csv",
                   help="free curve: plan one table for a duty cycle: a CSV with header "
                        "pulses,weight, a row per move length the machine runs; minimises "
                        "the weighted sum of move times [s] (instead of --pulses)")
    p.add_argument("--load-angle", type=number, default=AIM_DEG, metavar="DEG",
                   help="free curve: tighten the table until its worst load angle over every "
                        f"move length is at most this [°] (electrical degrees; default "
                        f"{AIM_DEG:g}; 90 is the torque peak)")
    p.add_argument("--format", choices=("text", "json"), default="text",
                   help="the summary's format (the table itself is always JSON)")
    p.add_argument("-o", "--output", metavar="TABLE", help="write the table here (default stdout)")
    p.set_defaults(func=_do_plan)


def _do_plan(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.motor import load_motor
    from profiles.motor.angles import PEAK_DEG
    from profiles.ppmc312.table import dump_table
    from profiles.reading import json_text
    from verify.output import write_output
    from verify.safety import judge_safety

    if args.moves is not None and (args.pulses is not None or args.source):
        raise FormatError("--moves plans for a mix of lengths: give it without --pulses "
                          "and --from")
    if args.kind != "free":
        for given, option in ((args.source, "--from"), (args.max_stages, "--max-stages"),
                              (args.moves, "--moves")):
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
        elif args.moves:
            table, summary = _duty_cycle(args, motor)
        else:
            table, summary = _free(args, motor)
    verdict = judge_safety(table, motor, aim_deg=min(args.load_angle, PEAK_DEG))
    if not verdict.safe:
        # never write a table that is unsafe for some move length the chip can run
        print(f"stepramp plan: refused: the table is not stall-safe for every move length: "
              f"{verdict.describe()}", file=sys.stderr)
        return EXIT_FINDINGS
    summary["safety"] = verdict.to_json()
    write_output(args.output, dump_table(table))
    # The table owns stdout when no -o is given; the summary then goes to stderr.
    stream = sys.stdout if args.output else sys.stderr
    if args.format == "json":
        print(json_text(summary, indent=None), end="", file=stream)
    else:
        summary.pop("safety")
        print(", ".join(f"{k}: {_fmt(v)}" for k, v in summary.items() if v not in (None, "")),
              file=stream)
        print(f"verdict: {verdict.describe()}", file=stream)
    return EXIT_OK


def _free(args: argparse.Namespace, motor: Any) -> tuple[Any, dict[str, Any]]:
    from profiles.ppmc312.planner import plan_free_curve

    plan = plan_free_curve(motor, clock=args.clock, max_stages=_max_stages(args),
                           pulses=args.pulses, separate_decel=args.separate_decel,
                           load_angle_deg=args.load_angle)
    table = plan.table
    return table, {"stages": len(table.rates), "clock": table.clock.name,
                   "separate_decel": table.separate, "pulses": plan.pulses,
                   "move_time_s": plan.duration_s, "solve_s": plan.solve_s, "info": plan.info}


def _duty_cycle(args: argparse.Namespace, motor: Any) -> tuple[Any, dict[str, Any]]:
    from profiles.ppmc312.planner import plan_duty_cycle

    mix = read_mix(args.moves)
    plan, times = plan_duty_cycle(motor, mix, clock=args.clock, max_stages=_max_stages(args),
                                  separate_decel=args.separate_decel,
                                  load_angle_deg=args.load_angle)
    table = plan.table
    return table, {"stages": len(table.rates), "clock": table.clock.name,
                   "separate_decel": table.separate, "weighted_time_s": plan.duration_s,
                   "move_times_s": {str(n): t for n, t in times.items()},
                   "solve_s": plan.solve_s, "info": plan.info}


def read_mix(path: str) -> list[tuple[int, float]]:
    """A duty-cycle CSV: header `pulses,weight`, one row per move length."""
    import csv
    import io

    from profiles.errors import FormatError
    from profiles.reading import read_bytes

    try:
        text = read_bytes(path).decode("utf-8")
    except UnicodeDecodeError:
        raise FormatError(f"{path}: not a UTF-8 text file") from None
    rows = list(csv.reader(io.StringIO(text)))
    header = [c.strip().lower() for c in rows[0]] if rows else []
    if header != ["pulses", "weight"]:
        raise FormatError(f"{path}: the first line must be the header pulses,weight "
                          f"(got {','.join(rows[0]) if rows else 'nothing'})")
    mix: list[tuple[int, float]] = []
    for line, row in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in row):
            continue
        if len(row) != 2:
            raise FormatError(f"{path}, line {line}: expected pulses,weight, got {row!r}")
        try:
            n, w = int(row[0].strip()), float(row[1].strip())
        except ValueError:
            raise FormatError(f"{path}, line {line}: pulses must be an integer and weight a "
                              f"number, got {row!r}") from None
        if not 1 <= n <= 0xFFFFFFFF or not 0 <= w < float("inf"):
            raise FormatError(f"{path}, line {line}: pulses 1..4294967295 and a weight ≥ 0 "
                              f"(got {n}, {w})")
        mix.append((n, w))
    if not mix:
        raise FormatError(f"{path}: no move lengths after the header")
    return mix


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
                   "max_step_error_us": q.extras["max_step_error_us"],
                   "mean_step_error_us": q.extras["mean_step_error_us"], "info": q.info}


def _init(args: argparse.Namespace, motor: Any) -> tuple[Any, dict[str, Any]]:
    from profiles.ppmc312.init_planner import Shape, plan_init

    shape: Shape = "s_curve" if args.kind == "s-curve" else "linear"
    # LE=0 by default: the table then exports to both interfaces (docs/manual-notes.md).
    separate = bool(args.separate_decel)
    with progress_bar(f"plan {args.kind}", unit="candidate") as progress:
        plan = plan_init(motor, shape, args.pulses, clock=args.clock,
                         separate_decel=separate, progress=progress)
    table = plan.table
    return table, {"kind": args.kind, "modelled_stages": len(plan.extras["stages"].rates),
                   "clock": table.clock.name, "separate_decel": table.separate,
                   "pulses": plan.pulses, "move_time_s": plan.duration_s,
                   "run": plan.extras["shape_run"], "info": plan.info}


def _max_stages(args: argparse.Namespace) -> int:
    return MAX_STAGES_DEFAULT if args.max_stages is None else args.max_stages


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)
