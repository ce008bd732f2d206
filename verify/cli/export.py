"""`stepramp export`: a table encoded into the bytes the device takes."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import (
    EXIT_FINDINGS,
    EXIT_OK,
    add_file_format_options,
    fields_as_options,
    positive_int,
    refuse_table_errors,
    render_upload,
)


def add_subparser(sub: Any) -> None:
    e = sub.add_parser("export", help="encode a table into the bytes the device takes")
    e.add_argument("table", metavar="TABLE", help="a table file (free curve or init)")
    e.add_argument("--to", choices=("parallel", "ascii"), default="parallel",
                   help="the chip's interface: parallel bus blocks or ASCII serial frames "
                        "(default parallel)")
    e.add_argument("--address", type=positive_int, default=0,
                   help="ASCII slave address 0-15 (default 0)")
    add_file_format_options(e)
    e.add_argument("--motor", metavar="M.json",
                   help="the motor the table was planned for: named in the file's provenance "
                        "comment (C header)")
    # The literal keeps the parser free of profiles' imports; a test holds it equal to
    # profiles.ppmc312.frames.REV13_BLOCK_DATA.
    e.add_argument("--max-block-data", type=positive_int, default=14,
                   help="data bytes per parameter block, 3-30 (default 14: the REV 1.3 "
                        "limit, manual §5-5, which every revision accepts; up to 30 only "
                        "for chips known to take REV 1.1 blocks)")
    e.add_argument("--force", action="store_true", help="export even a table with errors")
    e.add_argument("-o", "--output", metavar="OUT", help="write the file here (default stdout)")
    e.set_defaults(func=_do_export)


def _do_export(args: argparse.Namespace) -> int:
    from profiles.ppmc312.table import load_table
    from profiles.ppmc312.upload import encode_table
    from verify.output import write_output

    table = load_table(args.table)
    if not args.force and refuse_table_errors(args.table, table, "fix them or pass --force"):
        return EXIT_FINDINGS
    with fields_as_options({"address": "--address", "max_data": "--max-block-data"}):
        blocks = encode_table(table, to=args.to, address=args.address,
                              max_data=args.max_block_data)
    motor = None
    if args.motor:
        from profiles.motor import load_motor

        motor = load_motor(args.motor).name or args.motor
    write_output(args.output, render_upload(args, blocks, table, motor))
    return EXIT_OK
