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
           "duration_s / period": "packets (move duration / --period-us)", "din": "--din",
           "torque_constant_nm_per_a": "--torque-constant-nm-per-a"}
MAGIC_NAMES = {"0f0f0f0f": 0x0F0F0F0F, "f0f0f0f0": 0xF0F0F0F0}


def magic(text: str) -> int:
    """A mode-switch magic: one of the sheet's two (0F0F0F0F, F0F0F0F0), 0x optional."""
    from profiles.errors import echo

    key = text.strip().lower().removeprefix("0x")
    if key not in MAGIC_NAMES:
        raise argparse.ArgumentTypeError(
            f"{echo(text)} is not one of the sheet's mode-switch magics: 0F0F0F0F (the "
            "position and current pages) or F0F0F0F0 (the velocity page)")
    return MAGIC_NAMES[key]


def add_subparser(sub: Any) -> None:
    from profiles.mc200.formats import C_NAME_DEFAULT, FORMATS

    mc = sub.add_parser("mc200", help="MC-200 SPI packet streams")
    msub = mc.add_subparsers(dest="mc200_command", required=True, metavar="COMMAND")
    st = msub.add_parser("stream", help="the packets that run a move")
    st.add_argument("--mode", choices=("position", "velocity", "current"), default="position",
                    help="control mode of the commands: position [pulses, int32], velocity "
                         "[pps, float32] or current [A, float32] (default position)")
    st.add_argument("--motor", metavar="M.json",
                    help="stream the PPMC-312's stall-safe planned move for this motor; with "
                         "--mode current, the motor whose inertia, friction and load the "
                         "current drives (the move then ruckig's, if --vmax/--amax/--jmax)")
    st.add_argument("--vmax", type=number, help="ruckig profile: max speed [pps]")
    st.add_argument("--amax", type=number, help="ruckig profile: max acceleration [pps²]")
    st.add_argument("--jmax", type=number, help="ruckig profile: max jerk [pps³]")
    st.add_argument("--torque-constant-nm-per-a", type=number, metavar="KT",
                    help="--mode current: the motor's torque constant [N·m/A], > 0 up to 1000")
    st.add_argument("--pulses", type=positive_int, required=True,
                    help="move length [pulses]")
    st.add_argument("--period-us", type=number, required=True,
                    help="SPI packet period [µs], 15..1000000 (the wiring page asks ≥ 15 µs "
                         "from CS to CLK)")
    st.add_argument("--driver-id", type=positive_int, default=0,
                    help="driver ID 0-15 in every packet (default 0)")
    st.add_argument("--din", type=positive_int, default=0, metavar="BITS",
                    help="DIN3-DIN0 in every packet, 0..15 (0b0101 sets DIN2 and DIN0; their "
                         "meaning is the driver's parameters #304-#307; default 0)")
    st.add_argument("--spi-error-reset", action="store_true",
                    help="open the stream with a packet carrying the SPI-error reset bit (a "
                         "driver left in the SPI error takes commands again)")
    st.add_argument("--magic", type=magic, default=0x0F0F0F0F, metavar="HEX",
                    help="bytes 3-6 of the mode switch: 0F0F0F0F (the position and current "
                         "pages, default) or F0F0F0F0 (the velocity page)")
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
    md.add_argument("--magic", type=magic, metavar="HEX",
                    help="the mode-switch magic the host packets use: 0F0F0F0F or F0F0F0F0 "
                         "(default: what the stream's first mode switch carries)")
    md.set_defaults(func=_do_decode)

    fo = msub.add_parser("follow", help="the following error of a stream against the "
                                        "driver's captured replies")
    fo.add_argument("stream", metavar="STREAM",
                    help="the host packets sent (any format of mc200 stream)")
    fo.add_argument("replies", metavar="REPLIES",
                    help="the driver's replies captured with them, one per packet, in order "
                         "(hex, bin, json, c or ihex)")
    fo.add_argument("--period-us", type=number,
                    help="SPI packet period [µs], 15..1000000 (default: a JSON stream's "
                         "period_us)")
    fo.add_argument("--magic", type=magic, metavar="HEX",
                    help="the stream's mode-switch magic: 0F0F0F0F or F0F0F0F0 (default: "
                         "what its first mode switch carries)")
    fo.add_argument("--format", choices=("text", "json"), default="text",
                    help="report format (default text; times in ms, positions in pulses, "
                         "currents in A)")
    fo.add_argument("--plot", metavar="OUT.png",
                    help="write a figure (PNG or SVG by extension): positions, the following "
                         "error and the current against time")
    fo.set_defaults(func=_do_follow)


def _do_stream(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from profiles import mc200
    from profiles.formats import Provenance
    from profiles.mc200.formats import C_NAME_DEFAULT, FORMATS
    from verify.output import write_output

    with progress_bar("encode packets", unit="packet") as progress:
        with fields_as_options(OPTIONS):  # everything is checked before the first byte
            drive, motor = _drive(args)
            position_at, duration_s = mc200.stream_profile(
                args.pulses, profile=_staircase(motor, args.pulses, args.mode)
                if motor is not None and args.vmax is None else None,
                v_max_pps=args.vmax, a_max_pps2=args.amax, j_max_pps3=args.jmax)
            chunks = mc200.stream_chunks(position_at, duration_s, args.pulses,
                                         period_us=args.period_us, driver_id=args.driver_id,
                                         drive=drive, progress=progress)
        prov = Provenance(command_line(args), _provenance(args, duration_s))
        fmt, options = file_format(args, FORMATS, prov, default="hex",
                                   c_default=C_NAME_DEFAULT)
        # known ahead, so a C header declares its array's size before the rows
        options = replace(options, count=mc200.packet_count(duration_s, args.period_us,
                                                            drive=drive))
        # chunk by chunk: memory stays one chunk however long the move (issue 13)
        write_output(args.output, mc200.render_chunks(
            chunks, fmt, period_us=args.period_us, duration_s=duration_s, pulses=args.pulses,
            options=options, mode=args.mode))
    return EXIT_OK


def _drive(args: argparse.Namespace) -> tuple[Any, Any]:
    """The stream's `Drive` and the motor (if any), the options' combinations checked:
    a profile is --motor's plan or ruckig's limits, all three; --mode current needs
    --motor (the load the current drives) and --torque-constant-nm-per-a."""
    from profiles import mc200
    from profiles.errors import FormatError

    limits = (args.vmax, args.amax, args.jmax)
    current = args.mode == "current"
    if args.motor and any(v is not None for v in limits) and not current:
        raise FormatError("give either --motor or --vmax/--amax/--jmax (both only with "
                          "--mode current: the motor's load, ruckig's move)")
    if any(v is not None for v in limits) and any(v is None for v in limits):
        raise FormatError("give all of --vmax, --amax and --jmax, or none")
    if not args.motor and any(v is None for v in limits):
        raise FormatError("give --motor, or all of --vmax, --amax and --jmax")
    if current and not args.motor:
        raise FormatError("--mode current needs --motor: the inertia, friction and load the "
                          "current drives")
    if current != (args.torque_constant_nm_per_a is not None):
        raise FormatError("--torque-constant-nm-per-a (the motor's, [N·m/A]) goes with --mode "
                          "current, and --mode current needs it" if current else
                          "--torque-constant-nm-per-a turns a torque into a current: only "
                          "with --mode current")
    motor = None
    if args.motor:
        from profiles.motor import load_motor

        motor = load_motor(args.motor)
    model = (mc200.CurrentModel.from_motor(motor, args.torque_constant_nm_per_a)
             if motor is not None and current else None)
    drive = mc200.Drive(args.mode, args.magic, args.din, args.spi_error_reset, model)
    return drive, motor


def _provenance(args: argparse.Namespace, duration_s: float) -> tuple[str, ...]:
    """What the file says of how it was made: the profile, the move, the commands."""
    from profiles.mc200 import UNITS

    if args.motor and args.vmax is None:
        profile = f"profile: the PPMC-312 stall-safe plan for motor {args.motor}"
    else:
        profile = (f"profile: ruckig, vmax {args.vmax:g} pps, amax {args.amax:g} pps2, jmax "
                   f"{args.jmax:g} pps3")
    extra = [f"{n}" for n, on in ((f"DIN {args.din:04b}", args.din),
                                  ("opens with the SPI-error reset", args.spi_error_reset),
                                  (f"mode-switch magic {args.magic:08X}",
                                   args.magic != 0x0F0F0F0F)) if on]
    return (profile, f"move: {args.pulses} pulses in {duration_s:.6g} s, one packet every "
                     f"{args.period_us:g} us to driver {args.driver_id}",
            f"commands: {args.mode} [{UNITS[args.mode]}]"
            + (f", {args.motor} with Kt {args.torque_constant_nm_per_a:g} N.m/A"
               if args.mode == "current" else "") + "".join(f", {e}" for e in extra))


def _staircase(motor: Any, pulses: int, mode: str) -> Any:
    """The PPMC-312's stall-safe planned move for `motor` as a profile the stream follows:
    its exact positions against time for position commands, the staircase integrated
    continuously for velocities and currents (its mean speed over each period; the
    pulse-exact positions would give a period's speed in whole pulses). The MC-200
    stream knows no other device."""
    from profiles.errors import require_int
    from profiles.mc200 import INT32_MAX
    from profiles.ppmc312.execution import simulate_move
    from profiles.ppmc312.planner import plan_free_curve

    with fields_as_options(OPTIONS):  # the stream's own range first (pulses ≤ 2³¹ − 1)
        require_int("pulses", pulses, 1, INT32_MAX)
    run = simulate_move(plan_free_curve(motor, pulses=pulses).table, pulses)
    return (run.position_at if mode == "position" else run.position_linear_at), run.duration_s


def _do_decode(args: argparse.Namespace) -> int:
    import sys

    from profiles import mc200
    from profiles.mc200.formats import STREAM_FILE_MAX_BYTES, parse, payload_of_parsed
    from profiles.reading import read_bytes
    from verify.output import write_output

    # a failed check: CorruptedError, one line "corrupted: …"
    parsed = parse(read_bytes(args.file, limit=STREAM_FILE_MAX_BYTES), args.file)
    with progress_bar("decode packets", unit="packet") as progress:
        payload = payload_of_parsed(parsed)
        magic = mc200.detect_magic(payload) if args.magic is None else args.magic
        lines = mc200.decoded_lines(payload, args.direction, args.format, magic=magic,
                                    progress=progress)
        if parsed.integrity != "verified":  # decoded, but nothing vouches for the bytes
            print(f"stepramp mc200: warning: {args.file}: {parsed.detail}", file=sys.stderr)
        write_output(None, lines)  # a chunk of packets at a time (streams run to millions)
    return EXIT_OK


def _do_follow(args: argparse.Namespace) -> int:
    from profiles.errors import DecodeError, FormatError
    from profiles.mc200.follow import following_error
    from profiles.mc200.formats import (
        STREAM_FILE_MAX_BYTES,
        json_header,
        parse,
        payload_of_parsed,
    )
    from profiles.reading import json_text, read_bytes
    from verify.output import write_outputs

    if args.plot and not args.plot.lower().endswith((".png", ".svg")):
        raise FormatError(f"--plot {args.plot}: the figure format is taken from the "
                          "extension: .png or .svg")
    raw = read_bytes(args.stream, limit=STREAM_FILE_MAX_BYTES)
    stream = parse(raw, args.stream)
    period = args.period_us
    if period is None:
        period = json_header(raw).get("period_us") if stream.format == "json" else None
        if period is None:
            raise FormatError(f"--period-us: {args.stream} ({stream.format}) does not say its "
                              "packet period; give --period-us [µs]")
    replies = parse(read_bytes(args.replies, limit=STREAM_FILE_MAX_BYTES), args.replies)
    try:
        with fields_as_options(OPTIONS):
            following = following_error(payload_of_parsed(stream), payload_of_parsed(replies),
                                        period_us=period, magic=args.magic)
    except DecodeError as e:  # the replies' packets: say which file
        raise DecodeError(f"REPLIES {args.replies}: {e}") from None
    outputs: list[tuple[str | None, Any]] = []
    if args.plot:
        from verify.plot import figure_bytes, following_figure

        outputs.append((args.plot, figure_bytes(following_figure(following), args.plot)))
    text = (json_text(following.to_json()) if args.format == "json"
            else following.describe())
    write_outputs([*outputs, (None, text)])  # the figure and the report, all or none
    return EXIT_OK
