"""`stepramp link …`: talk to a PPMC-312 slave over its serial line (ASCII mode)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ._common import (
    EXIT_FINDINGS,
    EXIT_OK,
    add_motion_options,
    fields_as_options,
    motion_params,
    number,
    positive_int,
)


def add_subparser(sub: Any) -> None:
    link = sub.add_parser("link", help="send commands to a PPMC-312 slave over RS-485 "
                                       "(ASCII serial mode)")
    link.add_argument("--port", required=True,
                      help="serial port: a device (/dev/ttyUSB0, COM3) or a pyserial URL")
    link.add_argument("--baud", type=int, default=19_200, choices=(19_200, 38_400, 83_333),
                      help="line speed [bit/s], 8N1 (default 19200)")
    link.add_argument("--address", type=positive_int, required=True,
                      help="slave address 0-15")
    link.add_argument("--timeout-s", type=number, default=0.2,
                      help="wait for each reply [s] (default 0.2)")
    link.add_argument("--retries", type=positive_int, default=3,
                      help="resends of one command after a timeout or a damaged frame "
                           "(default 3)")
    link.add_argument("-v", "--verbose", action="store_true",
                      help="print every frame sent and every reply, decoded as `stepramp "
                           "answer --serial` decodes it, and say when the link waits for "
                           "the chip (after an init, §7-1)")
    lsub = link.add_subparsers(dest="link_command", required=True, metavar="COMMAND")
    init = lsub.add_parser("init", help="send an init table (linear or S-curve, LE=0)")
    init.add_argument("table", metavar="TABLE", help="an init table file (stepramp.table/1)")
    _add_move(lsub)
    lsub.add_parser("poll", help="busy, ready, or why pulse output stopped")
    lsub.add_parser("position", help="the pulse position counter [pulses]")
    lsub.add_parser("errors", help="the line error count and the last error code")
    lsub.add_parser("stop", help="stop pulse output at once")
    link.set_defaults(func=_do_link)


def _add_move(lsub: Any) -> None:
    """`link move`: the accel/decel move (82) by default, or any serial motion command of
    the registry (`--command NAME`; `stepramp move`'s options), at once or, for stop,
    decel-stop, change-speed and set-speed, registered to start at a position or on an event
    input (`--override-at`, `--on`: their §16 forms 8B…8E, 9B…9E, BB…BE)."""
    move = lsub.add_parser("move", help="start an accel/decel move, or send any motion "
                                        "command (--command NAME)")
    add_motion_options(move, command_help=" (its §16 frame; started at once unless "
                                           "--override-at or --on)",
                       override_at_help="registered in the override buffer, taking effect "
                                        "where the position counter reaches POS [pulses] (8B, "
                                        "8C, 8E, 8D); a later poll reports it (override "
                                        "command executed, B0 21, or aborted, B0 49)",
                       on_help="registered, taking effect when event input /EVT0 (evt1: "
                               "9B…9E) or /EVT1 (evt2: BB…BE) fires")


def _do_link(args: argparse.Namespace) -> int:
    from profiles.ppmc312.link import ChipRefused, Exchange, Link

    if args.link_command == "move":
        # An unusable request is refused before the port is opened.
        from profiles.ppmc312.motion import COMMANDS, DEFAULT, encode_command

        command = COMMANDS[args.motion or DEFAULT]
        args.params, typed = motion_params(args, command, "stepramp link move")
        with fields_as_options({"rate": typed.get("rate", "--rate"),
                                "high_rate": typed.get("rate", "--rate"),
                                "pulses": "--pulses", "position": "--override-at"}):
            encode_command(command.name, to="ascii", address=args.address, **args.params)

    def note(text: str) -> None:
        print(f"slave {args.address}: {text}", flush=True)

    def heard(exchange: Exchange) -> None:
        note(f"{exchange.what}: sent {exchange.sent.hex(' ').upper()}"
             + (f" (resend {exchange.attempt})" if exchange.attempt else ""))
        for line in _reply_lines(exchange):
            print("  " + line, flush=True)

    with Link(args.port, args.address, baud=args.baud, timeout_s=args.timeout_s,
              retries=args.retries, on_note=note if args.verbose else None,
              on_reply=heard if args.verbose else None) as link:
        try:
            print(f"slave {args.address}: {_run(link, args)}", flush=True)
            if args.link_command == "init":
                # This process ends here: the next `link move` cannot know the window,
                # so init returns only once the chip accepts motion commands.
                link.wait_until_motion_accepted()
        except ChipRefused as refused:
            print(f"stepramp link: {refused}", file=sys.stderr)
            return EXIT_FINDINGS
    return EXIT_OK


def _reply_lines(exchange: Any) -> list[str]:
    """A reply as `stepramp answer --serial --reply-to …` shows it: its bytes as they came
    (to paste there), its name, then its fields, indented."""
    from profiles.errors import DecodeError
    from profiles.ppmc312.replies import decode_reply

    got = exchange.reply.hex(" ").upper()
    try:
        lines = decode_reply(exchange.reply, reply_to=exchange.reply_to).describe()
    except DecodeError as e:
        # A frame the link took that no reading of the manual fits (an unknown special
        # code): shown as it came; the link's own message follows.
        return [f"reply {got}: {e}"]
    return [f"reply {got}: {lines[0]}", *lines[1:]]


def _run(link: Any, args: argparse.Namespace) -> str:
    command = args.link_command
    if command == "init":
        from profiles.ppmc312.table import InitTable, load_table

        table = load_table(args.table)
        link.init(table)  # refuses a free curve: it has no serial form
        assert isinstance(table, InitTable)
        return (f"init accepted: {table.shape}, start rate {table.start_rate}, high rate "
                f"{table.high_rate}, {table.accel_pulses} accel/decel pulses")
    if command == "move":
        return _move(link, args)
    if command == "poll":
        return str(link.poll())
    if command == "position":
        # The 32-bit counter, 0…0xFFFFFFFF (§2-1.6, §10-3), as the link reads it.
        return f"position {link.position()} pulses"
    if command == "errors":
        report = link.errors()
        return (f"{report.error_count} line error(s) (framing, overrun and checksum); "
                f"last error code 0x{report.error_code:02X} ({report.error_text})")
    link.stop()
    return "pulse output stopped"


_EVENT_PINS = {"evt1": "/EVT0", "evt2": "/EVT1"}   # the serial forms' イベント入力0, 1


def _move(link: Any, args: argparse.Namespace) -> str:
    from profiles.ppmc312.command_runs import STARTS
    from profiles.ppmc312.motion import COMMANDS

    params = args.params
    if args.motion is None:  # the accel/decel move as `link move` always sent it
        link.move(params["pulses"], ccw=bool(params.get("ccw")),
                  high_rate=params.get("rate", 0))
        return f"move of {args.pulses} pulses {'CCW' if args.ccw else 'CW'} started"
    link.motion(args.motion, **params)
    shown = [f"{params['pulses']} pulses" if "pulses" in params else "",
             f"rate {params['rate']}" if "rate" in params else "",
             "CCW" if params.get("ccw") else "", "with /INDEX" if params.get("index") else "",
             f"at position {params['override_at']}" if "override_at" in params else "",
             f"on {_EVENT_PINS[params['on']]}" if "on" in params else ""]
    what = ", ".join(part for part in shown if part)
    registered = "override_at" in params or "on" in params
    done = "registered" if registered else "started" if args.motion in STARTS else "taken"
    return f"{COMMANDS[args.motion].label} {done}" + (f": {what}" if what else "")
