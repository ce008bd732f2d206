"""`stepramp move`: the bytes of a PPMC-312 motion command (`--command NAME`, default the
accel/decel move 82), looked up in `profiles.ppmc312.motion.COMMANDS`."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import (
    EXIT_OK,
    add_file_format_options,
    fields_as_options,
    positive_int,
    render_upload,
)

# The option that sets each of the registry's parameters (`--high-rate` and `--override`
# are the accel move's older spellings of `--rate` and `--on`).
OPTIONS = {"rate": "--rate", "pulses": "--pulses", "ccw": "--ccw", "index": "--index",
           "override_at": "--override-at", "on": "--on"}
TRIGGERS = {1: "evt1", 3: "evt2"}  # --override TRG: the TRG bits of an event trigger


def add_subparser(sub: Any) -> None:
    from profiles.ppmc312.motion import COMMANDS, DEFAULT

    m = sub.add_parser("move", help="a motion command's bytes (default the accel/decel move, "
                                    "82)")
    m.add_argument("--command", dest="motion", choices=tuple(COMMANDS), default=None,
                   metavar="NAME",
                   help="the motion command: " + ", ".join(
                       f"{c.name} ({c.code:02X})" for c in COMMANDS.values())
                   + f" (default {DEFAULT})")
    m.add_argument("--pulses", type=positive_int,
                   help="the move length [pulses] (accel, constant: required), 1..0xFFFFFFFF")
    m.add_argument("--ccw", action="store_true", help="direction CCW (default CW)")
    m.add_argument("--rate", type=positive_int, metavar="R",
                   help="a rate divisor; 0 = the table's high rate where the manual allows "
                        "it (accel, constant, continuous, continuous-constant, origin-return:"
                        " the default there); required by change-speed, set-speed, "
                        "origin-search and high-speed-limit")
    m.add_argument("--high-rate", type=positive_int, metavar="R",
                   help="accel's high-rate override (its name for --rate; 0 = the table's)")
    m.add_argument("--index", action="store_true",
                   help="origin search/return: find /ORG and /INDEX low together (IDX = 1)")
    m.add_argument("--override-at", type=positive_int, metavar="POS",
                   help="stop, decel-stop, change-speed, set-speed: wait in the override "
                        "buffer until the position counter reaches POS [pulses] (OV = 1, TRG 00)")
    m.add_argument("--on", choices=("evt1", "evt2"),
                   help="wait in the override buffer for event input 1 or 2 (OV = 1, "
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
    options = {**{p: typed.get(p, OPTIONS[p]) for p in OPTIONS}, "address": "--address"}
    with fields_as_options({**options, "position": options["override_at"],
                            "high_rate": options["rate"]}):
        block = encode_command(command.name, to=args.to, address=args.address, **params)
    write_output(args.output, render_upload(args, [block]))
    return EXIT_OK


def motion_params(args: argparse.Namespace, command: Any, usage: str = "stepramp move"
                  ) -> tuple[dict[str, Any], dict[str, str]]:
    """The registry's parameters the options give, and the option that gave each; an
    option the command does not take, two options for one parameter or a missing one is
    one line naming the option (and `usage`, whose help lists them). `stepramp link move`
    shares it; an option its parser lacks counts as not given."""
    from profiles.errors import FormatError

    given = {"--pulses": args.pulses, "--ccw": args.ccw or None, "--rate": args.rate,
             "--high-rate": args.high_rate, "--index": args.index or None,
             "--override-at": getattr(args, "override_at", None),
             "--on": getattr(args, "on", None),
             "--override": TRIGGERS.get(getattr(args, "override", None) or 0)}
    params: dict[str, Any] = {}
    typed: dict[str, str] = {}
    for option, value in given.items():
        if value is None:
            continue
        param = {"--high-rate": "rate", "--override": "on"}.get(option, option[2:]
                                                                 .replace("-", "_"))
        if param not in command.takes or (option == "--high-rate"
                                          and command.rate_field != "high_rate"):
            raise FormatError(f"{option}: {command.label} does not take it "
                              f"({_takes(command, args)})")
        exclusive = {"on": "override_at", "override_at": "on"}.get(param, param)
        clash = typed.get(param) or typed.get(exclusive)
        if clash:
            raise FormatError(f"{option}: give {clash} or {option}, not both")
        params[param] = value
        typed[param] = option
    missing = [OPTIONS[p] for p in command.needs if p not in params]
    if missing:
        scope = "" if args.motion is None else f" by --command {command.name}"
        raise FormatError(f"the following arguments are required{scope}: "
                          f"{', '.join(missing)} (see {usage} --help)")
    return params, typed


def _takes(command: Any, args: argparse.Namespace) -> str:
    # only the options this parser has (`link move` sends no override or event form)
    options = [OPTIONS[p] for p in OPTIONS if p in command.takes and hasattr(args, p)]
    return f"it takes {', '.join(options)}" if options else "it takes no option"
