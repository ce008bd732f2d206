"""`stepramp answer HEX…`: decode what a PPMC-312 answers, on the parallel bus or in
ASCII serial mode."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import EXIT_OK

# The commands a serial reply may answer (profiles.ppmc312.replies.REPLY_TO; a test
# holds them equal): listed here so that building the parser imports no codec.
REPLY_TO = ("poll", "command", "position", "end-status", "inputs", "terminals", "status",
            "version", "error-code", "error-count")


def add_subparser(sub: Any) -> None:
    a = sub.add_parser("answer", help="decode PPMC-312 answers (parallel bus, or ASCII serial "
                                      "replies with --serial): every field by name")
    a.add_argument("hex", nargs="*", metavar="HEX",
                   help="the answer's bytes as hex, header first as the manual draws it "
                        "(`23 06 E0 48 00 00 12 34` or \"03 03 01 00 05\"); several answers "
                        "back to back are split by their length bytes")
    a.add_argument("--file", metavar="PATH",
                   help="read the bytes from a capture file instead (hex text, # comments)")
    a.add_argument("--read-order", action="store_true",
                   help="the bytes as the host reads them from DRR (§5-8): each answer lowest "
                        "parameter first and its header last (`78 56 34 12 00 42 06 03`), "
                        "so a logic analyser's capture of the DRR reads is pasted as is")
    a.add_argument("--serial", action="store_true",
                   help="the bytes are ASCII serial replies (control byte 80/90/A0/B0 + "
                        "address, ASCII hex, checksum), each from its control byte")
    a.add_argument("--reply-to", choices=REPLY_TO, metavar="COMMAND",
                   help="with --serial: the command the replies answer (a data reply carries "
                        f"no code): {', '.join(REPLY_TO)}; default: a poll's reading, or the "
                        "one command a reply's length fits")
    a.add_argument("--format", choices=("text", "json"), default="text",
                   help="text (one block per answer: its name, then its fields) or json "
                        "(one object)")
    a.set_defaults(func=_do_answer)


def _do_answer(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.reading import json_text
    from verify.output import write_output

    if args.reply_to is not None and not args.serial:
        raise FormatError("--reply-to is for --serial replies (a parallel answer carries its "
                          "response code)")
    if args.read_order and args.serial:
        raise FormatError("--read-order is for parallel answers read from DRR (a serial "
                          "reply comes on the line in its own order)")
    data = _input_bytes(args)
    if args.serial:
        from profiles.ppmc312.replies import decode_replies

        answers = decode_replies(data, reply_to=args.reply_to)
    elif args.read_order:
        from profiles.ppmc312.answers import decode_read_order

        answers = decode_read_order(data)
    else:
        from profiles.ppmc312.answers import decode_answers

        answers = decode_answers(data)
    if args.format == "json":
        write_output(None, json_text({"answers": [a.to_json() for a in answers]}))
    else:
        write_output(None, "\n".join("\n".join(a.describe()) + "\n" for a in answers))
    return EXIT_OK


def _input_bytes(args: argparse.Namespace) -> bytes:
    from profiles.errors import FormatError
    from profiles.formats import content_lines, hex_bytes

    if args.file is not None and args.hex:
        raise FormatError("give the bytes as HEX or with --file, not both")
    if args.file is None:
        if not args.hex:
            raise FormatError("give the answer's bytes as HEX (e.g. 03 01 00) or --file PATH")
        return hex_bytes(" ".join(args.hex), "HEX")
    from profiles.reading import read_bytes

    lines, _ = content_lines(read_bytes(args.file))
    return b"".join(hex_bytes(text, f"{args.file}, line {number}") for number, text in lines)
