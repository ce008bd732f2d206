"""PPMC-312 upload files: the blocks (or ASCII frames) in every format stepramp writes.

`FORMATS` is the device's format table (see `profiles.formats`): each format
renders a list of blocks and parses it back. The payload is the blocks back
to back, in order (exactly the `bin` file); its CRC-32 is what the text, JSON,
C and bus files carry, Intel HEX carries its record checksums.

| format | file | check |
|---|---|---|
| `text` (alias `hex`) | one block per line, hex byte pairs | `# crc32 9C3B2A11` comment line |
| `bin` | the raw bytes | none: no room (it must be exactly the bytes the chip takes) |
| `ihex` | Intel HEX of the payload from `base_address` | record checksums, EOF record |
| `c` | a C header, symbols prefixed by `name` | comment and `NAME_CRC32` constant |
| `json` | `{"blocks": [...], "crc32": "9C3B2A11"}` | the `crc32` field |
| `bus` | the host's register writes (WCR, WAR, DWR) | `# crc32` comment line |

Binary parallel blocks self-delimit by their length byte; an ASCII frame
starts with a control byte (bit 7 set) and runs to the next control byte or
the end (its characters and checksum are ASCII hex digits, all below 0x80).
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import CorruptedError, DecodeError, FormatError, echo
from ..formats import (
    Format,
    FormatTable,
    Parsed,
    Provenance,
    RenderOptions,
    c_comment,
    c_crc,
    c_header,
    c_name,
    c_prefixes,
    c_values,
    content_lines,
    crc_comment,
    crc_hex,
    find_crc_comment,
    first_content_line,
    hex_bytes,
    hex_line,
    looks_like_c,
    looks_like_ihex,
    parse_ihex,
    render_ihex,
    text_of,
    verify_crc,
)
from ..reading import parse_json
from .frames import HDR_CODE_EXEC, MAX_BLOCK_BYTES, block_list

if TYPE_CHECKING:
    from .table import Table


def _blocks(blocks: Sequence[bytes]) -> list[bytes]:
    items = block_list(blocks)
    if not items:
        raise FormatError("nothing to render: the upload has no blocks")
    for i, block in enumerate(items):
        if not block:
            raise DecodeError("empty block", block=i, byte=0)
    return items


# --- text ---------------------------------------------------------------------------------
def _render_text(blocks: Sequence[bytes], options: RenderOptions) -> bytes:
    items = _blocks(blocks)
    lines = [hex_line(b) for b in items]
    lines.append("# " + crc_comment(b"".join(items)))
    return ("\n".join(lines) + "\n").encode("ascii")


def _with_crc_comment(blocks: list[bytes], comments: list[str], fmt: str) -> Parsed[bytes]:
    integrity, detail = verify_crc(b"".join(blocks), find_crc_comment(comments),
                                   "the crc32 comment")
    return Parsed(blocks, fmt, integrity, detail)


def _parse_text(raw: bytes) -> Parsed[bytes]:
    lines, comments = content_lines(raw)
    blocks = [hex_bytes(content, f"line {number}") for number, content in lines]
    if not blocks:
        raise DecodeError("the upload file holds no blocks (only blanks and comments)")
    return _with_crc_comment(blocks, comments, "text")


def _looks_like_text(raw: bytes) -> bool:
    line = first_content_line(raw)
    return bool(line) and ((line[0] == "#" and not line.startswith(("#ifndef", "#include",
                                                                   "#define", "#pragma")))
                           or line[0] in "0123456789abcdefABCDEF")


# --- bin --------------------------------------------------------------------------------
def _render_bin(blocks: Sequence[bytes], options: RenderOptions) -> bytes:
    return b"".join(_blocks(blocks))


_ASCII_HEX = frozenset(b"0123456789ABCDEFabcdef")


def split_payload(raw: bytes) -> list[bytes]:
    """The blocks in raw upload bytes (byte offsets in errors are offsets in `raw`)."""
    blocks: list[bytes] = []
    pos = 0
    while pos < len(raw):
        head = raw[pos]
        if head & 0x80:
            end = pos + 1
            while end < len(raw) and not raw[end] & 0x80:
                if raw[end] not in _ASCII_HEX:
                    raise DecodeError(f"block {len(blocks)}: 0x{raw[end]:02X} in an ASCII frame, "
                                      "which carries hex characters only", byte=end)
                end += 1
            blocks.append(raw[pos:end])
        elif head <= HDR_CODE_EXEC:
            if pos + 1 >= len(raw):
                raise DecodeError(f"block {len(blocks)}: a header without a length byte at the "
                                  "end of the file", byte=pos)
            end = pos + 2 + raw[pos + 1]
            if end > len(raw):
                raise DecodeError(f"block {len(blocks)}: length byte 0x{raw[pos + 1]:02X} runs "
                                  f"past the end of the file ({len(raw) - pos - 2} data bytes "
                                  "left)", byte=pos + 1)
            blocks.append(raw[pos:end])
        else:
            raise DecodeError(f"block {len(blocks)}: 0x{head:02X} is neither a parallel block "
                              "header (00–03) nor an ASCII control byte (bit 7 set)", byte=pos)
        pos = end
    if not blocks:
        raise DecodeError("empty upload file")
    return blocks


def _parse_bin(raw: bytes) -> Parsed[bytes]:
    return Parsed(split_payload(raw), "bin", "none",
                  "the raw upload bytes, with no room for a check: corruption cannot be "
                  "detected")


def _looks_like_bin(raw: bytes) -> bool:
    # Parallel blocks start with a header 00–03, ASCII frames with a control byte ≥ 0x80;
    # text never starts with either.
    return bool(raw) and (raw[0] <= HDR_CODE_EXEC or raw[0] >= 0x80)


# --- Intel HEX -----------------------------------------------------------------------------
def _render_ihex(blocks: Sequence[bytes], options: RenderOptions) -> bytes:
    return render_ihex(b"".join(_blocks(blocks)), options.base_address)


def _parse_ihex(raw: bytes) -> Parsed[bytes]:
    payload, start = parse_ihex(raw)
    return Parsed(split_payload(payload), "ihex", "verified",
                  f"Intel HEX record checksums verified ({len(payload)} bytes from "
                  f"0x{start:08X})")


# --- C ----------------------------------------------------------------------------------------
C_NAME_DEFAULT = "stepramp"
C_INCLUDES = ("stdint.h", "stddef.h")


def c_symbols(blocks: Sequence[bytes], name: str) -> list[str]:
    """The C declarations of one upload, every symbol prefixed by `name` (NAME_block_N,
    NAME_blocks, NAME_block_lengths, NAME_BLOCK_COUNT, NAME_PAYLOAD_BYTES, NAME_CRC32):
    a header holds one (`--format c`) or several (one per axis, `render_c_set`)."""
    items = _blocks(blocks)
    name = c_name(name)
    macro = name.upper()
    payload = b"".join(items)
    # `static const` so the header can be included from several C files; every name
    # carries the prefix so the uploads of several axes compile together.
    out = [f"static const uint8_t {name}_block_{i}[] = {{"
           + ", ".join(f"0x{b:02X}" for b in block) + "};" for i, block in enumerate(items)]
    return [*out, "", f"#define {macro}_BLOCK_COUNT {len(items)}",
            f"#define {macro}_PAYLOAD_BYTES {len(payload)}",
            f"#define {macro}_CRC32 0x{crc_hex(payload)}UL",
            f"static const uint8_t *const {name}_blocks[{macro}_BLOCK_COUNT] = {{"
            + ", ".join(f"{name}_block_{i}" for i in range(len(items))) + "};",
            f"static const size_t {name}_block_lengths[{macro}_BLOCK_COUNT] = {{"
            + ", ".join(str(len(b)) for b in items) + "};"]


def _payload_line(blocks: Sequence[bytes], name: str) -> str:
    payload = b"".join(blocks)
    return (f"payload: {len(blocks)} blocks, {len(payload)} bytes, CRC-32 {crc_hex(payload)} "
            f"(zlib/IEEE 802.3 over the blocks back to back; {name.upper()}_CRC32)")


def _render_c(blocks: Sequence[bytes], options: RenderOptions) -> bytes:
    items = _blocks(blocks)
    name = c_name(C_NAME_DEFAULT if options.name is None else options.name)
    prov = options.provenance
    comment = [f"PPMC-312 upload generated by {prov.tool}: write the blocks in order.",
               *([f"command: {prov.command}"] if prov.command else []),
               *prov.lines, _payload_line(items, name)]
    return c_header(comment, name, c_symbols(items, name), C_INCLUDES)


def render_c_set(uploads: Sequence[tuple[str, Sequence[bytes], str]],
                 options: RenderOptions) -> bytes:
    """One C header holding several uploads (name, blocks, a comment line), each with its
    own prefix and CRC-32 (`parse_c_set` reads them back, each verified); the include
    guard is `options.name`'s."""
    prov = options.provenance
    body: list[str] = []
    for name, blocks, note in uploads:
        body += [c_comment([note, _payload_line(_blocks(blocks), name)]),
                 *c_symbols(blocks, name), ""]
    comment = [f"PPMC-312 uploads generated by {prov.tool}.",
               *([f"command: {prov.command}"] if prov.command else []), *prov.lines]
    return c_header(comment, options.name or C_NAME_DEFAULT, body[:-1], C_INCLUDES)


_C_ARRAY = re.compile(r"\b([A-Za-z][A-Za-z0-9_]*)_block_(\d+)\s*\[\s*\]\s*=\s*\{([^}]*)\}")
_C_COUNT = re.compile(r"#define\s+([A-Za-z][A-Za-z0-9_]*)_BLOCK_COUNT\s+(\d+)\b")


def _parse_c(raw: bytes) -> Parsed[bytes]:
    text = text_of(raw)
    names = c_prefixes(text, _C_ARRAY)
    if len(names) > 1:
        raise DecodeError(f"{names[1]}_block_0: one header holds one upload (symbols "
                          f"{names[0]}_…); this one holds {len(names)} "
                          f"({', '.join(names[:4])}{', …' if len(names) > 4 else ''})")
    return _parse_c_upload(text, names[0] if names else "")


def c_upload_names(raw: bytes) -> list[str]:
    """The symbol prefixes of the uploads in a C header (several in `render_c_set`'s, one
    in an upload header's); none for a file that is no C header."""
    return c_prefixes(text_of(raw), _C_ARRAY) if looks_like_c(raw) else []


def parse_c_set(raw: bytes) -> dict[str, Parsed[bytes]]:
    """Every upload of a C header of several (`render_c_set`) by prefix, each verified
    against its own CRC-32 (`CorruptedError` on a mismatch)."""
    text = text_of(raw)
    return {name: _parse_c_upload(text, name) for name in c_prefixes(text, _C_ARRAY)
            or [""]}


def _parse_c_upload(text: str, name: str) -> Parsed[bytes]:
    arrays = [a for a in _C_ARRAY.findall(text) if a[0] == name]
    if not arrays:
        raise DecodeError("a C upload header declares NAME_block_0[] = {0x.., …} arrays (as "
                          "stepramp export --format c writes); none found")
    found: dict[int, bytes] = {}
    for prefix, index, body in arrays:
        where = f"{prefix}_block_{index}"
        values = c_values(body, where, 0xFF)
        if int(index) in found:
            raise DecodeError(f"{where} is declared twice")
        found[int(index)] = bytes(values)
    if sorted(found) != list(range(len(found))):
        missing = min(set(range(len(found) + 1)) - set(found))
        raise CorruptedError(f"{name}_block_{missing} is missing (blocks are numbered from 0)")
    blocks = [found[i] for i in range(len(found))]
    for m in _C_COUNT.finditer(text):
        if m.group(1) == name.upper() and int(m.group(2)) != len(blocks):
            raise CorruptedError(f"{m.group(1)}_BLOCK_COUNT is {m.group(2)}, the header holds "
                                 f"{len(blocks)} blocks")
    claimed = c_crc(text, name.upper())
    integrity, detail = verify_crc(b"".join(blocks), claimed, f"{name.upper()}_CRC32")
    return Parsed(blocks, "c", integrity, detail)


# --- JSON ---------------------------------------------------------------------------------------
def _render_json(blocks: Sequence[bytes], options: RenderOptions) -> bytes:
    items = _blocks(blocks)
    doc = {"blocks": [hex_line(b) for b in items], "crc32": crc_hex(b"".join(items))}
    return (json.dumps(doc, indent=1) + "\n").encode("ascii")


def _parse_json(raw: bytes) -> Parsed[bytes]:
    # the one JSON reader: depth, number size and NaN caps (profiles.reading)
    obj = parse_json(raw, "the JSON upload")
    if not isinstance(obj, dict) or "blocks" not in obj or not set(obj) <= {"blocks", "crc32"} \
            or not isinstance(obj["blocks"], list):
        raise FormatError('a JSON upload is {"blocks": ["02 04 01 …", …], "crc32": "…"}')
    blocks = []
    for i, line in enumerate(obj["blocks"]):
        if not isinstance(line, str):
            raise FormatError(f"blocks[{i}]: expected a hex string, got {echo(line)}")
        block = hex_bytes(line, f"blocks[{i}]")
        if not block:
            raise DecodeError(f"blocks[{i}] is empty", block=i)
        blocks.append(block)
    if not blocks:
        raise DecodeError("the JSON upload lists no blocks")
    claimed = obj.get("crc32")
    if claimed is not None and (not isinstance(claimed, str)
                                or not re.fullmatch(r"[0-9A-Fa-f]{8}", claimed)):
        raise CorruptedError(f"crc32: {echo(claimed)} is not 8 hex digits")
    integrity, detail = verify_crc(b"".join(blocks), claimed, "the crc32 field")
    return Parsed(blocks, "json", integrity, detail)


def _looks_like_json(raw: bytes) -> bool:
    return first_content_line(raw).startswith("{")


# --- bus writes -----------------------------------------------------------------------------
def _render_bus(blocks: Sequence[bytes], options: RenderOptions) -> bytes:
    from .upload import bus_writes  # here, so reading the format table stays light

    items = _blocks(blocks)
    lines = [f"{reg} {value:02X}" for b in items for reg, value in bus_writes(b)]
    lines.append("# " + crc_comment(b"".join(items)))
    return ("\n".join(lines) + "\n").encode("ascii")


def _parse_bus(raw: bytes) -> Parsed[bytes]:
    """Blocks from register writes: each block is WCR 20, WAR 20 − size, then its bytes
    written to DWR last byte first (manual §5-6)."""
    writes: list[tuple[int, str, int]] = []
    lines, comments = content_lines(raw)
    for number, content in lines:
        parts = content.split()
        if len(parts) != 2 or parts[0] not in ("WCR", "WAR", "DWR"):
            raise DecodeError(f"line {number}: expected 'WCR|WAR|DWR XX', got "
                              f"{echo(content.strip())}")
        byte = hex_bytes(parts[1], f"line {number}")
        if len(byte) != 1:
            raise DecodeError(f"line {number}: a register write carries one byte")
        writes.append((number, parts[0], byte[0]))
    blocks = []
    k = 0
    while k < len(writes):
        number, reg, value = writes[k]
        if reg != "WCR" or value != 0x20:
            raise DecodeError(f"line {number}: a block starts with WCR 20, got {reg} {value:02X}")
        if k + 1 >= len(writes) or writes[k + 1][1] != "WAR":
            raise DecodeError(f"line {number}: WCR 20 is followed by WAR (0x20 − block size)")
        size = 0x20 - writes[k + 1][2]
        if not 1 <= size <= MAX_BLOCK_BYTES:
            raise DecodeError(f"line {writes[k + 1][0]}: WAR {writes[k + 1][2]:02X} gives a "
                              f"block of {size} bytes (1..{MAX_BLOCK_BYTES})")
        data = writes[k + 2:k + 2 + size]
        if len(data) != size or any(reg != "DWR" for _, reg, _ in data):
            found = next((i for i, (_, reg, _) in enumerate(data) if reg != "DWR"), len(data))
            raise DecodeError(f"line {number}: WAR says {size} DWR writes follow; found "
                              f"{found}")
        blocks.append(bytes(v for _, _, v in reversed(data)))
        k += 2 + size
    if not blocks:
        raise DecodeError("the bus file holds no register writes")
    return _with_crc_comment(blocks, comments, "bus")


def _looks_like_bus(raw: bytes) -> bool:
    for line in raw[:4096].decode("utf-8", errors="replace").splitlines():
        content = line.partition("#")[0].strip()
        if content:
            return content.startswith(("WCR", "WAR", "DWR"))
    return False


# --- the table ---------------------------------------------------------------------------------
FORMATS: FormatTable[bytes] = FormatTable("PPMC-312 upload", [
    Format("bin", "the blocks back to back, raw (no check: no room)", (".bin",),
           _render_bin, _parse_bin, _looks_like_bin, binary=True),
    Format("json", 'JSON {"blocks": [...], "crc32": "…"}', (".json",),
           _render_json, _parse_json, _looks_like_json),
    Format("ihex", "Intel HEX of the blocks back to back (record checksums)",
           (".ihex", ".ihx", ".i32"), _render_ihex, _parse_ihex, looks_like_ihex),
    Format("c", "C header (symbols prefixed by --name, CRC-32 constant)", (".h", ".c"),
           _render_c, _parse_c, looks_like_c),
    Format("bus", "host register writes WCR/WAR/DWR per block (CRC-32 comment)", (".bus",),
           _render_bus, _parse_bus, _looks_like_bus),
    Format("text", "one block per line, hex byte pairs (CRC-32 comment)",
           (".hex", ".txt"), _render_text, _parse_text, _looks_like_text),
], aliases={"hex": "text"})


def render(blocks: Sequence[bytes], fmt: str, options: RenderOptions | None = None) -> bytes:
    """The upload file in format `fmt` (see `FORMATS.names`)."""
    return FORMATS.render(blocks, fmt, options)


def parse(data: bytes, path: str | Path | None = None, fmt: str | None = None
          ) -> Parsed[bytes]:
    """The blocks of an upload file in any format, told apart by content (`path`'s
    extension breaks ties), with what its check said."""
    return FORMATS.parse(data, path, fmt)


def parse_upload(data: bytes) -> list[bytes]:
    """The blocks of an upload file (any format); a failed check raises `CorruptedError`."""
    return list(parse(data).items)


def provenance(table: Table | None = None, *, command: str | None = None,
               motor: str | None = None) -> Provenance:
    """The provenance comment lines for an upload of `table`."""
    from .table import FreeCurveTable, InitTable

    lines = []
    if motor:
        lines.append(f"motor: {motor}")
    if isinstance(table, FreeCurveTable):
        counts = (f"{len(table.accel_pulses)} stages" if not table.separate else
                  f"{len(table.accel_pulses)} accel / {len(table.decel)} decel stages (LE=1)")
        lines.append(f"table: free curve, clock {table.clock.name}, {counts}, rates "
                     f"{table.rates[0]}..{table.rates[-1]}" if table.rates else
                     f"table: free curve, clock {table.clock.name}, {counts}")
        lines.append(f"totals: accel {table.accel_total} pulses, decel {table.decel_total} "
                     "pulses")
    elif isinstance(table, InitTable):
        stop = "" if table.stop_rate is None else f", stop rate {table.stop_rate}"
        lines.append(f"table: init ({table.shape.replace('_', '-')}), clock "
                     f"{table.clock.name}, start rate {table.start_rate}{stop}, high rate "
                     f"{table.high_rate}")
        decel = "" if table.decel_pulses is None else f", decel {table.decel_pulses}"
        lines.append(f"totals: accel {table.accel_pulses} pulses{decel}")
    return Provenance(command, tuple(lines))


__all__ = ["FORMATS", "c_symbols", "c_upload_names", "hex_line", "parse", "parse_c_set",
           "parse_upload", "provenance", "render", "render_c_set", "split_payload"]
