"""`stepramp decode`: an upload file (or a table-read response) back into a table."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ._common import CLOCK_NAMES, EXIT_OK, clock_or_extck, fields_as_options, number


def add_subparser(sub: Any) -> None:
    d = sub.add_parser("decode", help="decode an upload file (any format) back into a table")
    d.add_argument("upload", metavar="UPLOAD",
                   help="an upload file: text (hex), bin, ihex, c, json or bus, told apart by "
                        "content; its CRC-32 (or Intel HEX checksums) is verified")
    d.add_argument("--extck-hz", type=number,
                   help="external clock frequency of an EXTCK upload [Hz]")
    d.add_argument("--table-read", action="store_true",
                   help="the file is the chip's table-read response (41), not an upload")
    d.add_argument("--clock", type=clock_or_extck,
                   help=f"with --table-read: the table's clock, {CLOCK_NAMES}, or EXTCK with "
                        "--extck-hz")
    d.add_argument("--edge", choices=("rising", "falling"), default=None,
                   help="with --table-read --clock EXTCK: the EXTCK edge the chip counts "
                        "(default rising; the response does not carry it)")
    d.add_argument("-o", "--output", metavar="TABLE",
                   help="write the table file here (default stdout)")
    d.set_defaults(func=_do_decode)


def _do_decode(args: argparse.Namespace) -> int:
    from profiles.ppmc312.formats import parse
    from profiles.ppmc312.table import Table, dump_table
    from profiles.reading import read_bytes, require_shallow_json
    from verify.output import write_output

    raw = read_bytes(args.upload)
    _not_another_device(raw)
    require_shallow_json(raw, args.upload)  # a JSON upload is parsed by formats.parse
    parsed = parse(raw, args.upload)  # a failed check: CorruptedError
    table: Table
    with fields_as_options({"extck_hz": "--extck-hz"}):
        table = _decode(args, parsed.items)
    # Decoded, but nothing vouches for the bytes (a table-read answer is a capture from
    # the bus, never a file stepramp wrote: no check is expected there).
    if parsed.integrity != "verified" and not args.table_read:
        print(f"stepramp decode: warning: {args.upload}: {parsed.detail}", file=sys.stderr)
    write_output(args.output, dump_table(table))
    return EXIT_OK


def _not_another_device(raw: bytes) -> None:
    """Another device's file is no upload: say which command reads it (else the PPMC-312
    reader would report its bytes as broken blocks)."""
    from profiles.errors import FormatError
    from verify.devices import detect

    device = detect(raw)
    if device.reader != "stepramp decode":
        raise FormatError(f"an {device.title} {device.files} file, not a PPMC-312 upload: "
                          f"read it with {device.reader}")


def _decode(args: argparse.Namespace, blocks: Any) -> Any:
    from profiles.errors import FormatError
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.upload import decode_table_read, decode_upload

    if args.edge is not None and not (args.table_read and args.clock == "EXTCK"):
        raise FormatError("--edge is for --table-read --clock EXTCK (an upload carries its "
                          "edge in the CLK field)")
    if args.table_read:
        # The table-read response (41) carries stages, not the CLK field: the user says.
        if not args.clock:
            raise FormatError("--table-read needs --clock (the response does not carry it)")
        if args.clock == "EXTCK":
            if args.extck_hz is None:
                raise FormatError("--clock EXTCK needs --extck-hz (the external frequency)")
            clock = Clock.extck(args.extck_hz, args.edge or "rising")
        else:
            clock = Clock.internal(args.clock)
        return decode_table_read(blocks, clock=clock)
    return decode_upload(blocks, extck_hz=args.extck_hz)
