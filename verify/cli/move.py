"""`stepramp move`: the bytes of the accel/decel move command (82)."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import (
    EXIT_OK,
    add_file_format_options,
    add_move_options,
    fields_as_options,
    positive_int,
    render_upload,
)


def add_subparser(sub: Any) -> None:
    m = sub.add_parser("move", help="the accel/decel move command (82) bytes")
    add_move_options(m)
    m.add_argument("--override", type=int, choices=(1, 3), metavar="TRG",
                   help="register as an override with trigger TRG (1 or 3), parallel only")
    m.add_argument("--to", choices=("parallel", "ascii"), default="parallel",
                   help="parallel bus block or ASCII serial frame (default parallel)")
    m.add_argument("--address", type=positive_int, default=0,
                   help="ASCII slave address 0-15 (default 0)")
    add_file_format_options(m)
    m.add_argument("-o", "--output", metavar="OUT", help="write the file here (default stdout)")
    m.set_defaults(func=_do_move)


def _do_move(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.ppmc312.ascii import encode_serial_move
    from profiles.ppmc312.upload import encode_move
    from verify.output import write_output

    if args.to == "ascii" and args.override:
        raise FormatError("--override has no serial form (parallel bus only)")
    with fields_as_options({"pulses": "--pulses", "address": "--address",
                            "high_rate": "--high-rate"}):
        if args.to == "ascii":
            blocks = [encode_serial_move(args.address, args.pulses, ccw=args.ccw,
                                         high_rate=args.high_rate)]
        else:
            blocks = [encode_move(args.pulses, ccw=args.ccw, high_rate=args.high_rate,
                                  override=args.override is not None,
                                  trigger=args.override or 0)]
    write_output(args.output, render_upload(args, blocks))
    return EXIT_OK
