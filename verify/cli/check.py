"""`stepramp check`: table or upload files against the chip's rules."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ._common import (
    CLOCK_NAMES,
    EXIT_FINDINGS,
    EXIT_OK,
    EXIT_UNUSABLE,
    MOTOR_METAVAR,
    add_sample_options,
    clock_or_extck,
    load_motor,
    number,
    progress_bar,
    pulse_list,
)


def add_subparser(sub: Any) -> None:
    c = sub.add_parser("check", help="check any file stepramp writes or reads against its "
                                     "device's rules")
    c.add_argument("files", nargs="+", metavar="FILE",
                   help="any file stepramp writes or reads: tables, uploads and move commands "
                        "(every format), the chip's table-read answer, sync's files, A-Link "
                        "settings, MC-200 streams, axes and motor files")
    c.add_argument("--format", choices=("text", "json", "junit"), default="text",
                   help="report format (default text: a rule with many findings in a file is "
                        "summarised; json and junit hold every finding)")
    c.add_argument("-v", "--verbose", action="store_true",
                   help="text: list every finding, none summarised")
    c.add_argument("--motor", metavar=MOTOR_METAVAR,
                   help="also judge stall-safety for this motor (a motor file or a name from "
                        "`stepramp motor list`): the criterion and the load angle, over every "
                        "move length the chip can run with the table")
    c.add_argument("--pulses", type=pulse_list, metavar="N[,M…]",
                   help="with --motor: judge only the moves of these lengths [pulses] "
                        "(default: every length 1..0xFFFFFFFF)")
    c.add_argument("--commands", type=lambda text: tuple(text.split(",")),
                   metavar="CODE|NAME[,…]",
                   help="with --motor: the motion commands the machine runs, by code or name "
                        "(82,81 or accel,decel-stop): besides every move (82), the verdict "
                        "judges a decel stop (81) at every pulse of the ramp under every "
                        "reading; leave out a command the machine never uses (default: all); "
                        "for A-Link settings the unit's commands (move-a,stop,change-speed,"
                        "limit,home…)")
    c.add_argument("--no-physics", dest="physics", action="store_false",
                   help="with --motor: skip the load-angle judge (the criterion only)")
    add_sample_options(c, "with --motor: ")
    c.add_argument("--strict", action="store_true",
                   help="with --motor: report resonance-dwell as an error, not a warning")
    c.add_argument("--extck-hz", type=number,
                   help="external clock frequency of EXTCK uploads [Hz]")
    c.add_argument("--clock", type=clock_or_extck,
                   help=f"the clock of the chip's table-read answer (41), which does not carry "
                        f"it: {CLOCK_NAMES}, or EXTCK with --extck-hz")
    c.add_argument("-o", "--output", metavar="OUT", help="write the report here (default stdout)")
    c.set_defaults(func=_do_check)


def _do_check(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.reading import display_path
    from verify.check_file import check_file
    from verify.output import write_output
    from verify.report import render

    if args.motor is None:  # options that judge with a motor are errors without one
        for option, given in (("--pulses", args.pulses is not None),
                              ("--commands", args.commands is not None),
                              ("--no-physics", not args.physics), ("--strict", args.strict)):
            if given:
                raise FormatError(f"{option} applies to the stall verdict: it needs --motor")
    # `is not None`: --motor '' is a wrong path, not "no motor" (the stall check would
    # silently not run and the table pass).
    motor = load_motor(args.motor) if args.motor is not None else None
    if args.commands is not None:
        from profiles.alink.safety import COMMAND_FAMILIES, alink_families
        from profiles.ppmc312.command_verdicts import command_names

        try:  # an unknown one: one line, before any file is read
            command_names(args.commands)
        except FormatError as e:
            try:  # A-Link settings files take the unit's command names
                alink_families(args.commands)
            except FormatError:
                raise FormatError(f"{e}; or A-Link commands ("
                                  + ", ".join(sorted(COMMAND_FAMILIES)) + ")") from None
    with progress_bar("check over the tolerance box", unit="part") as progress:
        results = [check_file(path, motor, args.extck_hz, pulses=args.pulses,
                              physics=args.physics, samples=args.samples, seed=args.seed,
                              strict=args.strict, clock=args.clock, progress=progress,
                              commands=args.commands)
                   for path in args.files]
    write_output(args.output, render(results, args.format, verbose=args.verbose))
    if any(r.error for r in results):
        # The report says it too, but it may have gone to a file: one line per unusable input.
        for r in results:
            if r.error:
                name = display_path(r.path)
                shown = display_path(r.error)
                print(f"stepramp check: {shown if shown.startswith(name) else f'{name}: {shown}'}",
                      file=sys.stderr)
        return EXIT_UNUSABLE
    return EXIT_OK if all(r.ok for r in results) else EXIT_FINDINGS
