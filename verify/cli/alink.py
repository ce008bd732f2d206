"""`stepramp alink …`: A-Link ALUM settings, any command of §11 and the homing speeds as
command words, and the words read back (answers and commands)."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import (
    EXIT_OK,
    add_cruise_reserve_option,
    add_file_format_options,
    command_line,
    cruise_reserve,
    fields_as_options,
    file_format,
    number,
    planned_for,
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
    add_cruise_reserve_option(s, "with --motor: plan")
    _add_unit_options(s)
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

    _add_command(asub, FORMATS, C_NAME_DEFAULT)
    _add_homing(asub, FORMATS, C_NAME_DEFAULT)
    d = asub.add_parser("decode", help="decode an answer (status/DATA1/DATA2) or, with "
                                       "--command, a command's words")
    d.add_argument("words", nargs=3, metavar="WORD", help="16-bit words, hex (0x…) or decimal")
    d.add_argument("--command", dest="as_command", action="store_true",
                   help="the triple is a command (CMD PARAM1 PARAM2, as `alink command` "
                        "writes it): name it, its nn and value, and what of it §11 does not "
                        "give")
    d.add_argument("--read-back", action="store_true",
                   help="the triple answers a read-back command (its status layout)")
    d.add_argument("--pair", type=int, choices=(0, 1, 2, 3),
                   help="the pair code sent, to check the answer against")
    d.add_argument("--format", choices=("text", "json"), default="text",
                   help="output format (default text)")
    d.set_defaults(func=_do_decode)


def _add_command(asub: Any, formats: Any, c_default: str) -> None:
    from profiles.alink.commands import COMMANDS

    c = asub.add_parser("command", help="the words of any A-Link command of manual §11")
    c.add_argument("command_name", metavar="NAME", choices=tuple(COMMANDS),
                   help="the command, the manual's symbol in lower case with dashes: "
                        + ", ".join(COMMANDS) + " (`stepramp alink command NAME --help` is "
                        "this; each NAME's nn and values are listed under --nn)")
    c.add_argument("--value", type=_integer, metavar="V",
                   help="its para (pulse, speed, time, type, out, a bit word…), decimal or "
                        "0x…; commands that take none (stop, home, read-backs…) refuse it")
    c.add_argument("--nn", type=_integer, metavar="N",
                   help="its nn where the manual gives several (default the first): "
                        + "; ".join(f"{k.name} " + ", ".join(
                            f"{nn} {f.does} [{f.value.shown}]" if f.value.takes else
                            f"{nn} {f.does}" for nn, f in k.forms.items())
                                    for k in COMMANDS.values() if len(k.forms) > 1))
    c.add_argument("--pair", type=int, default=1, metavar="P",
                   help="the pair code, 1..3 (default 1; the next command takes the next)")
    _add_unit_options(c)
    add_file_format_options(c, formats, default="text", c_default=c_default)
    c.add_argument("-o", "--output", metavar="OUT", help="write the file here (default stdout)")
    c.set_defaults(func=_do_command)


def _add_homing(asub: Any, formats: Any, c_default: str) -> None:
    h = asub.add_parser("homing", help="homing speeds (OL_SPEED, OH_SPEED, O_UPTIME) whose "
                                       "every stop is safe for a motor")
    h.add_argument("--motor", metavar="MOTOR", required=True,
                   help="the motor (a motor file or a name from `stepramp motor list`)")
    h.add_argument("--max-pps", type=number, default=0.0,
                   help="the MAX_SPEED the unit holds [pps] (0 = not set, the default): OH "
                        "stays at or below it")
    _add_unit_options(h)
    add_file_format_options(h, formats, default="text", c_default=c_default)
    h.add_argument("-o", "--output", metavar="OUT", help="write the file here (default stdout)")
    h.set_defaults(func=_do_homing)


def _integer(text: str) -> int:
    """An integer, decimal or with a 0x/0o/0b prefix, negative allowed (a pulse)."""
    from profiles.errors import echo

    try:
        return int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{echo(text)} is not an integer (decimal or 0x…)"
                                         ) from None


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
        from profiles.motor.angles import AIM_DEG
        from verify.references import exact_optimum

        reserve = cruise_reserve(args)
        motor = load_motor(args.motor)
        with fields_as_options({"pulses": "--pulses", "max_pps": "--max-pps"}):
            # the high speed is chosen from the motor's top: capped, it keeps the reserve
            plan = alink.plan_settings(reserve.applied(motor), pulses=args.pulses,
                                       max_pps=args.max_pps, s_curve=args.s_curve)
        tight = _tightened(motor, plan.table, args.pulses)
        settings = tight.settings
        predicted, shape = plan.duration_s, plan.extras["shape"]
        if args.pulses is not None and tight.price:
            moved = alink.move_time_s(settings, args.pulses)
            predicted, shape = moved.duration_s, moved.shape
        # verify judges the plan: its time against the continuous optimum
        ratio = (None if predicted is None or args.pulses is None
                 else predicted / exact_optimum(motor, args.pulses).duration_s)
        summary = {"predicted_time_s": predicted, "shape": shape,
                   "ratio_to_optimum": ratio,
                   "accel_limit_pps2": plan.extras["accel_limit_pps2"],
                   # what it was planned for, as a planned table carries it (JSON only)
                   "provenance": planned_for(
                       args.motor, motor, aim_deg=AIM_DEG, reserve=reserve,
                       pulses=None if args.pulses is None else (args.pulses,)).to_json(),
                   "load_angle_tightening": tight.price or None,
                   "worst_load_angle_deg": tight.judgement.worst_deg}
        # No S-curve-vs-linear time beside it: the unit's move-time model does not depend on
        # the ramp shape (profiles.alink.model.move_time_s), so that comparison is equal by
        # construction.
        # a start the tightening lowered makes the planner's note on the start speed stale
        moved = settings.start_pps != plan.table.start_pps
        warnings = [w for w in plan.warnings if not (moved and w.startswith("self-start"))] \
            + ([tight.price] if tight.price else [])
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


def _tightened(motor: Any, settings: Any, pulses: int | None) -> Any:
    """The planned settings tightened until every move, and every decel stop, is within
    the load-angle aim (`profiles.alink.planner.tighten_settings`, judged by
    `verify.safety.judge_safety` on the unit's ramp)."""
    from profiles.alink.planner import tighten_settings
    from profiles.alink.verdict import settings_judge
    from profiles.motor.angles import AIM_DEG

    return tighten_settings(motor, settings, settings_judge(motor, aim_deg=AIM_DEG),
                            aim_deg=AIM_DEG, pulses=pulses)


def _do_read(args: argparse.Namespace) -> int:
    import sys

    from profiles.alink import SETTINGS_CMDS, settings_from_commands
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
    elif others := sorted({c.name for c in parsed.items if c.cmd not in SETTINGS_CMDS}):
        lines = [f"commands: {len(parsed.items)}, a command list ({', '.join(others)}): "
                 "stepramp check says what the unit answers to each"]
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


def _do_command(args: argparse.Namespace) -> int:
    from profiles.alink import command_address, encode_command
    from profiles.alink.formats import C_NAME_DEFAULT, FORMATS, render
    from profiles.formats import Provenance
    from verify.output import write_output

    with fields_as_options(ADDRESSING):
        address = (None if args.address is None
                   else command_address(args.address, args.axis, args.duplex))
    command = encode_command(args.command_name, args.value, args.nn, pair=args.pair,
                             address=address,
                             labels={"value": "--value", "nn": "--nn", "pair": "--pair"})
    fmt, options = file_format(args, FORMATS, Provenance(command_line(args)), default="text",
                               c_default=C_NAME_DEFAULT)
    write_output(args.output, render([command], fmt, options))
    return EXIT_OK


def _do_homing(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from profiles.alink import homing_commands, plan_homing
    from profiles.alink.formats import C_NAME_DEFAULT, FORMATS, render
    from profiles.alink.planner.homing import tighten_homing
    from profiles.alink.safety import homing_judge
    from profiles.formats import Provenance
    from profiles.motor import load_motor
    from profiles.motor.angles import AIM_DEG
    from verify.output import write_output

    motor = load_motor(args.motor)
    with fields_as_options({"max_pps": "--max-pps"}):
        plan = plan_homing(motor, max_pps=args.max_pps)
    h, verdict, price = tighten_homing(motor, plan.table,
                                       homing_judge(motor, aim_deg=AIM_DEG), aim_deg=AIM_DEG)
    with fields_as_options(ADDRESSING):
        commands = homing_commands(h, slave_address=args.address, axis=args.axis,
                                   duplex=args.duplex)
    # the C comment's line stays ASCII: the model is in text and JSON
    fmt, options = file_format(args, FORMATS, Provenance(command_line(args), lines=(
        f"homing: OL {h.ol_pps} pps, OH {h.oh_pps} pps, O_UPTIME para {h.o_uptime_para}; "
        f"bound by {plan.binds}",)), default="text", c_default=C_NAME_DEFAULT)
    header = {"homing": {"ol_pps": h.ol_pps, "oh_pps": h.oh_pps,
                         "o_uptime_para": h.o_uptime_para,
                         "accel_pps2": h.accel_pps2, "binds": plan.binds,
                         "model": plan.extras["model"],
                         "worst_load_angle_deg": verdict.worst_deg,
                         "load_angle": verdict.what},
              "warnings": list(plan.warnings) + ([price] if price else [])}
    write_output(args.output, render(commands, fmt, replace(options, header=header)))
    return EXIT_OK


def _do_decode(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from profiles import alink
    from profiles.errors import FieldRangeError, FormatError, echo
    from profiles.reading import json_text
    from verify.output import write_output

    if args.as_command and (args.read_back or args.pair is not None):
        raise FormatError(f"{'--read-back' if args.read_back else '--pair'}: an answer's; a "
                          "command's words carry their own pair code")
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
    if args.as_command:
        decoded = alink.decode_command(*words)
        write_output(None, json_text(decoded.to_json()) if args.format == "json"
                     else decoded.describe() + "\n")
        return EXIT_OK
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


def _add_unit_options(p: Any) -> None:
    """Where the words go on the unit: its slave address, axis and link duplex."""
    p.add_argument("--address", type=positive_int,
                   help="slave address: adds each command's memory-map offset")
    p.add_argument("--axis", type=int, choices=(0, 1), default=0,
                   help="axis of the 2-axis unit (default 0)")
    p.add_argument("--duplex", choices=("full", "half"), default="full",
                   help="link duplex, sets the memory map (default full)")
