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
                   help="also show each stage's speed in rpm (from the motor's steps_per_rev), "
                        "in mm/s when the motor file has travel_mm_per_rev (without --motor: "
                        "the motor the table was planned for, when it is found unchanged), "
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
        units, note = units_for(table, motor)
        listing = list_stages(table, steps_per_rev=motor and motor.steps_per_rev,
                              units=units)
    except FieldRangeError as e:  # a stage the listing cannot state (a rate of 0)
        raise FormatError(f"{display_path(args.table)}: {e}") from None
    text = listing.render(args.format)
    if note and args.format == "text":
        text += note + "\n"
    if motor is not None and args.format != "csv":  # a CSV is the stages' columns only
        kept = reserve_of(args, table).at(motor, float(listing.stages.speeds_pps()[0]))
        if args.format == "text":
            text += kept.describe() + "\n"
        else:
            text = json.dumps({**listing.to_json(), "cruise_reserve": kept.to_json()},
                              indent=1) + "\n"
    write_output(args.output, text)
    return EXIT_OK


def units_for(table: Any, motor: Any) -> tuple[Any, str]:
    """The real units the listing gives (profiles/motor/travel.py) and, when they come
    from the table's provenance, the line that says so: `--motor`'s; else, for mm only,
    the motor the table was planned for, when its name still finds it and its hash is
    the one planned with (a rotary motor adds nothing unasked)."""
    from profiles.errors import StepRampError
    from profiles.motor.travel import axis_units
    from profiles.provenance import content_sha256

    if motor is not None:
        return axis_units(motor), ""
    planned = getattr(table, "provenance", None)
    if planned is None:
        return None, ""
    try:
        found = load_motor(planned.motor.name)
    except StepRampError:
        return None, ""
    units = axis_units(found)
    if not units.linear or content_sha256(found.to_json()) != planned.motor.sha256:
        return None, ""
    return units, (f"mm from the motor it was planned for: {planned.motor.short}, "
                   f"{units.describe()}")


def reserve_of(args: argparse.Namespace, table: Any) -> Any:
    """The reserve `--cruise-reserve` names, else the one the table was planned with
    (its provenance), else the default."""
    from profiles.motor.reserve import CruiseReserve, parse_cruise_reserve

    spec = args.cruise_reserve
    if spec is None and table.provenance is not None:
        spec = table.provenance.cruise_reserve
    return CruiseReserve() if spec is None else parse_cruise_reserve(spec)
