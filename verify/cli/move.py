"""`stepramp move`: the bytes of a PPMC-312 motion command (`--command NAME`, default the
accel/decel move 82), looked up in `profiles.ppmc312.motion.COMMANDS`."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import (
    EXIT_OK,
    MOTION_OPTIONS,
    add_file_format_options,
    add_motion_options,
    fields_as_options,
    motion_params,
    positive_int,
    render_upload,
)


def add_subparser(sub: Any) -> None:
    m = sub.add_parser("move", help="a motion command's bytes (default the accel/decel move, "
                                    "82)")
    add_motion_options(m, command_help="",
                       override_at_help="wait in the override buffer until the position "
                                        "counter reaches POS [pulses] (OV = 1, TRG 00)",
                       on_help="wait in the override buffer for event input 1 or 2 (OV = 1, "
                               "TRG 01 or 11)")
    m.add_argument("--override", type=int, choices=(1, 3), metavar="TRG",
                   help="--on's older spelling: TRG 1 (evt1) or 3 (evt2)")
    m.add_argument("--to", choices=("parallel", "ascii"), default="parallel",
                   help="parallel bus block or ASCII serial frame (default parallel)")
    m.add_argument("--address", type=positive_int, default=0,
                   help="ASCII slave address 0-15 (default 0)")
    add_file_format_options(m)
    m.add_argument("-o", "--output", metavar="OUT", help="write the file here (default stdout)")
    m.set_defaults(func=_do_move)


def _do_move(args: argparse.Namespace) -> int:
    from profiles.ppmc312.motion import COMMANDS, DEFAULT, encode_command
    from verify.output import write_output

    command = COMMANDS[args.motion or DEFAULT]
    params, typed = motion_params(args, command)
    options = {**{p: typed.get(p, MOTION_OPTIONS[p]) for p in MOTION_OPTIONS},
               "address": "--address"}
    with fields_as_options({**options, "position": options["override_at"],
                            "high_rate": options["rate"]}):
        block = encode_command(command.name, to=args.to, address=args.address, **params)
    write_output(args.output, render_upload(args, [block]))
    return EXIT_OK
