"""`stepramp design`: the interactive designer as a web page (extra `design`)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ._common import (
    EXIT_OK,
    add_cruise_reserve_option,
    cruise_reserve,
    fields_as_options,
    load_motor,
    positive_int,
)

DEFAULT_PORT = 5006


def add_subparser(sub: Any) -> None:
    d = sub.add_parser("design", help="the interactive designer in the browser (sliders for "
                                      "the move, the load and the aim; live verdict; "
                                      "downloads)")
    d.add_argument("--motor", required=True, metavar="M.json", help="the motor file")
    d.add_argument("--port", type=positive_int, default=DEFAULT_PORT,
                   help=f"serve on 127.0.0.1:PORT (default {DEFAULT_PORT}; 0: a free port)")
    d.add_argument("--pulses", type=positive_int, default=10_000,
                   help="the move length the page opens with [pulses] (default 10000)")
    add_cruise_reserve_option(d, "plan every table")
    d.add_argument("--no-browser", dest="browser", action="store_false",
                   help="only serve and print the address (default: also open a browser)")
    d.set_defaults(func=_do_design)


def _do_design(args: argparse.Namespace) -> int:
    from pathlib import Path

    from profiles.errors import FieldRangeError
    from verify.designer import control_specs
    from verify.designer.web import serve

    if args.port > 65535:
        raise FieldRangeError("--port", args.port, 0, 65535)
    cruise_reserve(args)  # refused before the server starts
    motor = load_motor(args.motor)
    name = Path(args.motor).stem.removeprefix("motor-")  # the files' names
    with fields_as_options({"pulses": "--pulses"}):
        control_specs(motor, args.pulses)  # every input refused before the server starts

    def say(text: str) -> None:
        print(text, flush=True)  # a script reading the address must not wait for a buffer

    with fields_as_options({"pulses": "--pulses"}):
        serve(motor, port=args.port, open_browser=args.browser, pulses=args.pulses,
              motor_name=name, say=say, cruise_reserve=args.cruise_reserve)
    print("stepramp design: stopped", file=sys.stderr)
    return EXIT_OK
