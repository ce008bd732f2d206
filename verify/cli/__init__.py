"""The `stepramp` command.

Exit codes: 0 ok, 1 findings (errors in a checked file, or a refused export),
2 unusable input (one line on stderr, no traceback, no output file left).
Every sub-command imports what it needs inside its handler, so `stepramp
check` never pays for toppra, casadi or matplotlib.

One module per command group, each with `add_subparser(sub)` registering its
parser and handler (`set_defaults(func=…)`). A new command is one module in
this package plus one entry in `COMMANDS` (a device's own group: its registry entry,
verify/devices). Command modules share only
`_common` and never import each other; the logic they call lives in the library.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import signal
import sys
import traceback
from collections.abc import Mapping, Sequence
from typing import NoReturn

# Before numpy loads: OpenBLAS starts a thread per core at import, 0.1 s of CPU on every
# cold start, for matrix products the commands never make (their numpy work is
# elementwise; the load-angle judge runs its own threads). A user's setting wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from profiles.compiling import announce, lean
from profiles.errors import StepRampError, bounded
from profiles.reading import display_path
from verify.devices import command_groups
from verify.output import OutputInterrupted

from ._common import EXIT_OK, EXIT_UNUSABLE, VersionAction, guard_paths

# The order here is the order of `stepramp --help`; each device's own command group
# (verify/devices) comes after the commands every device shares.
COMMANDS: tuple[str, ...] = (
    "check", "show", "export", "decode", "move", "expand",
    "plan", "simulate", "compare", "sync", "design",
    "sweep",
    *command_groups(),
    "motor",
    "link", "emulate", "answer",
)


class OneLineParser(argparse.ArgumentParser):
    """argparse whose usage errors are one line (`stepramp check: the following arguments
    are required: FILE`) and exit 2, like every other unusable input; sub-parsers inherit
    the class."""

    commands: Mapping[str, argparse.ArgumentParser]  # build_parser's, by command name

    def error(self, message: str) -> NoReturn:
        print(f"{self.prog}: {bounded(display_path(message))} (see {self.prog} --help)",
              file=sys.stderr)
        self.exit(EXIT_UNUSABLE)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The whole command line, or only `command`'s branch when it is a known command:
    registering a group imports its library modules (the codecs behind its options'
    choices), which `stepramp check` would otherwise pay on every cold start."""
    p = OneLineParser(prog="stepramp", description=__doc__.splitlines()[0])
    p.add_argument("--version", action=VersionAction)
    p.add_argument("--debug", action="store_true",
                   help="on an internal error, show the Python traceback (also accepted "
                        "anywhere on the command line)")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS if command not in COMMANDS else (command,):
        importlib.import_module(f"{__name__}.{name}").add_subparser(sub)
    p.commands = sub.choices  # each command's own parser, for the errors it names
    return p


def command_parser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    """`command`'s own parser in `build_parser`'s result (the top one if it has none)."""
    commands: Mapping[str, argparse.ArgumentParser] = getattr(parser, "commands", {})
    return commands.get(command, parser)


# Positional and option names that hold the command's input, in the order an error
# line names them.
_INPUTS = ("files", "table", "upload", "file", "motor", "words")


def _command_named(args: Sequence[str]) -> str | None:
    """The command a command line names: its first word when that is not an option."""
    return args[0] if args and not args[0].startswith("-") else None


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command. The error contract: 0 ok, 1 findings, 2 unusable input with one
    line on stderr naming the command (and the input); an unexpected exception is a bug,
    reported the same way as an internal error (`--debug` shows the traceback) and never
    as exit 1, which CI reads as "findings"."""
    if argv is None:  # the `stepramp` process itself (not a caller in its own process)
        lean()
    args_list = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args_list or bool(os.environ.get("STEPRAMP_DEBUG"))
    args_list = [a for a in args_list if a != "--debug"]
    parser = build_parser(_command_named(args_list))
    try:
        args, extra = parser.parse_known_args(args_list)
        if extra:  # named by the command's own parser ("stepramp answer: …"), not the top's
            command_parser(parser, args.command).error(
                f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit as e:  # --help/--version (0) or a usage error (printed, 2)
        return EXIT_OK if e.code in (0, None) else EXIT_UNUSABLE
    command = args.command  # the group for alink/mc200 ("stepramp mc200: …"), as before
    args.argv = args_list  # the command line, for the provenance files carry
    # the first run on a machine compiles the kernels: half a minute that must not look hung
    announce(lambda line: _say(command, line))
    try:
        guard_paths(args)  # before anything is read or written
        return int(args.func(args))
    except StepRampError as e:
        _say(command, str(e))
        return EXIT_UNUSABLE
    except BrokenPipeError:  # `stepramp … | head`: the reader has all it wanted
        _quiet_stdout()
        return EXIT_OK
    except OSError as e:
        where = f"{display_path(e.filename)}: " if e.filename else ""
        _say(command, f"{where}{e.strerror or e}")
        return EXIT_UNUSABLE
    except KeyboardInterrupt:
        _say(command, "interrupted")
        return 128 + signal.SIGINT
    except OutputInterrupted as e:
        _say(command, f"interrupted by signal {e.signum}; no output was left half-written")
        return 128 + e.signum
    except Exception as e:  # the catch-all of the contract: a bug, never exit 1
        if debug:
            traceback.print_exc()
        _say(command, f"internal error ({e.__class__.__name__}: {_first_line(e)})"
                      f"{_input_of(args)}; this is a bug in stepramp: please report it "
                      "(--debug shows the traceback)")
        return EXIT_UNUSABLE


def _say(command: str, message: str) -> None:
    # bounded: a message echoing a hostile input field stays a readable line
    print(f"stepramp {command}: {bounded(display_path(_first_line(message)))}",
          file=sys.stderr)


def _first_line(e: object) -> str:
    text = str(e).strip()
    return text.splitlines()[0] if text else ""


def _input_of(args: argparse.Namespace) -> str:
    for name in _INPUTS:
        value = getattr(args, name, None)
        if value:
            shown = " ".join(value) if isinstance(value, list) else str(value)
            return f" on {shown[:200]}"
    return ""


def _quiet_stdout() -> None:
    # Python would report the broken pipe again when it flushes stdout at exit.
    with contextlib.suppress(OSError, ValueError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
