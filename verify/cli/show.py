"""`stepramp show`: a table's stages, speeds and times, one row per stage."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import EXIT_OK, load_motor


def add_subparser(sub: Any) -> None:
    s = sub.add_parser("show", help="list a table's stages: rate, speed, pulses and times")
    s.add_argument("table", metavar="TABLE", help="a table file (free curve or init)")
    s.add_argument("--motor", metavar="M.json",
                   help="also show each stage's speed in rpm (from the motor's steps_per_rev)")
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
    steps = load_motor(args.motor).steps_per_rev if args.motor else None
    try:
        listing = list_stages(table, steps_per_rev=steps)
    except FieldRangeError as e:  # a stage the listing cannot state (a rate of 0)
        raise FormatError(f"{display_path(args.table)}: {e}") from None
    write_output(args.output, listing.render(args.format))
    return EXIT_OK
