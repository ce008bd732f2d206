"""MC-200 packet stream files: the 12-byte SPI packets in every format stepramp writes.

`FORMATS` is the stream's format table (see `profiles.formats`). Items are the
packets (12 bytes each); the payload is the packets back to back, in order
(exactly the `bin` file, exactly what goes over SPI). Streams run to millions of
packets, so every format renders chunk-wise (`FORMATS.render_chunks`: payload
chunks in, file chunks out, memory one chunk) and the CRC-32 is computed as the
chunks go and written at the end.

| format | file | check |
|---|---|---|
| `hex` | one packet per line, hex byte pairs | last line `# crc32 1C291CA3: CRC-32 …` |
| `bin` | the raw packets | none: no room (it must be exactly the bytes sent) |
| `json` | `{period_us, duration_s, pulses, [mode, unit,] "packets": [...], "crc32"}` | `crc32` |
| `c` | a C header: `NAME_packets[N][12]`, symbols prefixed by `name` | `NAME_CRC32`, comment |
| `ihex` | Intel HEX of the payload from `base_address` | record checksums, EOF record |

The check covers what the packets' own checksum cannot see (bit 7 of bytes 3
and 5: a position off by ±128 or ±8 388 608 pulses). Each packet's checksum is
still verified when the packets are decoded (`decode_stream`).
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import overload

import numpy as np

from ..errors import CorruptedError, DecodeError, FormatError, StepRampError, echo
from ..formats import (
    TEXT_CHUNK_BYTES,
    ChunkRender,
    Format,
    FormatTable,
    Parsed,
    RenderOptions,
    RunningCrc,
    c_comment,
    c_crc,
    c_define,
    c_name,
    c_rows,
    c_values,
    chunked,
    content_lines,
    find_crc_comment,
    first_content_line,
    hex_bytes,
    looks_like_binary,
    looks_like_c,
    looks_like_ihex,
    parse_ihex,
    render_ihex_chunks,
    text_chunks,
    text_of,
    verify_crc,
)
from ..reading import MAX_INPUT_BYTES, STREAM_INPUT_MAX_BYTES, parse_json
from .codec import PACKET_SIZE, checksums, hex_lines

C_NAME_DEFAULT = "stepramp_mc200"
STREAM_FILE_MAX_BYTES = STREAM_INPUT_MAX_BYTES  # (profiles.reading) hex, bin and ihex
JSON_HEADER_KEYS = ("period_us", "duration_s", "pulses", "mode", "unit")


def payload_of(packets: Sequence[bytes]) -> bytes:
    """The packets back to back (each must be 12 bytes)."""
    for i, p in enumerate(packets):
        if not isinstance(p, bytes | bytearray) or len(p) != PACKET_SIZE:
            raise FormatError(f"packet {i}: expected {PACKET_SIZE} bytes, got "
                              f"{len(p) if isinstance(p, bytes | bytearray) else type(p).__name__}")
    if not packets:
        raise FormatError("nothing to render: the stream has no packets")
    return b"".join(bytes(p) for p in packets)


class Packets(Sequence[bytes]):
    """The packets of a parsed stream: a view of the payload (the packets back to back),
    12 bytes an item. Millions of packets cost their payload, not an object each;
    `payload` hands the bytes on whole (`read_stream`, `iter_decode`)."""

    def __init__(self, payload: bytes) -> None:
        self.payload = payload

    def __len__(self) -> int:
        return len(self.payload) // PACKET_SIZE

    @overload
    def __getitem__(self, index: int) -> bytes: ...
    @overload
    def __getitem__(self, index: slice) -> list[bytes]: ...

    def __getitem__(self, index: int | slice) -> bytes | list[bytes]:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        k = range(len(self))[index]  # IndexError past the end, negative from the end
        return self.payload[k * PACKET_SIZE:(k + 1) * PACKET_SIZE]

    def __iter__(self) -> Iterator[bytes]:
        p = self.payload
        return (p[i:i + PACKET_SIZE] for i in range(0, len(p), PACKET_SIZE))

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Packets):
            return self.payload == other.payload
        if isinstance(other, list | tuple):
            return len(other) == len(self) and all(map(bytes.__eq__, self, other))
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]  # compared by content, like a list

    def __repr__(self) -> str:
        return f"Packets({len(self)} packets)"


def payload_of_parsed(parsed: Parsed[bytes]) -> bytes:
    """The packets of a parsed stream file back to back (no copy for `Packets`)."""
    items = parsed.items
    return items.payload if isinstance(items, Packets) else payload_of(items)


def split_packets(payload: bytes) -> Packets:
    """The packets of a payload (a whole number of 12-byte packets)."""
    if len(payload) % PACKET_SIZE:
        whole = len(payload) // PACKET_SIZE
        raise DecodeError(f"{len(payload)} bytes is not a whole number of {PACKET_SIZE}-byte "
                          "packets", block=whole, byte=len(payload) - whole * PACKET_SIZE)
    if not payload:
        raise DecodeError("the stream holds no packets")
    return Packets(bytes(payload))


class _Counted:
    """The payload chunks as they pass, with their CRC-32; refuses a chunk that is not
    whole packets and a stream without any (checked at the end: chunks are lazy)."""

    def __init__(self, chunks: Iterable[bytes]) -> None:
        self.chunks = chunks
        self.crc = RunningCrc()

    def __iter__(self) -> Iterator[bytes]:
        for chunk in self.chunks:
            chunk = bytes(chunk)
            if len(chunk) % PACKET_SIZE:
                raise FormatError(f"a chunk of {len(chunk)} bytes is not whole "
                                  f"{PACKET_SIZE}-byte packets")
            self.crc.update(chunk)
            if chunk:
                yield chunk
        if not self.crc.length:
            raise FormatError("nothing to render: the stream has no packets")

    @property
    def packets(self) -> int:
        return self.crc.length // PACKET_SIZE


# --- hex ----------------------------------------------------------------------------------
def _render_hex(chunks: Iterable[bytes], options: RenderOptions) -> Iterator[bytes]:
    counted = _Counted(chunks)
    for chunk in counted:
        yield hex_lines(chunk).encode("ascii")
    yield ("# " + counted.crc.comment() + "\n").encode("ascii")


def _hex_payload(raw: bytes) -> tuple[bytes, list[str]]:
    """The packets of a hex file (one a line) and its comments, read a chunk of lines at
    a time: a stream of millions of lines holds its payload, not a string per line."""
    out = bytearray()
    comments: list[str] = []
    k = 0  # packets so far
    for first, text in text_chunks(raw):
        lines, notes = content_lines(text, first)
        comments += notes
        # The fast path: 24 hex digits a line, read at once.
        if all(len("".join(content.split())) == 2 * PACKET_SIZE for _, content in lines):
            try:
                out += bytes.fromhex(" ".join(content for _, content in lines))
                k += len(lines)
                continue
            except ValueError:
                pass  # the slow path below names the line and column
        for number, content in lines:
            packet = hex_bytes(content, f"line {number}")
            if len(packet) != PACKET_SIZE:
                raise DecodeError(f"line {number}: {len(packet)} bytes; a line holds one "
                                  f"{PACKET_SIZE}-byte packet", block=k)
            out += packet
            k += 1
    if not out:
        raise DecodeError("the stream file holds no packets (only blanks and comments)")
    return bytes(out), comments


def _parse_hex(raw: bytes) -> Parsed[bytes]:
    payload, comments = _hex_payload(raw)
    integrity, detail = verify_crc(payload, find_crc_comment(comments), "the crc32 comment")
    return Parsed(split_packets(payload), "hex", integrity, detail)


def _looks_like_hex(raw: bytes) -> bool:
    line = first_content_line(raw)
    return bool(line) and ((line[0] == "#" and not line.startswith(("#ifndef", "#include",
                                                                   "#define", "#pragma")))
                           or line[0] in "0123456789abcdefABCDEF")


# --- bin ----------------------------------------------------------------------------------
def _looks_like_bin(raw: bytes) -> bool:
    # Not text, and packets most of whose byte 11 has bit 7 set (the checksum's
    # forced bit 15): a text file with one control character in it is no stream (a
    # flipped bit in a JSON file's brace must not make it one), a bin file with one bad
    # checksum byte still is (that packet is then reported, not the whole file refused).
    if len(raw) < PACKET_SIZE or not looks_like_binary(raw):
        return False
    marked = np.frombuffer(raw, dtype=np.uint8)[PACKET_SIZE - 1::PACKET_SIZE] & 0x80
    return 2 * int(np.count_nonzero(marked)) >= len(marked)


def _render_bin(chunks: Iterable[bytes], options: RenderOptions) -> Iterator[bytes]:
    yield from _Counted(chunks)


def _parse_bin(raw: bytes) -> Parsed[bytes]:
    return Parsed(split_packets(raw), "bin", "none",
                  "the raw packets, with no room for a check: only each packet's own "
                  "checksum, blind to bit 7 of bytes 3 and 5")


# --- JSON ---------------------------------------------------------------------------------
def _render_json(chunks: Iterable[bytes], options: RenderOptions) -> Iterator[bytes]:
    """The text `json.dumps(doc, indent=1)` gives for {header…, "packets": [hex lines],
    "crc32": "…"}, written a chunk at a time."""
    header = {k: v for k, v in options.header.items() if k not in ("packets", "crc32")}
    head = json.dumps(header, indent=1)[:-2] + "," if header else "{"
    yield (head + '\n "packets": [').encode("ascii")
    counted = _Counted(chunks)
    sep = "\n"
    for chunk in counted:
        rows = hex_lines(chunk).splitlines()
        yield (sep + ",\n".join(f'  "{r}"' for r in rows)).encode("ascii")
        sep = ",\n"
    yield f'\n ],\n "crc32": "{counted.crc.hex}"\n}}\n'.encode("ascii")


def _json_packets(raw: bytes) -> tuple[bytes, object]:
    _whole_reader_cap(raw, "json")
    # the one JSON reader: depth, number size and NaN caps (profiles.reading)
    obj = parse_json(raw, "the JSON stream")
    if not isinstance(obj, dict) or "packets" not in obj or not isinstance(obj["packets"], list) \
            or not set(obj) <= {*JSON_HEADER_KEYS, "packets", "crc32"}:
        raise FormatError('a JSON stream is {"period_us": …, "duration_s": …, "pulses": …, '
                          '"packets": ["08 00 …", …], "crc32": "…"}')
    out = bytearray()
    for i, line in enumerate(obj["packets"]):
        if not isinstance(line, str):
            raise FormatError(f"packets[{i}]: expected a hex string, got {echo(line)}")
        packet = hex_bytes(line, f"packets[{i}]")
        if len(packet) != PACKET_SIZE:
            raise DecodeError(f"packets[{i}]: {len(packet)} bytes, a packet is {PACKET_SIZE}",
                              block=i)
        out += packet
    return bytes(out), obj.get("crc32")


def json_header(raw: bytes) -> dict[str, object]:
    """A JSON stream file's header (`JSON_HEADER_KEYS` it holds: period_us, duration_s,
    pulses, mode, unit), e.g. the period `mc200 follow` reads from it."""
    _whole_reader_cap(raw, "json")
    obj = parse_json(raw, "the JSON stream")
    return {k: obj[k] for k in JSON_HEADER_KEYS if k in obj} if isinstance(obj, dict) else {}


def _parse_json(raw: bytes) -> Parsed[bytes]:
    payload, claimed = _json_packets(raw)
    if claimed is not None and (not isinstance(claimed, str)
                                or not re.fullmatch(r"[0-9A-Fa-f]{8}", claimed)):
        raise CorruptedError(f"crc32: {echo(claimed)} is not 8 hex digits")
    integrity, detail = verify_crc(payload, claimed, "the crc32 field")
    return Parsed(split_packets(payload), "json", integrity, detail)


def _looks_like_json(raw: bytes) -> bool:
    return first_content_line(raw).startswith("{")


# --- C ------------------------------------------------------------------------------------
def _render_c(chunks: Iterable[bytes], options: RenderOptions) -> Iterator[bytes]:
    name = c_name(C_NAME_DEFAULT if options.name is None else options.name)
    macro = name.upper()
    prov = options.provenance
    comment = [f"MC-200 packet stream generated by {prov.tool}: send the packets in order, "
               "one per SPI period.",
               *([f"command: {prov.command}"] if prov.command else []), *prov.lines]
    # The stream is written as it is made: its CRC (and its length, unless known ahead:
    # options.count) comes after the array; parse checks NAME_PACKET_COUNT either way.
    count = [f"#define {macro}_PACKET_COUNT {options.count}"] if options.count else []
    size = f"{macro}_PACKET_COUNT" if options.count else ""
    yield "\n".join([c_comment(comment), f"#ifndef {macro}_H", f"#define {macro}_H", "",
                     "#include <stdint.h>", "", *count,
                     f"static const uint8_t {name}_packets[{size}][{PACKET_SIZE}] = {{", ""]
                    ).encode("ascii")
    counted = _Counted(chunks)
    for chunk in counted:
        text = hex_lines(chunk)[:-1]
        yield ("    {0x" + text.replace(" ", ", 0x").replace("\n", "},\n    {0x")
               + "},\n").encode("ascii")
    if options.count and counted.packets != options.count:
        raise FormatError(f"the stream has {counted.packets} packets, {options.count} were "
                          "announced")
    crc = counted.crc
    yield "\n".join([
        "};", "",
        *([] if options.count else [f"#define {macro}_PACKET_COUNT {counted.packets}"]),
        f"#define {macro}_PAYLOAD_BYTES {crc.length}",
        f"#define {macro}_CRC32 0x{crc.hex}UL",
        c_comment([f"payload: {counted.packets} packets, {crc.length} bytes, CRC-32 {crc.hex} "
                   f"(zlib/IEEE 802.3 over the packets back to back; {macro}_CRC32)"]),
        "", f"#endif /* {macro}_H */", ""]).encode("ascii")


_C_ARRAY = re.compile(
    r"\b([A-Za-z][A-Za-z0-9_]*)_packets\s*\[[^\]]*\]\s*\[\s*12\s*\]\s*=\s*\{")


def _parse_c(raw: bytes) -> Parsed[bytes]:
    _whole_reader_cap(raw, "c")
    text = text_of(raw)
    name, rows = c_rows(text, _C_ARRAY, "NAME_packets[N][12] = {{0x.., …}, …}")
    out = bytearray()
    for k, row in enumerate(rows):
        values = c_values(row, f"{name}_packets[{k}]", 0xFF)
        if len(values) != PACKET_SIZE:
            raise DecodeError(f"{name}_packets[{k}]: {len(values)} values, a packet is "
                              f"{PACKET_SIZE} bytes")
        out += bytes(values)
    macro = name.upper()
    count = c_define(text, f"{macro}_PACKET_COUNT")
    if count is not None and int(count) != len(rows):
        raise CorruptedError(f"{macro}_PACKET_COUNT is {count}, the header holds {len(rows)} "
                             "packets")
    integrity, detail = verify_crc(bytes(out), c_crc(text, macro), f"{macro}_CRC32")
    return Parsed(split_packets(bytes(out)), "c", integrity, detail)


# --- Intel HEX ----------------------------------------------------------------------------
def _render_ihex(chunks: Iterable[bytes], options: RenderOptions) -> Iterator[bytes]:
    return render_ihex_chunks(_Counted(chunks), options.base_address)


def _parse_ihex(raw: bytes) -> Parsed[bytes]:
    payload, start = parse_ihex(raw)
    return Parsed(split_packets(payload), "ihex", "verified",
                  f"Intel HEX record checksums verified ({len(payload)} bytes from "
                  f"0x{start:08X})")


# --- the table ------------------------------------------------------------------------------
def _format(name: str, description: str, extensions: tuple[str, ...],
            render_chunks: ChunkRender, parse: Callable[[bytes], Parsed[bytes]],
            sniff: Callable[[bytes], bool], binary: bool = False) -> Format[bytes]:
    return Format(name, description, extensions, chunked(render_chunks, payload_of), parse,
                  sniff, binary, render_chunks)


FORMATS: FormatTable[bytes] = FormatTable("MC-200 stream", [
    _format("bin", "the packets back to back, raw (no check: no room)", (".bin",),
            _render_bin, _parse_bin, _looks_like_bin, binary=True),
    _format("json", 'JSON {"period_us", "duration_s", "pulses", "packets": [...], "crc32"}',
            (".json",), _render_json, _parse_json, _looks_like_json),
    _format("ihex", "Intel HEX of the packets back to back (record checksums)",
            (".ihex", ".ihx", ".i32"), _render_ihex, _parse_ihex, looks_like_ihex),
    _format("c", "C header NAME_packets[N][12] (symbols prefixed by --name, CRC-32 constant)",
            (".h", ".c"), _render_c, _parse_c, looks_like_c),
    _format("hex", "one packet per line, hex byte pairs (CRC-32 comment)", (".hex", ".txt"),
            _render_hex, _parse_hex, _looks_like_hex),
], aliases={"text": "hex"})


def render(packets: Sequence[bytes], fmt: str, options: RenderOptions | None = None) -> bytes:
    """The stream file of `packets` (12 bytes each) in format `fmt`, whole."""
    return FORMATS.render(packets, fmt, options)


def render_chunks(chunks: Iterable[bytes], fmt: str,
                  options: RenderOptions | None = None) -> Iterator[bytes]:
    """The stream file in format `fmt`, a chunk at a time, from chunks of packets
    (e.g. `stream_chunks`): memory is one chunk however long the stream."""
    return FORMATS.render_chunks(chunks, fmt, options)


def parse(data: bytes, path: str | Path | None = None, fmt: str | None = None
          ) -> Parsed[bytes]:
    """The packets of a stream file in any format, told apart by content (`path`'s
    extension breaks ties), with what its check said (`CorruptedError` on a mismatch)."""
    return FORMATS.parse(data, path, fmt)


def _first_lines_end(raw: bytes) -> int:
    cut = raw.find(b"\n", TEXT_CHUNK_BYTES)
    return len(raw) if cut < 0 else cut + 1


def _whole_reader_cap(raw: bytes, fmt: str) -> None:
    """JSON and C are read whole (a JSON parser, C's brace rows): past the 16 MiB every
    input may have, their memory would be many times the file's; long streams are read
    in chunks from hex, bin or ihex."""
    if len(raw) > MAX_INPUT_BYTES:
        raise FormatError(f"a {fmt} stream file of {len(raw)} bytes: {fmt} stream files are "
                          f"read up to {MAX_INPUT_BYTES} bytes (16 MiB); write long streams "
                          "as hex, bin or ihex (read up to 256 MiB)")


def is_stream_file(raw: bytes) -> bool:
    """Whether `raw` holds MC-200 host packets in one of the table's formats, to tell
    the devices' files apart (nothing is verified here). JSON by its "packets" key, C
    by its NAME_packets[…][12] array; hex text, bin and Intel HEX by the packets
    themselves: 12 bytes each (one a line in text), bit 7 of byte 11 set (the
    checksum's forced bit 15), and the reserved bytes 1 and 2 zero or the checksum
    right (a packet damaged in one of the two is still a packet). A PPMC-312 block
    never looks so: a 12-byte parallel block has its length 10 in byte 1, an ASCII
    frame hex digits (and neither sums to an MC-200 checksum but by a 1 in 32768
    chance)."""
    # The first chunk of lines tells a text file (a long stream is read once, by parse).
    head = raw[:_first_lines_end(raw)]
    try:
        fmt = FORMATS.detect(raw).name
        if fmt in ("json", "c") and len(raw) > MAX_INPUT_BYTES:
            # too long to read whole here: parse says why it stops
            text = head.decode("utf-8", "replace")
            return (_C_ARRAY.search(text) is not None if fmt == "c" else
                    '"packets"' in text and '"blocks"' not in text)
        if fmt == "json":
            obj = parse_json(raw, "the file")
            return isinstance(obj, dict) and "packets" in obj and "blocks" not in obj \
                and "format" not in obj
        if fmt == "c":
            return _C_ARRAY.search(text_of(raw)) is not None
        payload = (raw if fmt == "bin" else parse_ihex(head, whole=False)[0] if fmt == "ihex"
                   else _hex_payload(head)[0])
    except StepRampError:
        return False
    if fmt == "ihex" and len(head) < len(raw):  # 16-byte records may cut the last packet
        payload = payload[:len(payload) - len(payload) % PACKET_SIZE]
    if not payload or len(payload) % PACKET_SIZE:
        return False
    rows = np.frombuffer(payload, dtype=np.uint8).reshape(-1, PACKET_SIZE)
    reserved_clear = (rows[:, 1] == 0) & (rows[:, 2] == 0)
    summed = (rows[:, 10] | rows[:, 11].astype(np.int64) << 8) == checksums(rows)
    return bool(np.all(rows[:, 11] & 0x80) and np.all(reserved_clear | summed))


__all__ = ["FORMATS", "STREAM_FILE_MAX_BYTES", "Packets", "is_stream_file", "json_header", "parse",
           "payload_of",
           "payload_of_parsed", "render", "render_chunks", "split_packets"]
