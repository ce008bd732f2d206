"""`stepramp plan`: the fastest stall-safe table for a motor (free curve or init)."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from typing import Any

from profiles.motor.angles import AIM_DEG

from ._common import (
    CLOCK_NAMES,
    EXIT_FINDINGS,
    EXIT_OK,
    add_cruise_reserve_option,
    cruise_reserve,
    fields_as_options,
    internal_clock,
    number,
    planned_for,
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
    p.add_argument("--distance-mm", type=number, metavar="MM",
                   help="the move's length [mm] instead of --pulses: the motor file's "
                        "travel_mm_per_rev turns it into the nearest whole pulses (said when "
                        "not exact)")
    p.add_argument("--distance-rev", type=number, metavar="REV",
                   help="the move's length in motor revolutions [rev] instead of --pulses")
    p.add_argument("--separate-decel", action=argparse.BooleanOptionalAction, default=None,
                   help="separate decel counts (LE=1); default: free curve whichever is "
                        "faster, init tables no (the ASCII init command has no LE=1 form)")
    p.add_argument("--from", dest="source", choices=("ruckig", "toppra"),
                   help="free curve: follow this continuous reference's shape (its "
                        "acceleration speed by speed), tightened like a plan, and report its "
                        "time beside the reference's and the planner's (needs --pulses)")
    p.add_argument("--moves", metavar="MIX.csv",
                   help="free curve: plan one table for a duty cycle: a CSV with header "
                        "pulses,weight, a row per move length the machine runs; minimises "
                        "the weighted sum of move times [s] (instead of --pulses)")
    p.add_argument("--load-angle", type=number, default=AIM_DEG, metavar="DEG",
                   help="tighten the table until its worst load angle over every move length "
                        "(an init table's: and every motion command judged) is at most this "
                        f"[°] (electrical degrees; default {AIM_DEG:g}; 90 is the torque peak)")
    p.add_argument("--commands", type=lambda text: tuple(text.split(",")),
                   metavar="CODE|NAME[,…]",
                   help="the motion commands the machine runs, by code or name (as check "
                        "--commands): the verdict, and an init table's tightening, judge "
                        "only these besides every move (82) (default: all)")
    add_cruise_reserve_option(p)
    p.add_argument("--format", choices=("text", "json"), default="text",
                   help="the summary's format (the table itself is always JSON)")
    p.add_argument("-o", "--output", metavar="TABLE", help="write the table here (default stdout)")
    p.set_defaults(func=_do_plan)


def _do_plan(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError, require_number
    from profiles.motor import load_motor
    from profiles.motor.angles import PEAK_DEG
    from profiles.motor.loads import friction_warning
    from profiles.ppmc312.table import dump_table
    from profiles.reading import json_text
    from verify.output import write_output
    from verify.plan_text import plain_summary, real_units, top_pps
    from verify.safety import judge_safety

    with fields_as_options(OPTIONS):  # NaN, ±inf and negatives stop here, before any work
        require_number("load angle target [°]", args.load_angle, 1.0, PEAK_DEG)
    asked = distance_to_pulses(args)  # a length in mm or rev: pulses, once, at the edge
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
    if args.commands is not None:
        from profiles.ppmc312.command_verdicts import command_names

        command_names(args.commands)  # an unknown one: one line, before any work
    reserve = cruise_reserve(args)
    motor = load_motor(args.motor)
    warned = friction_warning(motor.friction_torque_nm,
                              motor.tolerance("friction_torque_nm")[1])
    if warned:
        print(f"stepramp plan: warning: {args.motor}: {warned}", file=sys.stderr)
    # every planner takes its top speed from the motor: capped, they all keep the reserve
    planned = reserve.applied(motor)
    with fields_as_options(OPTIONS):
        if args.kind != "free":
            table, summary = _init(args, planned, motor)
        elif args.source:
            table, summary = _from_reference(args, planned)
        elif args.moves is not None:
            table, summary = _duty_cycle(args, planned)
        else:
            table, summary = _free(args, planned)
    made = summary.pop("_plan")
    kept = reserve.at(motor, top_pps(table))
    summary["cruise_reserve"] = kept.to_json()
    verdict = judge_safety(table, motor, aim_deg=min(args.load_angle, PEAK_DEG),
                           commands=args.commands)
    if not verdict.safe:
        # never write a table that is unsafe for some move length the chip can run
        print(f"stepramp plan: refused: the table is not stall-safe for every move length: "
              f"{verdict.describe()}", file=sys.stderr)
        fix = (getattr(made, "extras", None) or {}).get("fix")
        if fix:
            print(f"stepramp plan: what would help: {fix}", file=sys.stderr)
        return EXIT_FINDINGS
    summary["safety"] = verdict.to_json()
    summary.update(real_units(summary, table, planned))
    if asked is not None:
        summary[f"asked_move_{asked.unit}"] = asked.asked
    table = replace(table, provenance=plan_provenance(args, motor))
    write_output(args.output, dump_table(table))
    # The table owns stdout when no -o is given; the summary then goes to stderr.
    stream = sys.stdout if args.output else sys.stderr
    if args.format == "json":
        print(json_text(summary, indent=None), end="", file=stream)
    else:
        lines = plain_summary(summary, made, table, planned, kept, verdict,
                              aim_deg=min(args.load_angle, PEAK_DEG),
                              check=f"stepramp check {args.output or 'TABLE'} --motor {args.motor}"
                              + ("" if args.commands is None
                                 else " --commands " + ",".join(args.commands)))
        print("\n".join(lines), file=stream)
    return EXIT_OK


def _free(args: argparse.Namespace, motor: Any) -> tuple[Any, dict[str, Any]]:
    from profiles.ppmc312.planner import plan_free_curve

    plan = plan_free_curve(motor, clock=args.clock, max_stages=_max_stages(args),
                           pulses=args.pulses, separate_decel=args.separate_decel,
                           load_angle_deg=args.load_angle)
    table = plan.table
    return table, {"stages": len(table.rates), "clock": table.clock.name,
                   "separate_decel": table.separate, "pulses": plan.pulses,
                   "move_time_s": plan.duration_s, "solve_s": plan.solve_s, "info": plan.info,
                   "_plan": plan}


def _duty_cycle(args: argparse.Namespace, motor: Any) -> tuple[Any, dict[str, Any]]:
    from profiles.ppmc312.planner import plan_duty_cycle
    from profiles.reading import display_path

    mix = read_mix(args.moves, mix_bytes(args))
    with progress_bar("plan --moves", unit="table") as progress:
        plan, times = plan_duty_cycle(motor, mix, clock=args.clock,
                                      max_stages=_max_stages(args),
                                      separate_decel=args.separate_decel,
                                      load_angle_deg=args.load_angle, progress=progress)
    candidates = plan.extras["candidates"]
    if len(mix) > len(times) or not set(times) <= set(candidates):
        # the planner did not plan a table for each row: say what it did instead
        print(f"stepramp plan: note: {display_path(args.moves)}: {len(mix)} rows, "
              f"{_count(len(times), 'distinct move length')} (equal lengths' weights summed); "
              f"{_count(len(candidates), 'candidate table')} planned ("
              + ("every length and the middles of neighbours" if set(times) <= set(candidates)
                 else "the mix's weighted quantiles and lengths spread from its shortest to "
                      "its longest")
              + "), each timed on every length", file=sys.stderr)
    table = plan.table
    return table, {"stages": len(table.rates), "clock": table.clock.name,
                   "separate_decel": table.separate, "weighted_time_s": plan.duration_s,
                   "move_times_s": {str(n): t for n, t in times.items()},
                   "solve_s": plan.solve_s, "info": plan.info, "_plan": plan}


def mix_bytes(args: argparse.Namespace) -> bytes:
    """The move-mix file's bytes, read once: `--moves -` is standard input, which the
    plan and its provenance (the file's hash) both need."""
    from profiles.reading import read_bytes

    raw: bytes | None = getattr(args, "moves_raw", None)
    if raw is None:
        raw = args.moves_raw = read_bytes(args.moves)
    return raw


def read_mix(path: str, raw: bytes) -> list[tuple[int, float]]:
    """A duty-cycle CSV: header `pulses,weight`, then a row per move length (a length
    may repeat: the planner sums its weights). Bounded: the file by the input cap, each
    field by the characters a number may have, the rows and distinct lengths by the
    duty-cycle caps; a bad row is one line naming the file, the line and the field."""
    import csv
    import io

    from profiles.errors import FormatError
    from profiles.ppmc312.planner.duty_cycle import MIX_LENGTHS_MAX, MIX_ROWS_MAX
    from profiles.reading import display_path, utf8_text

    name = display_path(path)
    text = utf8_text(raw, path, encoding="utf-8-sig")  # a spreadsheet's BOM too
    reader = csv.reader(io.StringIO(text))
    mix: list[tuple[int, float]] = []
    try:
        header = next(reader, None)
        if header is None or [c.strip().lower() for c in header] != ["pulses", "weight"]:
            shown = _echo(",".join(header)) if header else "nothing"
            raise FormatError(f"{name}: the first line must be the header pulses,weight "
                              f"(got {shown})")
        for row in reader:
            if not any(c.strip() for c in row):
                continue
            if len(mix) == MIX_ROWS_MAX:
                raise FormatError(f"{name}: more than {MIX_ROWS_MAX} rows, the cap of "
                                  "plan --moves: merge equal or nearby lengths")
            mix.append(_mix_row(row, f"{name}, line {reader.line_num}"))
    except csv.Error as e:
        raise FormatError(f"{name}, line {reader.line_num}: cannot be read as CSV ({e})") from None
    if not mix:
        raise FormatError(f"{name}: no move lengths after the header")
    distinct = len({n for n, _ in mix})
    if distinct > MIX_LENGTHS_MAX:
        raise FormatError(f"{name}: {distinct} distinct move lengths, more than the "
                          f"{MIX_LENGTHS_MAX} plan --moves takes: merge nearby lengths")
    return mix


def _mix_row(row: list[str], where: str) -> tuple[int, float]:
    """One row of a mix: (pulses, weight), each field checked where it is named."""
    from profiles.errors import FieldRangeError, FormatError, require_number
    from profiles.ppmc312.planner.duty_cycle import MIX_PULSES_MIN, MIX_WEIGHT_MAX
    from profiles.reading import MAX_NUMBER_CHARS

    if len(row) != 2:
        raise FormatError(f"{where}: {len(row)} fields, expected 2: pulses,weight")
    pulses, weight = (c.strip() for c in row)
    for field, value in (("pulses", pulses), ("weight", weight)):
        if len(value) > MAX_NUMBER_CHARS:
            raise FormatError(f"{where}, {field}: {len(value)} characters, more than the "
                              f"{MAX_NUMBER_CHARS} a number may have")
    try:
        n = int(pulses)
    except ValueError:
        raise FormatError(f"{where}, pulses: {_echo(pulses)} is not an integer") from None
    try:
        w = float(weight)
    except ValueError:
        raise FormatError(f"{where}, weight: {_echo(weight)} is not a number") from None
    if not MIX_PULSES_MIN <= n <= 0xFFFFFFFF:
        # 8: the shortest move a free curve is planned for (2 stages × 2 pulses × 2 sides)
        raise FieldRangeError(f"{where}, pulses", n, MIX_PULSES_MIN, 0xFFFFFFFF)
    return n, require_number(f"{where}, weight", w, 0.0, MIX_WEIGHT_MAX)


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _echo(text: str) -> str:
    """An input field as a message shows it: quoted, and cut when long."""
    return repr(text) if len(text) <= 60 else f"{text[:60]!r}… ({len(text)} characters)"


def _from_reference(args: argparse.Namespace, motor: Any) -> tuple[Any, dict[str, Any]]:
    from profiles.errors import FormatError
    from profiles.motor.angles import PEAK_DEG
    from profiles.ppmc312.planner.reference_plan import plan_from_reference, reference_basis
    from verify import references

    if args.pulses is None:
        raise FormatError("--from needs --pulses: a reference is a move of N pulses")
    # the planner follows the reference as data (profiles never import verify): solved here
    solve: dict[str, Any] = {"ruckig": references.ruckig_reference,
                             "toppra": references.toppra_reference}
    ref = solve[args.source](reference_basis(motor), args.pulses)
    followed = plan_from_reference(motor, args.pulses, args.source, ref, clock=args.clock,
                                   max_stages=_max_stages(args),
                                   load_angle_deg=min(args.load_angle, PEAK_DEG))
    table = followed.plan.table
    return table, {**followed.summary(), "stages": len(table.rates),
                   "clock": table.clock.name, "separate_decel": table.separate,
                   "pulses": args.pulses, "solve_s": followed.plan.solve_s,
                   "info": followed.plan.info, "_plan": followed.plan}


def _init(args: argparse.Namespace, planned: Any, motor: Any) -> tuple[Any, dict[str, Any]]:
    """The init table tightened until the one verdict (on `motor`, over the commands
    asked) finds it within the aim (profiles.ppmc312.planner.init_planner.tighten_init), planned
    for `planned` (the motor with the cruise reserve's top speed)."""
    from profiles.motor.angles import PEAK_DEG
    from profiles.ppmc312.init_judge import init_judge
    from profiles.ppmc312.planner.init_planner import tighten_init
    from profiles.ppmc312.table import InitShape

    shape: InitShape = "s_curve" if args.kind == "s-curve" else "linear"
    # LE=0 by default: the table then exports to both interfaces (docs/manual-notes.md).
    separate = bool(args.separate_decel)
    aim = min(args.load_angle, PEAK_DEG)
    with progress_bar(f"plan {args.kind}", unit="candidate") as progress:
        plan = tighten_init(planned, shape, args.pulses,
                            init_judge(motor, aim_deg=aim, commands=args.commands),
                            clock=args.clock, separate_decel=separate, aim_deg=aim,
                            progress=progress)
    table, levers = plan.table, plan.extras["levers"]
    plain = plan.extras["untightened"]
    return table, {"kind": args.kind, "modelled_stages": len(plan.extras["stages"].rates),
                   "clock": table.clock.name, "separate_decel": table.separate,
                   "pulses": plan.pulses, "move_time_s": plan.duration_s,
                   "run": plan.extras["shape_run"], "info": plan.info,
                   "tightening": {"start_scale": levers.start, "ramp_scale": levers.ramp,
                                  "top_scale": levers.top, "plans": plan.extras["plans"],
                                  "untightened_move_time_s": plain.duration_s,
                                  "untightened_start_rate": plain.table.start_rate,
                                  "untightened_high_rate": plain.table.high_rate,
                                  "price": plan.duration_s / plain.duration_s,
                                  "fix": plan.extras.get("fix")},
                   "_plan": plan}


def plan_provenance(args: argparse.Namespace, motor: Any) -> Any:
    """What the table was planned for (profiles/provenance.py): the motor as typed and
    its hash, the move lengths (a mix: its lengths and its file), the aim, the safety
    factor, the cruise reserve, the motion commands judged (--commands, by name), this
    version and the date."""
    import hashlib

    from profiles.motor.angles import PEAK_DEG
    from profiles.provenance import PULSES_LISTED_MAX, FileRef
    from profiles.reading import display_path

    pulses: tuple[int, ...] | None = None if args.pulses is None else (args.pulses,)
    moves = None
    if args.moves is not None:
        raw = mix_bytes(args)
        lengths = sorted({n for n, _ in read_mix(args.moves, raw)})
        pulses = tuple(lengths) if len(lengths) <= PULSES_LISTED_MAX else None
        moves = FileRef(display_path(args.moves), hashlib.sha256(raw).hexdigest())
    commands = None
    if args.commands is not None:
        from profiles.ppmc312.command_verdicts import command_names

        commands = command_names(args.commands)
    return planned_for(args.motor, motor, pulses=pulses, moves_file=moves,
                       aim_deg=min(args.load_angle, PEAK_DEG),
                       reserve=cruise_reserve(args), commands=commands)


def distance_to_pulses(args: argparse.Namespace) -> Any:
    """`--distance-mm` or `--distance-rev` as `args.pulses`, the nearest whole pulses
    (profiles/motor/travel.py; the rounding said on stderr when not exact); the length as
    asked (`Rounded`), or None when the move is given in pulses. Refused in one line
    naming the flag and its unit: with --pulses or --moves, in mm on a motor without
    travel_mm_per_rev, out of 1..2³²−1 pulses."""
    from profiles.errors import FormatError
    from profiles.motor import load_motor
    from profiles.motor.travel import AxisUnits, axis_units, pulses_of

    given = [(flag, value) for flag, value in (("--distance-mm", args.distance_mm),
                                               ("--distance-rev", args.distance_rev))
             if value is not None]
    if not given:
        return None
    if len(given) > 1 or args.pulses is not None or args.moves is not None:
        raise FormatError("--pulses, --distance-mm and --distance-rev each give the move's "
                          "length (--moves a mix of them): give one")
    flag, value = given[0]
    motor = load_motor(args.motor)
    units = axis_units(motor)
    if flag == "--distance-rev":
        units = AxisUnits(motor.steps_per_rev)
    elif not units.linear:
        raise FormatError(f"--distance-mm [mm]: motor {args.motor} has no travel_mm_per_rev "
                          "(a rotary axis, or a file made without its screw or belt): give "
                          "--distance-rev [rev] or --pulses, or make the motor with `stepramp "
                          "motor new --load screw:… | --travel-mm-per-rev MM`")
    rounded = pulses_of(units, value, flag=f"{flag} [{units.distance_unit}]", lo_pulses=1,
                        hi_pulses=0xFFFFFFFF)
    if not rounded.exact:
        print(f"stepramp plan: note: {rounded.note(flag)}", file=sys.stderr)
    args.pulses = rounded.pulses
    return rounded


def _max_stages(args: argparse.Namespace) -> int:
    return MAX_STAGES_DEFAULT if args.max_stages is None else args.max_stages
