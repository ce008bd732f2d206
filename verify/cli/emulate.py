"""`stepramp emulate --pty`: a PPMC-312 slave in ASCII serial mode on a pseudo-terminal."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import EXIT_OK, positive_int


def add_subparser(sub: Any) -> None:
    e = sub.add_parser("emulate", help="a PPMC-312 serial slave to talk to (until Ctrl-C)")
    e.add_argument("--pty", action="store_true", required=True,
                   help="serve on a new pseudo-terminal; its path is printed first")
    e.add_argument("--address", type=positive_int, default=0,
                   help="slave address 0-15 (default 0)")
    e.add_argument("--link", metavar="PATH",
                   help="also make a symbolic link PATH to the terminal (removed on exit)")
    e.add_argument("--log", action="store_true",
                   help="print one line per frame the slave handles")
    e.set_defaults(func=_do_emulate)


def _do_emulate(args: argparse.Namespace) -> int:
    import signal

    from profiles.ppmc312.serial_chip import PtyServer, SerialChip

    chip = SerialChip(args.address)
    server = PtyServer(chip, link=args.link,
                       on_log=(lambda line: print(line, flush=True)) if args.log else None)
    where = server.path + (f" (link {args.link})" if args.link else "")
    print(f"PPMC-312 slave {args.address} (ASCII serial mode) on {where}", flush=True)

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
