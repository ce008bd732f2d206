"""`stepramp decode`: an upload file (or a table-read response) back into a table."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import EXIT_OK, number


def add_subparser(sub: Any) -> None:
    d = sub.add_parser("decode", help="decode an upload file (hex or bin) back into a table")
    d.add_argument("upload", metavar="UPLOAD")
    d.add_argument("--extck-hz", type=number)
    d.add_argument("--table-read", action="store_true",
                   help="the file is the chip's table-read response (41), not an upload")
    d.add_argument("--clock", help="with --table-read: the table's clock (8MHz … 15.625kHz, "
                                   "or EXTCK with --extck-hz)")
    d.add_argument("-o", "--output", metavar="TABLE")
    d.set_defaults(func=_do_decode)


def _do_decode(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.files import parse_upload
    from profiles.ppmc312.table import Table, dump_table
    from profiles.ppmc312.upload import decode_table_read, decode_upload
    from profiles.reading import read_bytes
    from verify.output import write_output

    blocks = parse_upload(read_bytes(args.upload))
    table: Table
    if args.table_read:
        # The table-read response (41) carries stages, not the CLK field: the user says.
        if not args.clock:
            raise FormatError("--table-read needs --clock (the response does not carry it)")
        clock = (Clock.extck(args.extck_hz) if args.clock == "EXTCK"
                 else Clock.internal(args.clock))
        table = decode_table_read(blocks, clock=clock)
    else:
        table = decode_upload(blocks, extck_hz=args.extck_hz)
    write_output(args.output, dump_table(table))
    return EXIT_OK
