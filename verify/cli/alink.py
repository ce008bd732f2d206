"""`stepramp alink …`: A-Link ALUM settings, their command words, and responses."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import (
    EXIT_OK,
    add_file_format_options,
    command_line,
    fields_as_options,
    file_format,
    number,
    positive_int,
)

# Settings given by hand are checked field by field: the user typed these options.
EXPLICIT = {"start_pps": "--start-pps", "high_pps": "--high-pps",
            "accel_ms_per_kpps": "--accel-ms-per-kpps", "max_pps": "--max-pps"}
ADDRESSING = {"slave_address": "--address", "axis": "--axis", "pulses": "--pulses"}


def add_subparser(sub: Any) -> None:
    from profiles.alink.formats import C_NAME_DEFAULT, FORMATS

    alink = sub.add_parser("alink", help="A-Link ALUM settings and command words")
    asub = alink.add_subparsers(dest="alink_command", required=True, metavar="COMMAND")
    s = asub.add_parser("settings", help="settings (and their command words) for a move")
    s.add_argument("--motor", metavar="MOTOR", help="plan the fastest stall-safe settings for "
                   "this motor (a motor file or a name from `stepramp motor list`)")
    s.add_argument("--pulses", type=positive_int,
                   help="with --motor: optimise for a move of this many pulses [pulses]")
    s.add_argument("--start-pps", type=number, help="start speed (L_SPEED) [pps]")
    s.add_argument("--high-pps", type=number, help="high speed (H_SPEED) [pps]")
    s.add_argument("--accel-ms-per-kpps", type=number,
                   help="acceleration (UP_TIME) as time per 1000 pps of speed change [ms]")
    s.add_argument("--max-pps", type=number, default=0.0,
                   help="MAX_SPEED [pps] (0 = not set, the default)")
    s.add_argument("--s-curve", action="store_true", help="S-curve ramps (default linear)")
    s.add_argument("--address", type=positive_int,
                   help="slave address: adds each command's memory-map offset")
    s.add_argument("--axis", type=int, choices=(0, 1), default=0,
                   help="axis of the 2-axis unit (default 0)")
    s.add_argument("--duplex", choices=("full", "half"), default="full",
                   help="link duplex, sets the memory map (default full)")
    add_file_format_options(s, FORMATS, default="text", c_default=C_NAME_DEFAULT)
    s.add_argument("-o", "--output", metavar="OUT", help="write the output here (default stdout)")
    s.set_defaults(func=_do_settings)

    r = asub.add_parser("read", help="read a settings file back (any format of alink "
                                     "settings): its settings and commands")
    r.add_argument("file", metavar="FILE",
                   help="a settings file: text, json, hex or c, told apart by content; its "
                        "CRC-32 is verified")
    r.add_argument("--format", choices=("text", "json"), default="text",
                   help="output format (default text)")
    r.set_defaults(func=_do_read)

    d = asub.add_parser("decode", help="decode a status/DATA1/DATA2 triple")
    d.add_argument("words", nargs=3, metavar="WORD", help="16-bit words, hex (0x…) or decimal")
    d.add_argument("--read-back", action="store_true",
                   help="the triple answers a read-back command (its status layout)")
    d.add_argument("--pair", type=int, choices=(0, 1, 2, 3),
                   help="the pair code sent, to check the answer against")
    d.add_argument("--format", choices=("text", "json"), default="text",
                   help="output format (default text)")
    d.set_defaults(func=_do_decode)


def _do_settings(args: argparse.Namespace) -> int:
    from profiles import alink
    from profiles.alink.formats import C_NAME_DEFAULT, FORMATS
    from profiles.errors import FormatError
    from profiles.formats import Provenance
    from verify.output import write_output

    explicit = (args.start_pps, args.high_pps, args.accel_ms_per_kpps)
    if args.motor and any(v is not None for v in explicit):
        raise FormatError("give either --motor or --start-pps/--high-pps/--accel-ms-per-kpps")
    summary: dict[str, Any] = {}
    if args.motor:
        from profiles.motor import load_motor
        from verify.references import exact_optimum

        motor = load_motor(args.motor)
        with fields_as_options({"pulses": "--pulses", "max_pps": "--max-pps"}):
            plan = alink.plan_settings(motor, pulses=args.pulses, max_pps=args.max_pps,
                                       s_curve=args.s_curve)
        settings = plan.table
        # verify judges the plan: its time against the continuous optimum
        ratio = (None if plan.duration_s is None or args.pulses is None
                 else plan.duration_s / exact_optimum(motor, args.pulses).duration_s)
        summary = {"predicted_time_s": plan.duration_s, "shape": plan.extras["shape"],
                   "ratio_to_optimum": ratio,
                   "accel_limit_pps2": plan.extras["accel_limit_pps2"]}
        # No S-curve-vs-linear time beside it: the unit's move-time model does not depend on
        # the ramp shape (profiles.alink.model.move_time_s), so that comparison is equal by
        # construction.
        warnings = list(plan.warnings)
    else:
        if any(v is None for v in explicit):
            raise FormatError("give --motor, or all of --start-pps, --high-pps and "
                              "--accel-ms-per-kpps")
        with fields_as_options(EXPLICIT):
            settings = alink.quantise_settings(args.start_pps, args.high_pps,
                                               args.accel_ms_per_kpps, args.max_pps,
                                               s_curve=args.s_curve)
        warnings = list(settings.warnings)
    with fields_as_options(ADDRESSING):
        commands = alink.settings_commands(settings, slave_address=args.address,
                                           axis=args.axis, duplex=args.duplex)
    fmt, options = file_format(args, FORMATS, Provenance(command_line(args)), default="text",
                               c_default=C_NAME_DEFAULT)
    doc = alink.settings_document(settings, commands, summary=summary, warnings=warnings)
    write_output(args.output, alink.render_settings(doc, fmt, options))
    return EXIT_OK


def _do_read(args: argparse.Namespace) -> int:
    import sys

    from profiles.alink import settings_from_commands
    from profiles.alink.formats import document, parse
    from profiles.errors import StepRampError
    from profiles.reading import json_text, read_bytes
    from verify.output import write_output

    parsed = parse(read_bytes(args.file), args.file)  # a failed check: "corrupted: …"
    if parsed.integrity != "verified":
        print(f"stepramp alink: warning: {args.file}: {parsed.detail}", file=sys.stderr)
    doc = document(parsed.items)
    if args.format == "json":
        write_output(None, json_text(doc))
        return EXIT_OK
    if "multiplier" in doc:
        lines = [f"settings: start {doc['start_pps']} pps, high {doc['high_pps']} pps, "
                 f"MAX_SPEED {doc['max_pps'] or 'not set'}, multiplier ×{doc['multiplier']}, "
                 f"UP_TIME para {doc['up_time_para']} ({doc['accel_ms_per_kpps']:g} ms/kpps = "
                 f"{doc['accel_pps2']:.6g} pps²), {'S-curve' if doc['s_curve'] else 'linear'}"]
    else:
        try:  # why the commands program no settings the unit runs as given
            settings_from_commands(parsed.items)
            why = "?"  # pragma: no cover - document() found none
        except StepRampError as e:
            why = str(e)
        lines = [f"settings: none the unit runs as given ({why}; stepramp check says more)"]
    lines += [f"{c.name:10s} func {c.func:2d} para {c.para:8d}  pair {c.pair}  "
              + " ".join(f"0x{w:04X}" for w in c.words)
              + ("" if c.address is None else f"  at 0x{c.address:03X}")
              for c in parsed.items]
    write_output(None, "\n".join(lines) + "\n")
    return EXIT_OK


def _do_decode(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from profiles import alink
    from profiles.errors import FieldRangeError, FormatError, echo
    from profiles.reading import json_text
    from verify.output import write_output

    words = []
    for i, text in enumerate(args.words):
        try:
            words.append(int(text, 0))
        except ValueError:
            raise FormatError(f"word {i}: {echo(text)} is not an integer (hex 0x… or decimal)"
                              ) from None
    for i, w in enumerate(words):
        if not 0 <= w <= 0xFFFF:
            raise FieldRangeError(f"word {i}", w, 0, 0xFFFF)
    resp = alink.decode_response(*words, expected_pair=args.pair, read_back=args.read_back)
    doc = asdict(resp)
    if args.format == "json":
        write_output(None, json_text(doc))
    else:
        flags = [k for k, v in doc.items() if v is True and k not in ("ack", "valid", "read_back")]
        write_output(None, f"{'Ack' if resp.ack else 'Nak'}, value {resp.value}, pair codes "
                           f"{resp.pair_codes} ({'valid' if resp.valid else resp.mismatch})"
                           + (f", flags: {', '.join(flags)}" if flags else "") + "\n")
    return EXIT_OK
