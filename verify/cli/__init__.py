"""The `stepramp` command.

Exit codes: 0 ok, 1 findings (errors in a checked file, or a refused export),
2 unusable input (one line on stderr, no traceback, no output file left).
Every sub-command imports what it needs inside its handler, so `stepramp
check` never pays for toppra, casadi or matplotlib.

One module per command group, each with `add_subparser(sub)` registering its
parser and handler (`set_defaults(func=…)`). A new command is one module in
this package plus one entry in `COMMANDS`. Command modules share only
`_common` and never import each other; the logic they call lives in the library.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from profiles.errors import StepRampError

from ._common import EXIT_OK, EXIT_UNUSABLE, VersionAction

# The order here is the order of `stepramp --help`.
COMMANDS: tuple[str, ...] = (
    "check", "show", "export", "decode", "move", "expand",
    "plan", "simulate", "compare", "sync",
    "sweep",
    "alink", "mc200", "motor",
    "link", "emulate",
)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="stepramp", description=__doc__.splitlines()[0])
    p.add_argument("--version", action=VersionAction)
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"{__name__}.{name}").add_subparser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # argparse prints its own one-line usage error
        return EXIT_UNUSABLE if e.code not in (0, None) else EXIT_OK
    try:
        return int(args.func(args))
    except StepRampError as e:
        print(f"stepramp {args.command}: {e}", file=sys.stderr)
        return EXIT_UNUSABLE
    except OSError as e:
        print(f"stepramp {args.command}: {e.filename or ''}: {e.strerror or e}", file=sys.stderr)
        return EXIT_UNUSABLE
    except BrokenPipeError:  # pragma: no cover - `stepramp … | head`
        return EXIT_OK
