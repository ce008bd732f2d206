"""`stepramp check` for MC-200 stream files: the file's CRC-32 (`mc200-corrupted` /
`mc200-unchecked`), then the driver's reading of the sequence
(`profiles.mc200.model.read_stream`) judged by the device's rules
(`profiles.mc200.rules.stream_findings`: every packet's own check, the servo turns on, no
SPI error, the mode switch, commands that move with the servo off, reversals of a move,
and a stream that ends holding one target)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from profiles.errors import CorruptedError
from profiles.findings import Finding, integrity_findings

from .common import device_result

if TYPE_CHECKING:
    from ..check_options import CheckOptions
    from ..report import FileResult

TITLE = "MC-200 stream"


def check(raw: bytes, path: str, options: CheckOptions) -> FileResult:
    """`stepramp check`'s verdict on one of the device's files: its own check, then the
    device's rules (a file whose own check fails has that one finding: its content
    cannot be trusted for more)."""
    return device_result(path, findings(raw, path), TITLE, options)


def findings(raw: bytes, path: str) -> list[Finding]:
    from profiles.errors import FormatError
    from profiles.mc200.codec import detect_magic, looks_like_replies
    from profiles.mc200.formats import parse, payload_of_parsed
    from profiles.mc200.model import read_stream
    from profiles.mc200.rules import stream_findings

    try:
        parsed = parse(raw, path)
    except CorruptedError as e:  # a verdict on the file, not unusable input
        return [Finding("error", "mc200-corrupted", str(e))]
    out = integrity_findings("mc200", parsed.format, parsed.integrity, parsed.detail)
    payload = payload_of_parsed(parsed)
    if looks_like_replies(payload):  # read by mc200 follow, not run by the driver
        raise FormatError("not judged: MC-200 replies (the driver's answers, byte 9 saying "
                          "the control mode): stepramp mc200 follow STREAM REPLIES reads them")
    # the magic the stream's own first switch carries: one of the sheet's two pages
    return out + stream_findings(read_stream(payload, magic=detect_magic(payload)))
