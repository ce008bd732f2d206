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
| `json` | `{"blocks": [...], "answers": [...], "crc32": "…"}` | the `crc32` field |
| `bus` | the host's register accesses (`profiles.ppmc312.bus`) | `# crc32` comment line |

The answer handshake. The chip answers every block of a table upload (manual
§7-2 「各ブロック書込毎にレスポンスが報告されます」) and keeps ONE unread command answer
(§5-4): a host reads each answer (§5-8) and compares it with the expected one before
it writes the next block, or the chip raises alarm F4 01 and stops. Every format with
room carries those expected answers, header first (`emulator.expected_answers`: a
table upload the chip accepts; moves, table-read captures and ASCII frames have none):
- text: a line `# answer: 03 03 01 00 05` after each block's line;
- json: `"answers"`, hex strings aligned with `"blocks"`;
- c: `NAME_answer_N[]`, `NAME_answers[]`, `NAME_answer_lengths[]`, and §5-8's read
  procedure in the header comment;
- bus: each answer's reads (WAIT CSR.MREF 0, RCR --, RAR XX, DRR XX …) after its block's
  writes, before the next block's;
- bin and ihex: none, no room (they must be exactly the bytes the chip takes).

The CRC-32 covers the blocks only (the answers follow from them): a file's answers
are checked against what the chip model answers to its blocks (`emulator.chip_answers`),
and one that disagrees is `CorruptedError`, as a CRC mismatch is. A file without
answers (written before the handshake, or hand-made) reads as before;
`parse_handshake` gives the answers a file lists (None: none).

Binary parallel blocks self-delimit by their length byte; an ASCII frame
starts with a control byte (bit 7 set) and runs to the next control byte or
the end (its characters and checksum are ASCII hex digits, all below 0x80).
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Sequence
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
from .frames import HDR_CODE_EXEC, block_list

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


# --- the answers a file expects ----------------------------------------------------------
def _answers_for(items: list[bytes]) -> list[bytes] | None:
    from .emulator import expected_answers  # here, so reading the format table stays light

    return expected_answers(items)


def _handshake(parsed: Parsed[bytes], answers: Sequence[bytes | None],
               labels: Sequence[str]) -> tuple[Parsed[bytes], list[bytes] | None]:
    """`parsed` with its expected answers (one per block, None where a block has none, each
    named by `labels` in errors) checked against what the chip model answers to its
    blocks: `CorruptedError` on a difference or a block without one when others have."""
    from .emulator import chip_answers

    blocks = list(parsed.items)
    if all(a is None for a in answers):
        return parsed, None
    if len(answers) != len(blocks):
        raise CorruptedError(f"the file lists {len(answers)} expected answers for "
                             f"{len(blocks)} blocks (one a block)")
    missing = next((k for k, a in enumerate(answers) if a is None), None)
    if missing is not None:
        raise CorruptedError(f"block {missing} has no expected answer, though the file lists "
                             "the other blocks' (one a block)")
    listed = [a for a in answers if a is not None]
    chip = chip_answers(blocks)
    if chip is None:
        note = (f"; its {len(listed)} expected answers are not checked (the chip model "
                "answers table uploads only)")
        return Parsed(blocks, parsed.format, parsed.integrity, parsed.detail + note), listed
    for k, (want, got) in enumerate(zip(listed, chip, strict=True)):
        if want != got:
            raise CorruptedError(f"{labels[k]}: the file expects the answer {hex_line(want)} "
                                 f"to block {k}, the chip answers {hex_line(got)}: the file "
                                 "changed after it was written")
    note = f"; its {len(listed)} expected answers agree with the chip model"
    return Parsed(blocks, parsed.format, parsed.integrity, parsed.detail + note), listed


_Reader = Callable[[bytes], tuple[Parsed[bytes], list[bytes] | None]]


def _blocks_only(reader: _Reader) -> Callable[[bytes], Parsed[bytes]]:
    return lambda raw: reader(raw)[0]


# --- text ---------------------------------------------------------------------------------
ANSWER_COMMENT = "answer:"  # text files: `# answer: 03 03 01 00 05` after each block


def _render_text(blocks: Sequence[bytes], options: RenderOptions) -> bytes:
    items = _blocks(blocks)
    answers = _answers_for(items)
    lines = []
    for k, block in enumerate(items):
        lines.append(hex_line(block))
        if answers is not None:
            lines.append(f"# {ANSWER_COMMENT} {hex_line(answers[k])}")
    lines.append("# " + crc_comment(b"".join(items)))
    return ("\n".join(lines) + "\n").encode("ascii")


def _with_crc_comment(blocks: list[bytes], comments: list[str], fmt: str) -> Parsed[bytes]:
    integrity, detail = verify_crc(b"".join(blocks), find_crc_comment(comments),
                                   "the crc32 comment")
    return Parsed(blocks, fmt, integrity, detail)


def _read_text(raw: bytes) -> tuple[Parsed[bytes], list[bytes] | None]:
    blocks: list[bytes] = []
    answers: list[bytes | None] = []
    labels: list[str] = []
    comments: list[str] = []
    for number, line in enumerate(text_of(raw).splitlines(), start=1):
        content, hashed, comment = line.partition("#")
        if content.strip():
            blocks.append(hex_bytes(content, f"line {number}"))
            answers.append(None)
            labels.append(f"line {number}")
        if not hashed:
            continue
        comments.append(comment)
        head, _, rest = comment.strip().partition(" ")
        if head != ANSWER_COMMENT:
            continue
        where = f"line {number}"
        if not blocks or answers[-1] is not None:
            raise DecodeError(f"{where}: an answer line follows its block's line, one a block")
        answer = hex_bytes(rest.partition("#")[0], where)
        if not answer:
            raise DecodeError(f"{where}: the answer line lists no bytes")
        answers[-1], labels[-1] = answer, where
    if not blocks:
        raise DecodeError("the upload file holds no blocks (only blanks and comments)")
    return _handshake(_with_crc_comment(blocks, comments, "text"), answers, labels)


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
    NAME_blocks, NAME_block_lengths, NAME_BLOCK_COUNT, NAME_PAYLOAD_BYTES, NAME_CRC32 and,
    for a table upload the chip accepts, its expected answers NAME_answer_N, NAME_answers,
    NAME_answer_lengths): a header holds one (`--format c`) or several (one per axis,
    `render_c_set`)."""
    items = _blocks(blocks)
    name = c_name(name)
    macro = name.upper()
    payload = b"".join(items)
    # `static const` so the header can be included from several C files; every name
    # carries the prefix so the uploads of several axes compile together.
    out = [*_c_arrays(name, "block", items), "", f"#define {macro}_BLOCK_COUNT {len(items)}",
           f"#define {macro}_PAYLOAD_BYTES {len(payload)}",
           f"#define {macro}_CRC32 0x{crc_hex(payload)}UL",
           *_c_table(name, "block", items)]
    answers = _answers_for(items)
    if answers is not None:
        out += ["", *_c_arrays(name, "answer", answers), *_c_table(name, "answer", answers)]
    return out


def _c_arrays(name: str, kind: str, rows: Sequence[bytes]) -> list[str]:
    return [f"static const uint8_t {name}_{kind}_{i}[] = {{"
            + ", ".join(f"0x{b:02X}" for b in row) + "};" for i, row in enumerate(rows)]


def _c_table(name: str, kind: str, rows: Sequence[bytes]) -> list[str]:
    """NAME_KINDs[] (pointers) and NAME_KIND_lengths[] of the arrays `_c_arrays` wrote."""
    count = f"{name.upper()}_BLOCK_COUNT"
    return [f"static const uint8_t *const {name}_{kind}s[{count}] = {{"
            + ", ".join(f"{name}_{kind}_{i}" for i in range(len(rows))) + "};",
            f"static const size_t {name}_{kind}_lengths[{count}] = {{"
            + ", ".join(str(len(r)) for r in rows) + "};"]


def _payload_line(blocks: Sequence[bytes], name: str) -> str:
    payload = b"".join(blocks)
    return (f"payload: {len(blocks)} blocks, {len(payload)} bytes, CRC-32 {crc_hex(payload)} "
            f"(zlib/IEEE 802.3 over the blocks back to back; {name.upper()}_CRC32)")


def c_read_procedure(name: str) -> list[str]:
    """The header comment's lines on the answer handshake (manual §5-6, §5-8), for the
    upload prefixed `name` (ASCII: a C comment)."""
    return ["Handshake (manual 5-4, 5-6, 5-8): the chip answers every block and keeps ONE "
            "unread answer.",
            "Write block i: wait CSR.MWEF = 0; WCR <- 0x20; WAR <- 0x20 - its size; DWR <- "
            "its bytes, last byte first.",
            "Then read its answer before writing the next block: wait CSR.MREF = 0; "
            "dummy-read RCR; read RAR;",
            "read 0x40 - RAR bytes from DRR within 3.625 us a byte, lowest parameter first "
            "(the answer's last byte",
            f"first, its header last); compare them with {name}_answers[i] "
            f"({name}_answer_lengths[i] bytes, header first).",
            "A difference stops the upload; an answer left unread when the next block is "
            "written raises alarm F4 01."]


def _render_c(blocks: Sequence[bytes], options: RenderOptions) -> bytes:
    items = _blocks(blocks)
    name = c_name(C_NAME_DEFAULT if options.name is None else options.name)
    prov = options.provenance
    comment = [f"PPMC-312 upload generated by {prov.tool}: write the blocks in order.",
               *([f"command: {prov.command}"] if prov.command else []),
               *prov.lines, _payload_line(items, name),
               *(c_read_procedure(name) if _answers_for(items) is not None else [])]
    return c_header(comment, name, c_symbols(items, name), C_INCLUDES)


def render_c_set(uploads: Sequence[tuple[str, Sequence[bytes], str]],
                 options: RenderOptions) -> bytes:
    """One C header holding several uploads (name, blocks, a comment line), each with its
    own prefix and CRC-32 (`parse_c_set` reads them back, each verified); the include
    guard is `options.name`'s."""
    prov = options.provenance
    body: list[str] = []
    answered = False
    for name, blocks, note in uploads:
        body += [c_comment([note, _payload_line(_blocks(blocks), name)]),
                 *c_symbols(blocks, name), ""]
        answered = answered or _answers_for(_blocks(blocks)) is not None
    comment = [f"PPMC-312 uploads generated by {prov.tool}.",
               *([f"command: {prov.command}"] if prov.command else []), *prov.lines,
               *(c_read_procedure("NAME") if answered else [])]
    return c_header(comment, options.name or C_NAME_DEFAULT, body[:-1], C_INCLUDES)


_C_ARRAY = re.compile(r"\b([A-Za-z][A-Za-z0-9_]*)_block_(\d+)\s*\[\s*\]\s*=\s*\{([^}]*)\}")
_C_ANSWER = re.compile(r"\b([A-Za-z][A-Za-z0-9_]*)_answer_(\d+)\s*\[\s*\]\s*=\s*\{([^}]*)\}")
_C_COUNT = re.compile(r"#define\s+([A-Za-z][A-Za-z0-9_]*)_BLOCK_COUNT\s+(\d+)\b")


def _read_c(raw: bytes) -> tuple[Parsed[bytes], list[bytes] | None]:
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
    against its own CRC-32 and its expected answers against the chip model's
    (`CorruptedError` on a mismatch)."""
    text = text_of(raw)
    return {name: _parse_c_upload(text, name)[0] for name in c_prefixes(text, _C_ARRAY)
            or [""]}


def _parse_c_upload(text: str, name: str) -> tuple[Parsed[bytes], list[bytes] | None]:
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
    answers: dict[int, bytes] = {}
    for prefix, index, body in _C_ANSWER.findall(text):
        if prefix == name:
            where = f"{prefix}_answer_{index}"
            if int(index) in answers:
                raise DecodeError(f"{where} is declared twice")
            answers[int(index)] = bytes(c_values(body, where, 0xFF))
    listed = [answers.get(i) for i in range(max(len(blocks), max(answers, default=-1) + 1))]
    return _handshake(Parsed(blocks, "c", integrity, detail), listed,
                      [f"{name}_answer_{i}" for i in range(len(listed))])


# --- JSON ---------------------------------------------------------------------------------------
def _render_json(blocks: Sequence[bytes], options: RenderOptions) -> bytes:
    items = _blocks(blocks)
    answers = _answers_for(items)
    doc: dict[str, object] = {"blocks": [hex_line(b) for b in items]}
    if answers is not None:
        doc["answers"] = [hex_line(a) for a in answers]
    doc["crc32"] = crc_hex(b"".join(items))
    return (json.dumps(doc, indent=1) + "\n").encode("ascii")


_JSON_KEYS = frozenset(("blocks", "answers", "crc32"))


def _hex_list(obj: dict[str, object], key: str) -> list[bytes]:
    """The byte strings of a JSON list of hex strings (`key`), each non-empty."""
    items = obj[key]
    if not isinstance(items, list):
        raise FormatError(f"{key}: expected a list of hex strings, got {echo(items)}")
    out = []
    for i, line in enumerate(items):
        if not isinstance(line, str):
            raise FormatError(f"{key}[{i}]: expected a hex string, got {echo(line)}")
        data = hex_bytes(line, f"{key}[{i}]")
        if not data:
            raise DecodeError(f"{key}[{i}] is empty", block=i)
        out.append(data)
    return out


def _read_json(raw: bytes) -> tuple[Parsed[bytes], list[bytes] | None]:
    # the one JSON reader: depth, number size and NaN caps (profiles.reading)
    obj = parse_json(raw, "the JSON upload")
    if not isinstance(obj, dict) or "blocks" not in obj or not set(obj) <= _JSON_KEYS \
            or not isinstance(obj["blocks"], list):
        raise FormatError('a JSON upload is {"blocks": ["02 04 01 …", …], "answers": '
                          '["03 03 01 00 05", …], "crc32": "…"}')
    blocks = _hex_list(obj, "blocks")
    if not blocks:
        raise DecodeError("the JSON upload lists no blocks")
    claimed = obj.get("crc32")
    if claimed is not None and (not isinstance(claimed, str)
                                or not re.fullmatch(r"[0-9A-Fa-f]{8}", claimed)):
        raise CorruptedError(f"crc32: {echo(claimed)} is not 8 hex digits")
    integrity, detail = verify_crc(b"".join(blocks), claimed, "the crc32 field")
    answers: list[bytes | None] = list(_hex_list(obj, "answers")) if "answers" in obj else []
    if "answers" in obj and not answers:
        raise CorruptedError("answers: the list is empty (one expected answer a block)")
    return _handshake(Parsed(blocks, "json", integrity, detail), answers,
                      [f"answers[{i}]" for i in range(len(answers))])


def _looks_like_json(raw: bytes) -> bool:
    return first_content_line(raw).startswith("{")


# --- bus accesses -----------------------------------------------------------------------------
def _render_bus(blocks: Sequence[bytes], options: RenderOptions) -> bytes:
    from .bus import bus_script  # here, so reading the format table stays light

    items = _blocks(blocks)
    lines = bus_script(items, _answers_for(items))
    lines.append("# " + crc_comment(b"".join(items)))
    return ("\n".join(lines) + "\n").encode("ascii")


def _read_bus(raw: bytes) -> tuple[Parsed[bytes], list[bytes] | None]:
    """Blocks from register writes (each WCR 20, WAR 20 − size, its bytes to DWR last byte
    first: manual §5-6) and the answers read after them (§5-8), `profiles.ppmc312.bus`'s
    syntax."""
    from .bus import read_bus_script, script_upload

    _lines, comments = content_lines(raw)
    script = script_upload(read_bus_script(raw))
    labels = [f"line {n}" if n is not None else f"block {k}"
              for k, n in enumerate(script.answer_lines)]
    return _handshake(_with_crc_comment(script.blocks, comments, "bus"), script.answers,
                      labels)


_BUS_STARTS = ("WCR", "WAR", "DWR", "WAIT CSR.")


def _looks_like_bus(raw: bytes) -> bool:
    for line in raw[:4096].decode("utf-8", errors="replace").splitlines():
        content = line.partition("#")[0].strip()
        if content:
            return content.startswith(_BUS_STARTS)
    return False


# --- the table ---------------------------------------------------------------------------------
FORMATS: FormatTable[bytes] = FormatTable("PPMC-312 upload", [
    Format("bin", "the blocks back to back, raw (no check, no answers: no room)", (".bin",),
           _render_bin, _parse_bin, _looks_like_bin, binary=True),
    Format("json", 'JSON {"blocks": [...], "answers": [...], "crc32": "…"}', (".json",),
           _render_json, _blocks_only(_read_json), _looks_like_json),
    Format("ihex", "Intel HEX of the blocks back to back (record checksums; no answers: no "
           "room)", (".ihex", ".ihx", ".i32"), _render_ihex, _parse_ihex, looks_like_ihex),
    Format("c", "C header (symbols prefixed by --name, CRC-32 constant, expected answers)",
           (".h", ".c"), _render_c, _blocks_only(_read_c), looks_like_c),
    Format("bus", "host register accesses: each block's writes, then its answer's reads "
           "(CRC-32 comment)", (".bus",), _render_bus, _blocks_only(_read_bus),
           _looks_like_bus),
    Format("text", "one block per line, hex byte pairs, each with its expected answer "
           "(CRC-32 comment)", (".hex", ".txt"), _render_text, _blocks_only(_read_text),
           _looks_like_text),
], aliases={"hex": "text"})

# The reader of every format: the blocks (verified) and the expected answers they list.
_READERS: dict[str, _Reader] = {
    "bin": lambda raw: (_parse_bin(raw), None), "ihex": lambda raw: (_parse_ihex(raw), None),
    "json": _read_json, "c": _read_c, "bus": _read_bus, "text": _read_text}


def render(blocks: Sequence[bytes], fmt: str, options: RenderOptions | None = None) -> bytes:
    """The upload file in format `fmt` (see `FORMATS.names`)."""
    return FORMATS.render(blocks, fmt, options)


def parse(data: bytes, path: str | Path | None = None, fmt: str | None = None
          ) -> Parsed[bytes]:
    """The blocks of an upload file in any format, told apart by content (`path`'s
    extension breaks ties), with what its check said."""
    return FORMATS.parse(data, path, fmt)


def parse_handshake(data: bytes, path: str | Path | None = None, fmt: str | None = None
                    ) -> tuple[Parsed[bytes], list[bytes] | None]:
    """`parse`, and the answers the file expects, one a block, header first (verified
    against the chip model's: `CorruptedError` on a difference); None when it lists none
    (bin and Intel HEX have no room; a file written before the handshake, a move)."""
    if not isinstance(data, bytes | bytearray | memoryview):
        raise FormatError(f"parse needs bytes, got {type(data).__name__}")
    raw = bytes(data)
    if raw.startswith(b"\xef\xbb\xbf"):  # a UTF-8 byte-order mark, as FORMATS.parse drops
        raw = raw[3:]
    if not raw.strip():
        raise DecodeError("empty file")
    chosen = FORMATS.get(fmt) if fmt is not None else FORMATS.detect(raw, path)
    return _READERS[chosen.name](raw)


def parse_upload(data: bytes) -> list[bytes]:
    """The blocks of an upload file (any format); a failed check raises `CorruptedError`."""
    return list(parse(data).items)


def provenance(table: Table | None = None, *, command: str | None = None,
               motor: str | None = None) -> Provenance:
    """The provenance comment lines for an upload of `table` (a planned table's recorded
    provenance among them: what it was planned for, its commands)."""
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
    planned = getattr(table, "provenance", None)
    if planned is not None:  # what plan recorded: the motor, the moves, the commands, …
        lines.append(planned.describe().replace("°", " deg"))  # a C comment is ASCII
    return Provenance(command, tuple(lines))


__all__ = ["ANSWER_COMMENT", "FORMATS", "c_read_procedure", "c_symbols", "c_upload_names",
           "hex_line", "parse", "parse_c_set", "parse_handshake", "parse_upload", "provenance",
           "render", "render_c_set", "split_payload"]
