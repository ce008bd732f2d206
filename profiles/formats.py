"""File formats: one `Format` record per format, one `FormatTable` per device.

Learned from cantools (`database/can/formats/`: one module per format, each with
load and dump, dispatched from one table): a device module lists its formats in
a `FormatTable`; each `Format` has a `render` (items → file bytes) and a `parse`
(file bytes → items), so every file stepramp writes can be read back and
checked. `FormatTable.detect` tells the formats apart by content (the file
name's extension only breaks ties).

Integrity. The device protocols carry little or no check (the PPMC-312
parallel upload none at all), so the files carry one the wire lacks:
a CRC-32 of the payload in the text formats (a comment line), JSON (a field)
and C (a comment and a constant), Intel HEX its record checksums. `parse`
verifies it and raises `CorruptedError` on a mismatch; a file without one
(hand-made) parses with `Parsed.integrity == "absent"`, for a warning. Raw
binary has no room for a check (it must be exactly the bytes the device
takes): `integrity == "none"`.

The helpers below (CRC-32, hex text, Intel HEX, C identifiers, provenance) are
shared by the device tables.

Streams. A format may also render chunk-wise (`Format.render_chunks`: the
payload's bytes in chunks → the file's bytes in chunks), for files of millions
of items (an MC-200 stream) whose memory must not grow with their length; its
CRC-32 is then computed as the chunks go (`RunningCrc`) and written at the end.
`render` of such a format is its `render_chunks` of the whole payload (`chunked`),
so the two can never disagree.
"""

from __future__ import annotations

import re
import zlib
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Generic, Literal, TypeVar

from .errors import CorruptedError, DecodeError, FieldRangeError, FormatError, echo

T = TypeVar("T")

# verified: the file's check matched; absent: the format has a check but this
# file carries none (hand-made); none: the format has no room for one (bin).
Integrity = Literal["verified", "absent", "none"]


@dataclass(frozen=True)
class Provenance:
    """Where a file came from, for the comment a C header (and text files) carry."""

    command: str | None = None            # the command line that wrote it
    lines: tuple[str, ...] = ()           # device-specific: motor, clock, stages, totals

    @property
    def tool(self) -> str:
        return f"stepramp {tool_version()}"


@dataclass(frozen=True)
class RenderOptions:
    name: str | None = None               # C: prefix of the include guard and every symbol
    base_address: int = 0                 # Intel HEX: address of the first byte
    provenance: Provenance = field(default_factory=Provenance)
    # device fields a format writes ahead of the items: the JSON document's other keys
    # (e.g. an MC-200 stream's period_us), a settings file's summary lines
    header: Mapping[str, Any] = field(default_factory=dict)
    # items a chunk-wise render will be given, when known ahead (a C header can then
    # declare its array's size before the rows); None: unknown
    count: int | None = None


@dataclass(frozen=True)
class Parsed(Generic[T]):
    items: Sequence[T]
    format: str
    integrity: Integrity
    detail: str = ""                      # what was verified, or why nothing was


@dataclass(frozen=True)
class Format(Generic[T]):
    name: str
    description: str
    extensions: tuple[str, ...]
    render: Callable[[Sequence[T], RenderOptions], bytes]
    parse: Callable[[bytes], Parsed[T]]
    sniff: Callable[[bytes], bool]         # does this content look like the format?
    binary: bool = False
    # payload chunks → file chunks, for formats that stream (memory: one chunk)
    render_chunks: ChunkRender | None = None


ChunkRender = Callable[[Iterable[bytes], RenderOptions], Iterator[bytes]]


def chunked(render_chunks: ChunkRender, payload: Callable[[Sequence[T]], bytes]
            ) -> Callable[[Sequence[T], RenderOptions], bytes]:
    """The whole-list `render` of a streaming format: its `render_chunks` of the one
    chunk `payload(items)` (one renderer, so a streamed file equals a whole one)."""
    def render(items: Sequence[T], options: RenderOptions) -> bytes:
        data = payload(items)
        if options.count is None:
            options = replace(options, count=len(items))
        return b"".join(render_chunks([data], options))

    return render


class FormatTable(Generic[T]):
    """A device's formats, in detection order, with aliases (old names kept working)."""

    def __init__(self, device: str, formats: Sequence[Format[T]],
                 aliases: dict[str, str] | None = None) -> None:
        self.device = device
        self.formats = {f.name: f for f in formats}
        self.aliases = dict(aliases or {})

    @property
    def names(self) -> tuple[str, ...]:
        """Every accepted `--format` value, aliases included."""
        return (*self.formats, *self.aliases)

    def get(self, name: str) -> Format[T]:
        key = self.aliases.get(name, name)
        if key not in self.formats:
            raise FormatError(f"format: {echo(name)} is not one of {', '.join(self.names)}")
        return self.formats[key]

    def for_path(self, path: str | Path | None) -> Format[T] | None:
        """The format a file name's extension names, if it names one."""
        if path is None:
            return None
        suffix = Path(str(path)).suffix.lower()
        for f in self.formats.values():
            if suffix in f.extensions:
                return f
        return None

    def detect(self, data: bytes, path: str | Path | None = None) -> Format[T]:
        """The format of `data`: by content; the extension breaks a tie."""
        matches = [f for f in self.formats.values() if f.sniff(data)]
        if not matches:
            # "an" before a letter read with a vowel sound: A-Link, MC-200 ("em")
            article = "an" if self.device[:1] in "AEFHILMNORSX" else "a"
            raise DecodeError(f"not {article} {self.device} file in any known format "
                              f"({', '.join(self.formats)})")
        by_name = self.for_path(path)
        return by_name if by_name in matches else matches[0]

    def render(self, items: Sequence[T], fmt: str,
               options: RenderOptions | None = None) -> bytes:
        return self.get(fmt).render(items, options or RenderOptions())

    def render_chunks(self, chunks: Iterable[bytes], fmt: str,
                      options: RenderOptions | None = None) -> Iterator[bytes]:
        """The file in format `fmt`, chunk by chunk, from the payload's chunks."""
        chosen = self.get(fmt)
        if chosen.render_chunks is None:
            raise FormatError(f"format: {chosen.name} cannot be written chunk by chunk")
        return chosen.render_chunks(chunks, options or RenderOptions())

    def parse(self, data: bytes, path: str | Path | None = None,
              fmt: str | None = None) -> Parsed[T]:
        if not isinstance(data, bytes | bytearray | memoryview):
            raise FormatError(f"parse needs bytes, got {type(data).__name__}")
        raw = bytes(data)
        if raw.startswith(b"\xef\xbb\xbf"):  # a UTF-8 byte-order mark from a text editor
            raw = raw[3:]
        if not raw.strip():
            raise DecodeError("empty file")
        chosen = self.get(fmt) if fmt is not None else self.detect(raw, path)
        return chosen.parse(raw)


def tool_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("stepramp")
    except PackageNotFoundError:  # pragma: no cover - running from a bare checkout
        return "unknown (not installed: pip install -e .)"


# --- CRC-32 -------------------------------------------------------------------------
def crc32(payload: bytes) -> int:
    """CRC-32 as zlib, PNG and Ethernet compute it (polynomial 0x04C11DB7, reflected,
    initial and final XOR 0xFFFFFFFF): 0xCBF43926 for b"123456789"."""
    return zlib.crc32(payload) & 0xFFFFFFFF


def crc_hex(payload: bytes) -> str:
    return f"{crc32(payload):08X}"


_CRC_COMMENT = re.compile(r"\bcrc32\s+(?:0x)?([0-9A-Fa-f]{8})\b")


def crc_comment(payload: bytes) -> str:
    """The text formats' check line (after `#`)."""
    crc = RunningCrc()
    crc.update(payload)
    return crc.comment()


class RunningCrc:
    """CRC-32 (as `crc32`) and length of a payload fed in chunks (zlib's running value)."""

    def __init__(self) -> None:
        self.value = 0
        self.length = 0

    def update(self, chunk: bytes) -> None:
        self.value = zlib.crc32(chunk, self.value)
        self.length += len(chunk)

    @property
    def hex(self) -> str:
        return f"{self.value & 0xFFFFFFFF:08X}"

    def comment(self) -> str:
        """The text formats' check line (after `#`)."""
        return f"crc32 {self.hex}: CRC-32 of the {self.length} bytes above"


def find_crc_comment(comments: Sequence[str]) -> str | None:
    """The CRC given in a comment line, if any (the last one wins)."""
    found = None
    for text in comments:
        m = _CRC_COMMENT.search(text)
        if m:
            found = m.group(1).upper()
    return found


def verify_crc(payload: bytes, claimed: str | None, where: str) -> tuple[Integrity, str]:
    """Compare a file's CRC with its payload: `CorruptedError` on a mismatch."""
    if claimed is None:
        return "absent", "no CRC-32 in the file (hand-made?): its bytes cannot be verified"
    actual = crc_hex(payload)
    if claimed.upper() != actual:
        raise CorruptedError(f"{where} says CRC-32 {claimed.upper()}, the content gives "
                             f"{actual}: the file changed after it was written")
    return "verified", f"CRC-32 {actual} of {len(payload)} bytes verified"


# --- hex text -------------------------------------------------------------------------
_HEX_DIGITS = frozenset("0123456789abcdefABCDEF")


def hex_line(data: bytes) -> str:
    return data.hex(" ").upper()


def hex_bytes(content: str, where: str) -> bytes:
    """Bytes from hex digit pairs, spaces allowed between pairs; errors name the column."""
    out = bytearray()
    column = 0
    for token in content.split():
        column = content.index(token, column)
        for k, ch in enumerate(token):
            if ch not in _HEX_DIGITS:
                raise DecodeError(f"{where}, column {column + k + 1}: {echo(ch)} is not a hex "
                                  "digit")
        if len(token) % 2:
            raise DecodeError(f"{where}, column {column + 1}: {echo(token)} has an odd number of "
                              "hex digits (two a byte)")
        out += bytes.fromhex(token)
        column += len(token)
    return bytes(out)


def text_of(raw: bytes) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise DecodeError(f"neither text nor a binary file (byte 0x{raw[e.start]:02X})",
                          byte=e.start) from None


def content_lines(raw: bytes | str, first: int = 1) -> tuple[list[tuple[int, str]], list[str]]:
    """(line number, content) of every line of a text file with content, and the text
    of its `#` comments; `first` numbers the first line (for `text_chunks`)."""
    lines, comments = [], []
    text = raw if isinstance(raw, str) else text_of(raw)
    for number, line in enumerate(text.splitlines(), start=first):
        content, _, comment = line.partition("#")
        if comment:
            comments.append(comment)
        if content.strip():
            lines.append((number, content))
    return lines, comments


TEXT_CHUNK_BYTES = 1 << 20


def text_chunks(raw: bytes, size: int = TEXT_CHUNK_BYTES) -> Iterator[tuple[int, str]]:
    """The text of `raw` in whole lines, about `size` bytes at a time, each chunk with the
    number of its first line: a reader of a long text file (an MC-200 stream of millions
    of lines) holds one chunk's lines, not the file's. Chunks end after a newline, so a
    character is never cut; line numbers count newlines (a file whose lines end in a
    lone CR is one chunk)."""
    pos, number = 0, 1
    while pos < len(raw):
        cut = raw.find(b"\n", min(pos + size, len(raw)) - 1)
        end = len(raw) if cut < 0 else cut + 1
        chunk = raw[pos:end]
        try:
            text = chunk.decode("utf-8")
        except UnicodeDecodeError as e:
            raise DecodeError(f"neither text nor a binary file (byte 0x{chunk[e.start]:02X})",
                              byte=pos + e.start) from None
        yield number, text
        number += chunk.count(b"\n")
        pos = end


def _text_lines(raw: bytes) -> Iterator[tuple[int, str]]:
    """The numbered lines of a text file, a chunk at a time (memory: one chunk)."""
    for first, text in text_chunks(raw):
        yield from enumerate(text.splitlines(), start=first)


_CONTROL = re.compile(rb"[\x00-\x08\x0e-\x1f\x7f]")


def looks_like_binary(raw: bytes) -> bool:
    """Not a text file: a control character other than white space, or not UTF-8."""
    if _CONTROL.search(raw):
        return True
    try:
        raw.decode("utf-8")
    except UnicodeDecodeError:
        return True
    return False


def first_content_line(raw: bytes) -> str:
    """The first non-blank line of a text file, stripped ('' for binary or empty)."""
    try:
        text = raw[:4096].decode("utf-8", errors="strict")
    except UnicodeDecodeError as e:
        text = raw[:e.start].decode("utf-8")
        if not text.strip():
            return ""
    for line in text.splitlines():
        if line.strip():
            return line.strip()
    return ""


# --- Intel HEX ------------------------------------------------------------------------
IHEX_RECORD_BYTES = 16
IHEX_ADDRESS_MAX = 0xFFFFFFFF


def _ihex_record(kind: int, address: int, data: bytes) -> str:
    body = bytes([len(data), address >> 8 & 0xFF, address & 0xFF, kind]) + data
    return ":" + body.hex().upper() + f"{-sum(body) & 0xFF:02X}"


def render_ihex(payload: bytes, base_address: int) -> bytes:
    """Intel HEX (I32HEX): 16-byte data records from `base_address`, an extended linear
    address record (04) wherever the upper 16 address bits change, the EOF record."""
    if isinstance(base_address, bool) or not isinstance(base_address, int) or not (
            0 <= base_address <= IHEX_ADDRESS_MAX - max(len(payload) - 1, 0)):
        raise FieldRangeError("base address", base_address, 0,
                              IHEX_ADDRESS_MAX - max(len(payload) - 1, 0))
    return b"".join(render_ihex_chunks([payload], base_address))


def render_ihex_chunks(chunks: Iterable[bytes], base_address: int) -> Iterator[bytes]:
    """`render_ihex` of a payload given in chunks, the records of each chunk as they
    are complete (a record is cut where the whole payload's would be, never at a
    chunk's edge). A payload running past address 0xFFFFFFFF raises FieldRangeError
    when it gets there."""
    if isinstance(base_address, bool) or not isinstance(base_address, int) or not (
            0 <= base_address <= IHEX_ADDRESS_MAX):
        raise FieldRangeError("base address", base_address, 0, IHEX_ADDRESS_MAX)
    upper: int | None = None
    address = base_address
    data = b""

    def records(final: bool) -> Iterator[str]:
        nonlocal upper, address, data
        pos = 0
        while pos < len(data):
            # A record never crosses a 64 KiB boundary (its address is 16 bits).
            full = min(IHEX_RECORD_BYTES, 0x10000 - (address & 0xFFFF))
            n = min(full, len(data) - pos)
            if n < full and not final:
                break  # wait for the next chunk: the whole payload's record is longer
            if address + n - 1 > IHEX_ADDRESS_MAX:
                raise FieldRangeError("base address", base_address, 0, max(
                    0, IHEX_ADDRESS_MAX - (address - base_address + n) + 1))
            if address >> 16 != upper:
                upper = address >> 16
                yield _ihex_record(0x04, 0, upper.to_bytes(2, "big"))
            yield _ihex_record(0x00, address & 0xFFFF, data[pos:pos + n])
            pos += n
            address += n
        data = data[pos:]

    for chunk in chunks:
        data += bytes(chunk)
        lines = list(records(final=False))
        if lines:
            yield ("\n".join(lines) + "\n").encode("ascii")
    lines = [*records(final=True), _ihex_record(0x01, 0, b"")]
    yield ("\n".join(lines) + "\n").encode("ascii")


def parse_ihex(raw: bytes, *, whole: bool = True) -> tuple[bytes, int]:
    """The contiguous payload of an Intel HEX file and its start address. Every
    record's checksum is verified (`CorruptedError`); the data must be one run
    without gaps or overlaps, ended by the EOF record (`whole=False`: `raw` is the
    file's first lines, to tell what it holds, and need not be ended)."""
    base = 0
    start: int | None = None
    payload = bytearray()
    ended = False
    for number, line in _text_lines(raw):
        line = line.strip()
        if not line:
            continue
        where = f"line {number}"
        if ended:
            raise DecodeError(f"{where}: data after the end-of-file record")
        if not line.startswith(":"):
            raise DecodeError(f"{where}: an Intel HEX record starts with ':'")
        body = hex_bytes(line[1:], where)
        if len(body) < 5 or len(body) != 5 + body[0]:
            raise CorruptedError(f"{where}: the record is {len(body)} bytes, its length byte "
                                 f"says {5 + body[0] if body else 5}")
        if sum(body) & 0xFF:
            want = -sum(body[:-1]) & 0xFF
            raise CorruptedError(f"{where}: record checksum {body[-1]:02X}, the record gives "
                                 f"{want:02X}")
        kind, address, data = body[3], int.from_bytes(body[1:3], "big"), body[4:-1]
        if kind == 0x00:
            full = base + address
            if start is None:
                start = full
            elif full != start + len(payload):
                raise DecodeError(f"{where}: data at 0x{full:08X}, expected 0x"
                                  f"{start + len(payload):08X} (the upload is one run of "
                                  "bytes, without gaps)")
            payload += data
        elif kind == 0x01:
            ended = True
        elif kind in (0x02, 0x04):  # extended segment (× 16) / linear (× 65536) address
            if len(data) != 2:
                raise DecodeError(f"{where}: an extended address record carries 2 bytes")
            base = int.from_bytes(data, "big") << (4 if kind == 0x02 else 16)
        elif kind in (0x03, 0x05):
            pass  # start addresses: nothing to upload
        else:
            raise DecodeError(f"{where}: record type {kind:02X} is not Intel HEX (00-05)")
    if whole and not ended:
        raise CorruptedError("no end-of-file record (:00000001FF): the file is truncated")
    if start is None:
        raise DecodeError("the Intel HEX file holds no data records")
    return bytes(payload), start


def looks_like_ihex(raw: bytes) -> bool:
    return first_content_line(raw).startswith(":")


# --- C ----------------------------------------------------------------------------------
_C_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
C_NAME_MAX = 40  # + "_block_lengths" stays within C99's 63 significant characters
C_KEYWORDS = frozenset("""auto break case char const continue default do double else enum
extern float for goto if inline int long register restrict return short signed sizeof static
struct switch typedef union unsigned void volatile while _Bool _Complex _Imaginary""".split())


def c_name(name: str, what: str = "--name") -> str:
    """`name` if it can prefix C symbols: a letter, then letters, digits, underscores;
    `what` names where it came from in the error."""
    if not isinstance(name, str) or not _C_IDENTIFIER.match(name) or name in C_KEYWORDS \
            or len(name) > C_NAME_MAX:
        raise FormatError(f"{what} {echo(name)}: a C prefix is a letter followed by letters, "
                          f"digits or underscores, at most {C_NAME_MAX} characters, not a C "
                          "keyword (e.g. x_axis)")
    return name


def c_header(comment: Sequence[str], name: str, body: Sequence[str],
             includes: Sequence[str] = ("stdint.h",)) -> bytes:
    """A whole C header: the comment, the include guard NAME_H, the includes, `body`."""
    macro = c_name(name).upper()
    return "\n".join([c_comment(comment), f"#ifndef {macro}_H", f"#define {macro}_H", "",
                      *(f"#include <{h}>" for h in includes), "", *body,
                      "", f"#endif /* {macro}_H */", ""]).encode("ascii")


def c_prefixes(text: str, array: re.Pattern[str]) -> list[str]:
    """The distinct symbol prefixes (`array`'s group 1) of a header, in order."""
    return list(dict.fromkeys(m.group(1) for m in array.finditer(text)))


def c_name_for(path: str | Path | None, default: str = "stepramp") -> str:
    """A C prefix from an output file name (`x-axis.upload.h` → `x_axis_upload`)."""
    if path is None:
        return default
    stem = Path(str(path)).name.split(".")[0]
    name = re.sub(r"[^A-Za-z0-9_]", "_", stem).strip("_")[:C_NAME_MAX]
    if not name or not name[0].isalpha() or name in C_KEYWORDS:
        return default
    return name


def c_comment(lines: Sequence[str]) -> str:
    """A C block comment holding `lines` (made ASCII, never closing early)."""
    safe = [line.encode("ascii", "backslashreplace").decode("ascii").replace("*/", "* /")
            for line in lines]
    return "/* " + "\n * ".join(safe) + "\n */"


def c_values(row: str, where: str, hi: int) -> list[int]:
    """The integers of one C initializer list (`0x12, 7, …`; a `u` suffix allowed),
    each 0..`hi`; errors name `where`."""
    values = []
    for t in (t.strip() for t in row.split(",")):
        if not t:
            continue
        try:
            value = int(t.rstrip("uU"), 0)
        except ValueError:
            raise DecodeError(f"{where}: {echo(t)} is not a C integer") from None
        if not 0 <= value <= hi:
            raise DecodeError(f"{where}: {t} is not a " + ("byte (0..0xFF)" if hi == 0xFF else
                                                            f"{hi.bit_length()}-bit word"))
        values.append(value)
    return values


_C_ROW = re.compile(r"\{([^{}]*)\}")


def c_rows(text: str, array: re.Pattern[str], example: str) -> tuple[str, list[str]]:
    """The prefix (`array`'s group 1) and the rows `{…}` of the first 2-D array
    `array` finds in a C header, comments dropped; `example` shows what was looked for."""
    m = array.search(text)
    if m is None:
        raise DecodeError(f"a C header declares {example} (as stepramp writes); none found")
    end = text.find("};", m.end())
    if end < 0:
        raise CorruptedError(f"{m.group(1)}: the array is not closed by '}};': the file is "
                             "truncated")
    body = re.sub(r"/\*.*?\*/", "", text[m.end():end], flags=re.S)
    return m.group(1), [row.group(1) for row in _C_ROW.finditer(body)]


def c_define(text: str, macro: str, value: str = r"(\d+)\b") -> str | None:
    """The value of the last `#define MACRO value` in `text` (`value`: its regex with one
    group), if any."""
    found = None
    for m in re.finditer(rf"#define\s+{re.escape(macro)}\s+{value}", text):
        found = m.group(1)
    return found


def c_crc(text: str, macro: str) -> str | None:
    """The CRC-32 a header's `#define MACRO_CRC32 0x…UL` gives, as 8 hex digits."""
    found = c_define(text, f"{macro}_CRC32", r"0x([0-9A-Fa-f]{1,8})[uUlL]*\b")
    return None if found is None else f"{int(found, 16):08X}"


def looks_like_c(raw: bytes) -> bool:
    line = first_content_line(raw)
    return line.startswith(("/*", "//", "#ifndef", "#include", "#define", "#pragma",
                            "static ", "const "))
