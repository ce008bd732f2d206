"""`stepramp simulate`: what the chip runs for an accel/decel move, or for a program."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import EXIT_OK, fields_as_options, positive_int


def add_subparser(sub: Any) -> None:
    s = sub.add_parser("simulate", help="what the chip runs for an accel/decel move or a "
                                        "program")
    s.add_argument("table", metavar="TABLE", nargs="?",
                   help="a table file (free curve or init) or an A-Link settings file "
                        "(alink settings, any format: the unit's ramp) with --pulses, or a "
                        "program file (stepramp.program/1: every command it issues); or give "
                        "--axes")
    s.add_argument("--pulses", type=positive_int, help="move length [pulses] (with TABLE)")
    s.add_argument("--axes", metavar="AXES.json",
                   help="a stepramp.axes/1 file whose axes give tables (\"table\": …): every "
                        "axis's move from one trigger, the joint timeline [ms], finish spread "
                        "[µs] and line deviation [pulses]")
    s.add_argument("--high-rate", type=positive_int, default=0,
                   help="high-rate override, a rate divisor (0 = the table's)")
    s.add_argument("--reading", choices=("a", "b", "c"), default="a",
                   help="a program's decel stop from the middle of an accel stage: (a) at once "
                        "from the stage's decel count, (b) finish the stage, (c) at once one "
                        "stage down (default a; check judges every one)")
    s.add_argument("--format", choices=("text", "json"), default="text",
                   help="summary format on stdout (default text)")
    s.add_argument("--csv", metavar="OUT",
                   help="write the per-stage timeline as CSV (ticks and s)")
    s.add_argument("--pulse-times", metavar="OUT",
                   help="write every pulse's time as CSV (pulse, time_s [s]), streamed; at most "
                        "10 M pulses")
    s.add_argument("--samples", metavar="OUT",
                   help="write the staircase sampled at 1000 points as CSV (t_s [s], x_pulses, "
                        "v_pps [pps], a_pps2 [pps²])")
    s.set_defaults(func=_do_simulate)


def _do_simulate(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.ppmc312.execution import (
        pulse_times_csv_chunks,
        samples_csv,
        simulate_move,
        to_csv,
    )
    from profiles.ppmc312.table import load_table
    from profiles.reading import json_text
    from verify.output import Data, write_output, write_outputs

    if args.axes is not None:
        if args.table is not None or args.pulses is not None or args.high_rate:
            raise FormatError("--axes takes the tables and pulses from the axes file: give no "
                              "TABLE, --pulses or --high-rate with it")
        return _simulate_axes(args)
    if args.table is not None and args.pulses is None and _is_program(args.table):
        return _simulate_program(args)
    if args.table is None or args.pulses is None:
        raise FormatError("give TABLE and --pulses, a program file, or --axes AXES.json")
    if _is_alink(args.table):
        return _simulate_alink(args)
    table = load_table(args.table)
    with fields_as_options({"pulses": "--pulses",
                            "high_rate": "--high-rate (0: the table's)"}):
        execution = simulate_move(table, args.pulses, high_rate=args.high_rate)
    # All files or none: a failing --pulse-times leaves no --csv behind. The pulse times
    # are written as they are computed (memory does not grow with the move).
    files: list[tuple[str | None, Data]] = []
    if args.csv:
        files.append((args.csv, to_csv(execution)))
    if args.pulse_times:
        files.append((args.pulse_times, pulse_times_csv_chunks(execution)))
    if args.samples:
        files.append((args.samples, samples_csv(execution, 1000)))
    write_outputs(files)
    if args.format == "json":
        write_output(None, json_text(execution.to_json()))
    else:
        lines = [f"shape: {execution.shape} (status 0x{execution.status:02X})",
                 f"pulses: {execution.pulses}",
                 f"ticks: {execution.ticks}",
                 f"duration: {execution.duration_s:.6f} s "
                 f"(+ {execution.first_pulse_latency_s * 1e6:.0f} µs to the first pulse)",
                 f"segments: {len(execution.segments)}"]
        write_output(None, "\n".join(lines) + "\n")
    return EXIT_OK


def _simulate_axes(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.ppmc312.execution import simulate_move
    from profiles.ppmc312.sync import line_deviation
    from profiles.ppmc312.table import load_table
    from profiles.reading import json_text
    from verify.devices import get, load_axes
    from verify.output import write_output
    from verify.sync.timeline import joint_timeline

    axes = load_axes(args.axes, load_motors=False)
    device = get(axes.device)
    if not device.simulates:
        raise FormatError(f"{args.axes}: simulate --axes runs PPMC-312 tables, not "
                          f"{device.title} {device.files}")
    runs = []
    for a in axes.axes:
        if a.table_path is None:
            raise FormatError(f"{args.axes}: axis {a.name} gives a motor; simulate --axes runs "
                              "tables (\"table\": \"NAME.table.json\"; stepramp sync writes them)")
        runs.append(simulate_move(load_table(a.table_path), a.distance))
    names = [a.name for a in axes.axes]
    if args.format == "json":
        d = [e.duration_s for e in runs]
        doc = {"axes": [{"name": n, "pulses": a.pulses, **e.to_json()}
                        for n, a, e in zip(names, axes.axes, runs, strict=True)],
               "finish_spread_s": max(d) - min(d),
               "max_line_deviation_pulses": line_deviation(runs)[0]}
        write_output(None, json_text(doc))
    else:
        write_output(None, joint_timeline(names, runs))
    return EXIT_OK


def _is_alink(path: str) -> bool:
    """Whether `path` names an A-Link settings file or command list (one that cannot be
    read is not: loading the table then says why)."""
    from profiles.alink.formats import is_settings_file
    from profiles.errors import StepRampError
    from profiles.reading import read_bytes

    try:
        return path != "-" and is_settings_file(read_bytes(path))
    except StepRampError:
        return False


def _simulate_alink(args: argparse.Namespace) -> int:
    """The move the A-Link unit runs with the settings a file leaves (the stage model of
    profiles/alink/ramp.py, the one the load-angle verdict judges)."""
    from profiles.alink.formats import parse
    from profiles.alink.ramp import run_move
    from profiles.errors import FormatError
    from profiles.reading import json_text, read_bytes
    from verify.devices.alink import ramp_of_commands
    from verify.output import Data, write_output, write_outputs

    if args.high_rate or args.samples:
        raise FormatError("an A-Link settings file: --high-rate and --samples are for "
                          "PPMC-312 tables (use --csv, --pulse-times)")
    ramp, _, why = ramp_of_commands(parse(read_bytes(args.table), args.table).items)
    if ramp is None:
        raise FormatError(f"{args.table}: {str(why).removeprefix('--motor: ')}")
    with fields_as_options({"pulses": "--pulses"}):
        move = run_move(ramp, args.pulses)
    files: list[tuple[str | None, Data]] = []
    if args.csv:
        files.append((args.csv, move.segments_csv()))
    if args.pulse_times:
        files.append((args.pulse_times, move.pulse_times_chunks()))
    write_outputs(files)
    if args.format == "json":
        write_output(None, json_text({"ramp": ramp.describe(), **move.to_json()}))
        return EXIT_OK
    lines = [f"A-Link settings: {ramp.describe()}",
             f"shape: {move.shape}",
             f"pulses: {move.pulses} (up {move.up}, {move.middle} at "
             f"{'the speed reached' if move.up < ramp.ramp_pulses else f'{ramp.high_pps:g} pps'}"
             f", down {move.down})",
             f"duration: {move.duration_s:.6f} s (peak {move.peak_pps:.6g} pps)",
             f"segments: {len(move.counts)}"]
    write_output(None, "\n".join(lines) + "\n")
    return EXIT_OK


def _is_program(path: str) -> bool:
    """Whether `path` names a program file (a file that cannot be read is not: loading the
    table then says why)."""
    from profiles.errors import StepRampError
    from profiles.ppmc312.program import FORMAT
    from profiles.reading import read_bytes
    from verify.devices import document_format

    try:
        return path != "-" and document_format(read_bytes(path)) == FORMAT
    except StepRampError:
        return False


def _simulate_program(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.ppmc312.program import load_program
    from profiles.ppmc312.program_verdict import timeline
    from profiles.reading import json_text
    from verify.output import Data, write_output, write_outputs

    if args.high_rate or args.samples:
        raise FormatError("a program gives its own rates and runs several motions: "
                          "--high-rate and --samples are for one move (use --csv, "
                          "--pulse-times)")
    program = load_program(args.table)
    run = program.run(args.reading)
    files: list[tuple[str | None, Data]] = []
    if args.csv:
        files.append((args.csv, run.to_csv(program.names())))
    if args.pulse_times:
        files.append((args.pulse_times, run.pulse_times_chunks()))
    write_outputs(files)
    if args.format == "json":
        write_output(None, json_text({
            "program": {"table": program.table_path, "commands": program.names()},
            "reading": run.reading, "notes": list(run.notes),
            "motions": [m.to_json(program.names()) for m in run.motions]}))
    else:
        write_output(None, timeline(program, run))
    return EXIT_OK
