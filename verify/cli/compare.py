"""`stepramp compare`: a table against the continuous time optimum."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ._common import EXIT_FINDINGS, EXIT_OK, fields_as_options, positive_int


def add_subparser(sub: Any) -> None:
    c = sub.add_parser("compare", help="a table against the continuous time optimum")
    c.add_argument("table", metavar="TABLE", help="a table file (free curve or init)")
    c.add_argument("--motor", required=True, metavar="MOTOR",
                   help="the motor: a motor file or a name from `stepramp motor list`")
    c.add_argument("--pulses", type=positive_int, required=True,
                   help="move length [pulses]")
    c.add_argument("--format", choices=("text", "json"), default="text",
                   help="report format (default text; times in ms, JSON in s)")
    c.add_argument("--plot", metavar="OUT.png", help="write a figure (PNG or SVG by extension)")
    c.add_argument("--references", default="toppra,ruckig,casadi",
                   help="comma-separated references to compute (default: all three)")
    c.add_argument("--no-physics", dest="physics", action="store_false",
                   help="skip the load-angle judge (the criterion only); the move is judged "
                        "by both by default, and an unsafe move exits 1")
    c.set_defaults(func=_do_compare)


def _do_compare(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.motor import load_motor
    from profiles.ppmc312.table import load_table
    from profiles.reading import json_text
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
    table, motor = load_table(args.table), load_motor(args.motor)
    with fields_as_options({"pulses": "--pulses"}):
        result = compare_table(table, motor, args.pulses, include=names, physics=args.physics)
    if args.plot:  # a motor file without a name is named by its file
        result.plot(args.plot, motor_label=Path(args.motor).stem)
    if args.format == "json":
        write_output(None, json_text(result.to_json()))
    else:
        write_output(None, result.to_text())
    return EXIT_OK if result.safe else EXIT_FINDINGS
