"""`stepramp show`: a table's stages, speeds and times, one row per stage."""

from __future__ import annotations

import argparse
import json
from typing import Any

from ._common import EXIT_OK, load_motor


def add_subparser(sub: Any) -> None:
    s = sub.add_parser("show", help="list a table's stages: rate, speed, pulses and times")
    s.add_argument("table", metavar="TABLE", help="a table file (free curve or init)")
    s.add_argument("--motor", metavar="M.json",
                   help="also show each stage's speed in rpm (from the motor's steps_per_rev) "
                        "and the torque reserve the motor keeps at the table's top speed")
    s.add_argument("--cruise-reserve", metavar="Nx,S%|off",
                   help="with --motor: the reserve to hold the top speed to (default: the one "
                        "the table was planned with, else 2x,10%%; see stepramp plan)")
    s.add_argument("--format", choices=("text", "json", "csv"), default="text",
                   help="text (times in ms), json or csv (times in s); default text")
    s.add_argument("-o", "--output", metavar="OUT", help="write the listing here (default stdout)")
    s.set_defaults(func=_do_show)


def _do_show(args: argparse.Namespace) -> int:
    from profiles.errors import FieldRangeError, FormatError
    from profiles.ppmc312.listing import list_stages
    from profiles.ppmc312.table import load_table
    from profiles.reading import display_path
    from verify.output import write_output

    table = load_table(args.table)
    if args.cruise_reserve is not None and not args.motor:
        raise FormatError("--cruise-reserve holds the table's top speed to a motor's torque: "
                          "it needs --motor")
    motor = load_motor(args.motor) if args.motor else None
    try:
        listing = list_stages(table, steps_per_rev=motor and motor.steps_per_rev)
    except FieldRangeError as e:  # a stage the listing cannot state (a rate of 0)
        raise FormatError(f"{display_path(args.table)}: {e}") from None
    text = listing.render(args.format)
    if motor is not None and args.format != "csv":  # a CSV is the stages' columns only
        kept = reserve_of(args, table).at(motor, float(listing.stages.speeds_pps()[0]))
        if args.format == "text":
            text += kept.describe() + "\n"
        else:
            text = json.dumps({**listing.to_json(), "cruise_reserve": kept.to_json()},
                              indent=1) + "\n"
    write_output(args.output, text)
    return EXIT_OK


def reserve_of(args: argparse.Namespace, table: Any) -> Any:
    """The reserve `--cruise-reserve` names, else the one the table was planned with
    (its provenance), else the default."""
    from profiles.motor.reserve import CruiseReserve, parse_cruise_reserve

    spec = args.cruise_reserve
    if spec is None and table.provenance is not None:
        spec = table.provenance.cruise_reserve
    return CruiseReserve() if spec is None else parse_cruise_reserve(spec)
