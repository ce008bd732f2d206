"""`stepramp mc200 …`: MC-200 SPI packet streams."""

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
    progress_bar,
)

OPTIONS = {"v_max_pps": "--vmax", "a_max_pps2": "--amax", "j_max_pps3": "--jmax",
           "pulses": "--pulses", "period_us": "--period-us", "driver_id": "--driver-id",
           "duration_s / period": "packets (move duration / --period-us)"}


def add_subparser(sub: Any) -> None:
    from profiles.mc200.formats import C_NAME_DEFAULT, FORMATS

    mc = sub.add_parser("mc200", help="MC-200 SPI packet streams")
    msub = mc.add_subparsers(dest="mc200_command", required=True, metavar="COMMAND")
    st = msub.add_parser("stream", help="the packets that run a move")
    st.add_argument("--motor", metavar="M.json",
                    help="stream the PPMC-312's stall-safe planned move for this motor")
    st.add_argument("--vmax", type=number, help="ruckig profile: max speed [pps]")
    st.add_argument("--amax", type=number, help="ruckig profile: max acceleration [pps²]")
    st.add_argument("--jmax", type=number, help="ruckig profile: max jerk [pps³]")
    st.add_argument("--pulses", type=positive_int, required=True,
                    help="move length [pulses]")
    st.add_argument("--period-us", type=number, required=True,
                    help="SPI packet period [µs], 10..1000000")
    st.add_argument("--driver-id", type=positive_int, default=0,
                    help="driver ID 0-15 in every packet (default 0)")
    add_file_format_options(st, FORMATS, default="hex", c_default=C_NAME_DEFAULT)
    st.add_argument("-o", "--output", metavar="OUT", help="write the file here (default stdout)")
    st.set_defaults(func=_do_stream)

    md = msub.add_parser("decode", help="decode a packet file (any format of mc200 stream)")
    md.add_argument("file", metavar="FILE",
                    help="a packet file: hex, bin, json, c or ihex, told apart by content; "
                         "its CRC-32 (or Intel HEX checksums) is verified, then every "
                         "packet's checksum")
    md.add_argument("--direction", choices=("host", "driver"), default="host",
                    help="host → driver commands or driver → host replies (default host)")
    md.add_argument("--format", choices=("text", "json"), default="text",
                    help="output format (default text)")
    md.set_defaults(func=_do_decode)


def _do_stream(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from profiles import mc200
    from profiles.errors import FormatError
    from profiles.formats import Provenance
    from profiles.mc200.formats import C_NAME_DEFAULT, FORMATS
    from verify.output import write_output

    limits = (args.vmax, args.amax, args.jmax)
    motor = None
    if args.motor:
        if any(v is not None for v in limits):
            raise FormatError("give either --motor or --vmax/--amax/--jmax")
        from profiles.motor import load_motor

        motor = load_motor(args.motor)
    elif any(v is None for v in limits):
        raise FormatError("give --motor, or all of --vmax, --amax and --jmax")
    profile = (f"profile: the PPMC-312 stall-safe plan for motor {args.motor}" if args.motor
               else f"profile: ruckig, vmax {args.vmax:g} pps, amax {args.amax:g} pps2, jmax "
                    f"{args.jmax:g} pps3")
    with progress_bar("encode packets", unit="packet") as progress:
        with fields_as_options(OPTIONS):  # everything is checked before the first byte
            position_at, duration_s = mc200.stream_profile(
                args.pulses, profile=None if motor is None else _staircase(motor, args.pulses),
                v_max_pps=args.vmax, a_max_pps2=args.amax, j_max_pps3=args.jmax)
            chunks = mc200.stream_chunks(position_at, duration_s, args.pulses,
                                         period_us=args.period_us, driver_id=args.driver_id,
                                         progress=progress)
        prov = Provenance(command_line(args), (
            profile, f"move: {args.pulses} pulses in {duration_s:.6g} s, one packet every "
                     f"{args.period_us:g} us to driver {args.driver_id}"))
        fmt, options = file_format(args, FORMATS, prov, default="hex",
                                   c_default=C_NAME_DEFAULT)
        # known ahead, so a C header declares its array's size before the rows
        options = replace(options, count=mc200.packet_count(duration_s, args.period_us))
        # chunk by chunk: memory stays one chunk however long the move (issue 13)
        write_output(args.output, mc200.render_chunks(chunks, fmt, period_us=args.period_us,
                                                      duration_s=duration_s,
                                                      pulses=args.pulses, options=options))
    return EXIT_OK


def _staircase(motor: Any, pulses: int) -> Any:
    """The PPMC-312's stall-safe planned move for `motor` as a profile the stream follows
    (its exact positions against time): the MC-200 stream knows no other device."""
    from profiles.errors import require_int
    from profiles.mc200 import INT32_MAX
    from profiles.ppmc312.execution import simulate_move
    from profiles.ppmc312.planner import plan_free_curve

    with fields_as_options(OPTIONS):  # the stream's own range first (pulses ≤ 2³¹ − 1)
        require_int("pulses", pulses, 1, INT32_MAX)
    run = simulate_move(plan_free_curve(motor, pulses=pulses).table, pulses)
    return run.position_at, run.duration_s


def _do_decode(args: argparse.Namespace) -> int:
    import sys

    from profiles import mc200
    from profiles.mc200.formats import STREAM_FILE_MAX_BYTES, parse, payload_of_parsed
    from profiles.reading import read_bytes
    from verify.output import write_output

    # a failed check: CorruptedError, one line "corrupted: …"
    parsed = parse(read_bytes(args.file, limit=STREAM_FILE_MAX_BYTES), args.file)
    with progress_bar("decode packets", unit="packet") as progress:
        lines = mc200.decoded_lines(payload_of_parsed(parsed), args.direction, args.format,
                                    progress=progress)
        if parsed.integrity != "verified":  # decoded, but nothing vouches for the bytes
            print(f"stepramp mc200: warning: {args.file}: {parsed.detail}", file=sys.stderr)
        write_output(None, lines)  # a chunk of packets at a time (streams run to millions)
    return EXIT_OK
