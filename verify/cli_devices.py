"""`stepramp alink …` and `stepramp mc200 …`: the A-Link ALUM and MC-200 side of the CLI."""

from __future__ import annotations

import argparse
import json
from typing import Any

from profiles.errors import FormatError


def register(sub: Any) -> None:
    from verify.cli import _float, _positive_int

    alink = sub.add_parser("alink", help="A-Link ALUM settings and command words")
    asub = alink.add_subparsers(dest="alink_command", required=True, metavar="COMMAND")
    s = asub.add_parser("settings", help="settings (and their command words) for a move")
    s.add_argument("--motor", metavar="M.json", help="plan the fastest stall-safe settings")
    s.add_argument("--pulses", type=_positive_int, help="with --motor: optimise for this move")
    s.add_argument("--start-pps", type=_float)
    s.add_argument("--high-pps", type=_float)
    s.add_argument("--accel-ms-per-kpps", type=_float)
    s.add_argument("--max-pps", type=_float, default=0.0, help="MAX_SPEED (0 = not set)")
    s.add_argument("--s-curve", action="store_true")
    s.add_argument("--address", type=_positive_int, help="slave address (memory-map offsets)")
    s.add_argument("--axis", type=int, choices=(0, 1), default=0)
    s.add_argument("--duplex", choices=("full", "half"), default="full")
    s.add_argument("--format", choices=("text", "json", "hex", "c"), default="text")
    s.add_argument("-o", "--output", metavar="OUT")
    s.set_defaults(func=cmd_alink_settings)

    d = asub.add_parser("decode", help="decode a status/DATA1/DATA2 triple")
    d.add_argument("words", nargs=3, metavar="WORD", help="16-bit words, hex (0x…) or decimal")
    d.add_argument("--read-back", action="store_true", help="read-back status layout")
    d.add_argument("--pair", type=int, choices=(0, 1, 2, 3), help="the pair code sent")
    d.add_argument("--format", choices=("text", "json"), default="text")
    d.set_defaults(func=cmd_alink_decode)

    mc = sub.add_parser("mc200", help="MC-200 SPI packet streams")
    msub = mc.add_subparsers(dest="mc200_command", required=True, metavar="COMMAND")
    st = msub.add_parser("stream", help="the packets that run a move")
    st.add_argument("--motor", metavar="M.json", help="stream the stall-safe planned move")
    st.add_argument("--vmax", type=_float, help="ruckig: max speed [pps]")
    st.add_argument("--amax", type=_float, help="ruckig: max acceleration [pps/s]")
    st.add_argument("--jmax", type=_float, help="ruckig: max jerk [pps/s²]")
    st.add_argument("--pulses", type=_positive_int, required=True)
    st.add_argument("--period-us", type=_float, required=True)
    st.add_argument("--driver-id", type=_positive_int, default=0)
    st.add_argument("--format", choices=("hex", "bin", "json"), default="hex")
    st.add_argument("-o", "--output", metavar="OUT")
    st.set_defaults(func=cmd_mc200_stream)

    md = msub.add_parser("decode", help="decode a packet file (hex or bin)")
    md.add_argument("file", metavar="FILE")
    md.add_argument("--direction", choices=("host", "driver"), default="host")
    md.add_argument("--format", choices=("text", "json"), default="text")
    md.set_defaults(func=cmd_mc200_decode)


# --- A-Link -----------------------------------------------------------------------
def cmd_alink_settings(args: argparse.Namespace) -> int:
    from profiles import alink
    from verify.cli import EXIT_OK
    from verify.output import write_output

    explicit = (args.start_pps, args.high_pps, args.accel_ms_per_kpps)
    if args.motor and any(v is not None for v in explicit):
        raise FormatError("give either --motor or --start-pps/--high-pps/--accel-ms-per-kpps")
    summary: dict[str, Any] = {}
    if args.motor:
        from profiles.motor import load_motor

        plan = alink.plan_settings(load_motor(args.motor), pulses=args.pulses,
                                   max_pps=args.max_pps, s_curve=args.s_curve)
        settings = plan.settings
        summary = {"predicted_time_s": plan.predicted_time_s, "shape": plan.shape,
                   "ratio_to_optimum": plan.ratio_to_optimum,
                   "accel_limit_pps2": plan.accel_limit_pps2}
        if args.pulses is not None:
            other = alink.move_time_s(
                alink.AlinkSettings(settings.start_pps, settings.high_pps, settings.accel_para,
                                    settings.max_pps, not settings.s_curve), args.pulses)
            summary["s_curve_time_s" if not settings.s_curve else "linear_time_s"] = \
                other.duration_s
        warnings = list(plan.warnings)
    else:
        if any(v is None for v in explicit):
            raise FormatError("give --motor, or all of --start-pps, --high-pps and "
                              "--accel-ms-per-kpps")
        settings = alink.quantise_settings(args.start_pps, args.high_pps,
                                           args.accel_ms_per_kpps, args.max_pps,
                                           s_curve=args.s_curve)
        warnings = list(settings.warnings)
    commands = alink.settings_commands(settings, slave_address=args.address, axis=args.axis,
                                       duplex=args.duplex)
    doc = {"multiplier": settings.multiplier, "start_pps": settings.start_pps,
           "high_pps": settings.high_pps, "up_time_para": settings.accel_para,
           "accel_ms_per_kpps": settings.accel_ms_per_kpps,
           "accel_pps2": settings.accel_pps2, "max_pps": settings.max_pps,
           "s_curve": settings.s_curve, **summary, "warnings": warnings,
           "commands": [{"name": c.name, "cmd": c.cmd, "func": c.func, "para": c.para,
                         "words": [f"0x{w:04X}" for w in c.words],
                         **({"address": f"0x{c.address:03X}"} if c.address is not None
                            else {})}
                        for c in commands]}
    write_output(args.output, _render_alink(doc, args.format))
    return EXIT_OK


def _render_alink(doc: dict[str, Any], fmt: str) -> str:
    if fmt == "json":
        return json.dumps(doc, indent=1) + "\n"
    if fmt == "hex":
        return "".join(" ".join(w[2:] for w in c["words"]) + "\n" for c in doc["commands"])
    if fmt == "c":
        # The separating comma goes before each row's comment: "}, /* … */," is not C.
        last = len(doc["commands"]) - 1
        rows = "\n".join("    {" + ", ".join(c["words"]) + "}" + ("," if i < last else " ")
                          + f"  /* {c['name']} func {c['func']} para {c['para']} */"
                          for i, c in enumerate(doc["commands"]))
        return ("/* A-Link ALUM settings generated by stepramp: "
                f"start {doc['start_pps']} pps, high {doc['high_pps']} pps, "
                f"×{doc['multiplier']}, UP_TIME para {doc['up_time_para']} */\n"
                "#ifndef STEPRAMP_ALINK_H\n#define STEPRAMP_ALINK_H\n#include <stdint.h>\n\n"
                f"static const uint16_t stepramp_alink_words[{len(doc['commands'])}][3] = {{\n"
                f"{rows}\n}};\n\n#endif\n")
    lines = [f"multiplier ×{doc['multiplier']}: start {doc['start_pps']} pps, high "
             f"{doc['high_pps']} pps, UP_TIME para {doc['up_time_para']} "
             f"({doc['accel_ms_per_kpps']:g} ms/kpps = {doc['accel_pps2']:.6g} pps/s)"]
    for key in ("predicted_time_s", "linear_time_s", "s_curve_time_s", "ratio_to_optimum"):
        if doc.get(key) is not None:
            lines.append(f"{key}: {doc[key]:.6g}")
    lines += [f"warning: {w}" for w in doc["warnings"]]
    lines += [f"{c['name']:10s} func {c['func']:2d} para {c['para']:8d}  "
              + " ".join(c["words"]) for c in doc["commands"]]
    return "\n".join(lines) + "\n"


def cmd_alink_decode(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from profiles import alink
    from verify.cli import EXIT_OK
    from verify.output import write_output

    words = []
    for i, text in enumerate(args.words):
        try:
            words.append(int(text, 0))
        except ValueError:
            raise FormatError(f"word {i}: {text!r} is not an integer (hex 0x… or decimal)"
                              ) from None
    for i, w in enumerate(words):
        if not 0 <= w <= 0xFFFF:
            from profiles.errors import FieldRangeError

            raise FieldRangeError(f"word {i}", w, 0, 0xFFFF)
    resp = alink.decode_response(*words, expected_pair=args.pair, read_back=args.read_back)
    doc = asdict(resp)
    if args.format == "json":
        write_output(None, json.dumps(doc, indent=1) + "\n")
    else:
        flags = [k for k, v in doc.items() if v is True and k not in ("ack", "valid", "read_back")]
        write_output(None, f"{'Ack' if resp.ack else 'Nak'}, value {resp.value}, pair codes "
                           f"{resp.pair_codes} ({'valid' if resp.valid else resp.mismatch})"
                           + (f", flags: {', '.join(flags)}" if flags else "") + "\n")
    return EXIT_OK


# --- MC-200 -----------------------------------------------------------------------
def cmd_mc200_stream(args: argparse.Namespace) -> int:
    from profiles import mc200
    from verify.cli import EXIT_OK
    from verify.output import write_output

    limits = (args.vmax, args.amax, args.jmax)
    position_at: mc200.PositionFn
    if args.motor:
        if any(v is not None for v in limits):
            raise FormatError("give either --motor or --vmax/--amax/--jmax")
        from profiles.motor import load_motor
        from profiles.ppmc312.execution import simulate_move
        from profiles.ppmc312.planner import plan_free_curve

        plan = plan_free_curve(load_motor(args.motor), pulses=args.pulses)
        execution = simulate_move(plan.table, args.pulses)
        position_at, duration_s = execution.position_at, execution.duration_s
    else:
        if any(v is None for v in limits):
            raise FormatError("give --motor, or all of --vmax, --amax and --jmax")
        position_at, duration_s = mc200.ruckig_profile(args.pulses, args.vmax, args.amax,
                                                       args.jmax)
    packets = mc200.stream_move(position_at, duration_s, args.pulses, period_us=args.period_us,
                                driver_id=args.driver_id)
    if args.format == "bin":
        data: str | bytes = mc200.encode_stream(packets)
    elif args.format == "json":
        data = json.dumps({"period_us": args.period_us, "duration_s": duration_s,
                           "pulses": args.pulses,
                           "packets": [p.encode().hex(" ").upper() for p in packets]},
                          indent=1) + "\n"
    else:
        data = mc200.render_hex(packets)
    write_output(args.output, data)
    return EXIT_OK


def cmd_mc200_decode(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from profiles import mc200
    from profiles.reading import read_bytes
    from verify.cli import EXIT_OK
    from verify.output import write_output

    packets = mc200.decode_stream(read_bytes(args.file), args.direction)
    rows = [asdict(p) for p in packets]
    if args.format == "json":
        write_output(None, json.dumps({"direction": args.direction, "packets": rows},
                                      indent=1) + "\n")
    else:
        write_output(None, "".join(
            f"{i:6d}  " + " ".join(f"{k}={v}" for k, v in row.items()) + "\n"
            for i, row in enumerate(rows)))
    return EXIT_OK
