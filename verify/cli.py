"""The `stepramp` command.

Exit codes: 0 ok, 1 findings (errors in a checked file, or a refused export),
2 unusable input (one line on stderr, no traceback, no output file left).
Every sub-command imports what it needs inside its handler, so `stepramp
check` never pays for toppra, casadi or matplotlib.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from typing import Any

from profiles.errors import FormatError, StepRampError
from verify.output import write_output

EXIT_OK, EXIT_FINDINGS, EXIT_UNUSABLE = 0, 1, 2


def _positive_int(text: str) -> int:
    try:
        value = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} is negative")
    return value


def _float(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


# --- check -----------------------------------------------------------------
def _check_one(path: str, motor: Any, extck_hz: float | None) -> Any:
    from verify.checks import check_table
    from verify.report import FileResult

    try:
        table, chip_findings = _load_checkable(path, extck_hz)
        findings = list(chip_findings)
        if table is not None:
            findings += check_table(table)
        if motor is not None and table is not None:
            from profiles.ppmc312.init_model import InitBuildError, as_free_curve
            from verify.stall import check_stall

            try:
                findings += check_stall(as_free_curve(table), motor)
            except InitBuildError:
                pass  # no stages to judge: check_table has reported why, with the chip's code
    except StepRampError as e:
        return FileResult(path=path, ok=False, findings=[], error=str(e))
    findings = _dedupe(findings)
    ok = not any(f.severity == "error" for f in findings)
    return FileResult(path=path, ok=ok, findings=findings)


def _dedupe(findings: list[Any]) -> list[Any]:
    seen: set[Any] = set()
    out = []
    for f in findings:
        if f not in seen:
            seen.add(f)
            out.append(f)
    return out


def _load_checkable(path: str, extck_hz: float | None) -> tuple[Any | None, list[Any]]:
    """A table file, or an upload file judged first by what the chip would answer."""
    from profiles.ppmc312.table import table_from_json
    from profiles.reading import parse_json, read_bytes

    raw = read_bytes(path)
    if _looks_like_table_json(raw):
        return table_from_json(parse_json(raw, path)), []
    from profiles.ppmc312.emulator import accept_upload
    from profiles.ppmc312.files import parse_upload
    from profiles.ppmc312.upload import decode_upload
    from verify.findings import Finding

    blocks = parse_upload(raw)
    findings: list[Any] = []
    if blocks and blocks[0][:1] in (b"\x02", b"\x03"):  # parallel blocks: ask the chip model
        verdict = accept_upload(blocks)
        if not verdict.ok:
            # F0 carries a parameter-error code; F1/F6 (state, size) are the code themselves.
            code = verdict.error_code if verdict.response_code == 0xF0 else verdict.response_code
            findings.append(Finding("error", "chip-rejects-upload", verdict.message,
                                    chip_code=code, stage=None))
            return None, findings
    return decode_upload(blocks, extck_hz=extck_hz), findings


def _looks_like_table_json(raw: bytes) -> bool:
    """A JSON object that is not a `{"blocks": …}` upload is judged as a table file, so
    a wrong or missing "format" is reported as such."""
    if raw.lstrip()[:1] != b"{":
        return False
    return b"stepramp.table/1" in raw or b'"blocks"' not in raw


def cmd_check(args: argparse.Namespace) -> int:
    from verify.report import render

    motor = _load_motor(args.motor) if args.motor else None
    results = []
    for path in args.files:
        result = _check_one(path, motor, args.extck_hz)
        results.append(result)
    write_output(args.output, render(results, args.format))
    if any(r.error for r in results):
        return EXIT_UNUSABLE
    return EXIT_OK if all(r.ok for r in results) else EXIT_FINDINGS


def _load_motor(path: str) -> Any:
    from profiles.motor import load_motor

    return load_motor(path)


# --- export / decode ---------------------------------------------------------
def cmd_export(args: argparse.Namespace) -> int:
    from profiles.ppmc312.files import render
    from profiles.ppmc312.table import load_table
    from profiles.ppmc312.upload import encode_table
    from verify.checks import check_table

    table = load_table(args.table)
    errors = [f for f in check_table(table) if f.severity == "error"]
    if errors and not args.force:
        for f in errors:
            stage = "" if f.stage is None else f" stage {f.stage}"
            code = "" if f.chip_code is None else f" (chip {f.chip_code_hex})"
            print(f"{args.table}: error [{f.rule}]{stage}{code}: {f.message}", file=sys.stderr)
        print(f"{args.table}: refused: {len(errors)} error(s); fix them or pass --force",
              file=sys.stderr)
        return EXIT_FINDINGS
    blocks = encode_table(table, to=args.to, address=args.address, max_data=args.max_block_data)
    write_output(args.output, render(blocks, args.format))
    return EXIT_OK


def cmd_decode(args: argparse.Namespace) -> int:
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.files import parse_upload
    from profiles.ppmc312.table import Table, dump_table
    from profiles.ppmc312.upload import decode_table_read, decode_upload
    from profiles.reading import read_bytes

    blocks = parse_upload(read_bytes(args.upload))
    table: Table
    if args.table_read:
        # The table-read response (41) carries stages, not the CLK field: the user says.
        if not args.clock:
            raise FormatError("--table-read needs --clock (the response does not carry it)")
        clock = (Clock.extck(args.extck_hz) if args.clock == "EXTCK"
                 else Clock.internal(args.clock))
        table = decode_table_read(blocks, clock=clock)
    else:
        table = decode_upload(blocks, extck_hz=args.extck_hz)
    write_output(args.output, dump_table(table))
    return EXIT_OK


def cmd_move(args: argparse.Namespace) -> int:
    from profiles.ppmc312.ascii import encode_serial_move
    from profiles.ppmc312.files import render
    from profiles.ppmc312.upload import encode_move

    if args.to == "ascii":
        if args.override:
            raise FormatError("--override has no serial form (parallel bus only)")
        blocks = [encode_serial_move(args.address, args.pulses, ccw=args.ccw,
                                     high_rate=args.high_rate)]
    else:
        blocks = [encode_move(args.pulses, ccw=args.ccw, high_rate=args.high_rate,
                              override=args.override is not None,
                              trigger=args.override or 0)]
    write_output(args.output, render(blocks, args.format))
    return EXIT_OK


def cmd_expand(args: argparse.Namespace) -> int:
    from profiles.ppmc312.init_model import as_free_curve
    from profiles.ppmc312.table import FreeCurveTable, dump_table, load_table

    table = load_table(args.table)
    if isinstance(table, FreeCurveTable):
        raise FormatError(f"{args.table}: already a free curve; expand takes an init table")
    write_output(args.output, dump_table(as_free_curve(table)))
    return EXIT_OK


# --- parser ------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="stepramp", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    c = sub.add_parser("check", help="check table or upload files against the chip's rules")
    c.add_argument("files", nargs="+", metavar="FILE")
    c.add_argument("--format", choices=("text", "json", "junit"), default="text")
    c.add_argument("--motor", metavar="M.json", help="also check stall-safety for this motor")
    c.add_argument("--extck-hz", type=_float, help="external clock frequency for EXTCK uploads")
    c.add_argument("-o", "--output", metavar="OUT", help="write the report here (default stdout)")
    c.set_defaults(func=cmd_check)

    e = sub.add_parser("export", help="encode a table into the bytes the device takes")
    e.add_argument("table", metavar="TABLE")
    e.add_argument("--to", choices=("parallel", "ascii"), default="parallel")
    e.add_argument("--address", type=_positive_int, default=0, help="ASCII slave address 0-15")
    e.add_argument("--format", choices=("hex", "bin", "c", "json", "bus"), default="hex")
    e.add_argument("--max-block-data", type=_positive_int, default=30,
                   help="data bytes per parameter block (3-30, default 30)")
    e.add_argument("--force", action="store_true", help="export even a table with errors")
    e.add_argument("-o", "--output", metavar="OUT")
    e.set_defaults(func=cmd_export)

    d = sub.add_parser("decode", help="decode an upload file (hex or bin) back into a table")
    d.add_argument("upload", metavar="UPLOAD")
    d.add_argument("--extck-hz", type=_float)
    d.add_argument("--table-read", action="store_true",
                   help="the file is the chip's table-read response (41), not an upload")
    d.add_argument("--clock", help="with --table-read: the table's clock (8MHz … 15.625kHz, "
                                   "or EXTCK with --extck-hz)")
    d.add_argument("-o", "--output", metavar="TABLE")
    d.set_defaults(func=cmd_decode)

    m = sub.add_parser("move", help="the accel/decel move command (82) bytes")
    m.add_argument("--pulses", type=_positive_int, required=True, help="1..0xFFFFFFFF")
    m.add_argument("--ccw", action="store_true", help="direction CCW (default CW)")
    m.add_argument("--high-rate", type=_positive_int, default=0,
                   help="high-rate override (0 = the table's)")
    m.add_argument("--override", type=int, choices=(1, 3), metavar="TRG",
                   help="register as an override with trigger TRG (1 or 3), parallel only")
    m.add_argument("--to", choices=("parallel", "ascii"), default="parallel")
    m.add_argument("--address", type=_positive_int, default=0, help="ASCII slave address 0-15")
    m.add_argument("--format", choices=("hex", "bin", "c", "json", "bus"), default="hex")
    m.add_argument("-o", "--output", metavar="OUT")
    m.set_defaults(func=cmd_move)

    x = sub.add_parser("expand", help="the free curve equivalent to an init table (the "
                                      "modelled staircase the chip builds)")
    x.add_argument("table", metavar="TABLE")
    x.add_argument("-o", "--output", metavar="OUT")
    x.set_defaults(func=cmd_expand)

    for register in _EXTRA_COMMANDS:
        register(sub)
    return p


# Sub-commands defined in other modules register themselves here (planning,
# simulation, devices), keeping this file about plumbing.
_EXTRA_COMMANDS: list[Callable[[Any], None]] = []




def main(argv: Sequence[str] | None = None) -> int:
    _load_extra_commands()
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


def _load_extra_commands() -> None:
    if _EXTRA_COMMANDS:
        return
    from verify import cli_devices, cli_motion

    _EXTRA_COMMANDS.extend([cli_motion.register, cli_devices.register])


if __name__ == "__main__":
    sys.exit(main())
