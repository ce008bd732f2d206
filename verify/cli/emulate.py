"""`stepramp emulate`: the emulated PPMC-312 — a slave in ASCII serial mode on a
pseudo-terminal (`--pty`), or a bus script run through the chip on its parallel bus
(`--bus SCRIPT`)."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import EXIT_FINDINGS, EXIT_OK, positive_int

POSITION_MAX = 0xFFFFFFFF


def _input_at(names: tuple[str, ...]) -> Any:
    """An argparse type: "NAME:POS", NAME one of `names`, POS a counter value."""
    def parse(text: str) -> tuple[str, int]:
        name, sep, pos = text.partition(":")
        if not sep or name.upper() not in names:
            raise argparse.ArgumentTypeError(
                f"{text!r}: give NAME:POS, NAME one of {', '.join(names)}")
        value = positive_int(pos)
        if value > POSITION_MAX:
            raise argparse.ArgumentTypeError(f"{text!r}: POS is 0..0xFFFFFFFF")
        return name.upper(), value
    return parse


def add_subparser(sub: Any) -> None:
    e = sub.add_parser("emulate", help="an emulated PPMC-312: a serial slave to talk to "
                                       "(--pty, until Ctrl-C), or a bus script run through "
                                       "the chip (--bus)")
    # One of the two, named by the handler when neither is given (a one-line error that
    # says what each does, as answer and simulate do).
    how = e.add_mutually_exclusive_group()
    how.add_argument("--pty", action="store_true",
                     help="serve on a new pseudo-terminal; its path is printed first")
    how.add_argument("--bus", metavar="SCRIPT",
                     help="run a bus script (`export --format bus`, or one of your own: WAIT "
                          "CSR.MWEF 0 / WCR / WAR / DWR / WAIT CSR.MREF 0 / RCR -- / RAR / "
                          "DRR lines) through the chip register by register, from power-on; "
                          "exit 1 when a read differs, the procedure slips or the chip would "
                          "raise an alarm (F4 01: a block written over an unread answer)")
    e.add_argument("--address", type=positive_int, default=None,
                   help="with --pty: slave address 0-15 (default 0)")
    e.add_argument("--link", metavar="PATH",
                   help="with --pty: also make a symbolic link PATH to the terminal (removed "
                        "on exit)")
    e.add_argument("--origin-at", type=positive_int, metavar="POS",
                   help="with --pty: /ORG is low where the position counter reads POS "
                        "(0..0xFFFFFFFF): an origin search (10) or high-speed origin return "
                        "(11) meets it there; without it they run until stopped")
    e.add_argument("--event-at", type=_input_at(("0", "1")), action="append", default=[],
                   metavar="N:POS",
                   help="with --pty: the event input /EVTN (0 or 1) fires where a motion's "
                        "counter passes POS: an override registered on it (9B…9E: /EVT0, "
                        "BB…BE: /EVT1) takes effect there; repeatable")
    e.add_argument("--limit-at", type=_input_at(("FL", "BL", "FHL", "BHL")), action="append",
                   default=[], metavar="SIGNAL:POS",
                   help="with --pty: the limit input SIGNAL (FL, FHL: CW; BL, BHL: CCW) is low "
                        "where the counter reads POS: /FL, /BL stop at once (end code 33), "
                        "/FHL, /BHL decelerate at or above 05's speed (34) (§7-6); a start "
                        "that way from POS is refused B0 44; repeatable")
    e.add_argument("--log", action="store_true",
                   help="with --pty: print one line per frame the slave handles")
    e.set_defaults(func=_do_emulate)


def _do_emulate(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError

    if args.bus is not None:
        serial_only = [name for name, given in (("--address", args.address is not None),
                                                ("--link", args.link is not None),
                                                ("--origin-at", args.origin_at is not None),
                                                ("--event-at", bool(args.event_at)),
                                                ("--limit-at", bool(args.limit_at)),
                                                ("--log", args.log)) if given]
        if serial_only:
            raise FormatError(f"{', '.join(serial_only)}: for --pty (the serial slave); "
                              "--bus runs the chip on its parallel bus")
        return _run_bus(args.bus)
    if not args.pty:
        raise FormatError("give --pty (a serial slave on a pseudo-terminal) or --bus SCRIPT "
                          "(a bus script run through the chip)")
    return _serve_pty(args)


def _run_bus(path: str) -> int:
    """The script through the chip: its verdict on one line. A script that cannot be
    read, or a line that is no register access, raises (one line, exit 2); a script that
    runs into a mismatch, a slip or an alarm is a finding about it (exit 1)."""
    from profiles.errors import DecodeError
    from profiles.ppmc312.bus import run_bus_script
    from profiles.reading import display_path, read_bytes

    name = display_path(path)
    try:
        run = run_bus_script(read_bytes(path))
    except DecodeError as e:  # a line that is no register access: named with the file
        raise DecodeError(f"{name}: {e}") from None
    print(f"{name}: {run.message}", flush=True)
    return EXIT_OK if run.ok else EXIT_FINDINGS


def _serve_pty(args: argparse.Namespace) -> int:
    import signal

    from profiles.ppmc312.serial_chip import PtyServer, SerialChip

    address = 0 if args.address is None else args.address
    chip = SerialChip(address, origin_at=args.origin_at,
                      events_at=[(int(n), pos) for n, pos in args.event_at],
                      limits_at=args.limit_at)
    server = PtyServer(chip, link=args.link,
                       on_log=(lambda line: print(line, flush=True)) if args.log else None)
    where = server.path + (f" (link {args.link})" if args.link else "")
    print(f"PPMC-312 slave {address} (ASCII serial mode) on {where}", flush=True)

    def stop(_signum: int, _frame: Any) -> None:
        server.request_stop()

    previous = {s: signal.signal(s, stop) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        server.serve()
    finally:
        server.stop()
        for s, handler in previous.items():
            signal.signal(s, handler)
    return EXIT_OK
