"""Reading input files: one place that turns a path into bytes or JSON.

Every reader raises a one-line `FormatError` naming the file, never a traceback,
and every read is bounded: regular files, named pipes (a FIFO, a shell's process
substitution `<(cmd)`) and `-` (stdin) are read, never more than `MAX_INPUT_BYTES`;
JSON nesting is capped at `MAX_JSON_DEPTH` and numbers at `MAX_NUMBER_CHARS`
characters; NaN and Infinity are refused. Tables, motors and uploads are kilobytes,
so the caps only ever stop a wrong path (/dev/zero, a directory, a socket) or a
hostile file, before it costs memory, time or a Python limit. A pipe is read like
stdin: to its end (its writer closing it), at most the same number of bytes.

Files from other editors (issue 32 item 7): a UTF-8 byte-order mark (Windows editors and
spreadsheets write one) is dropped as the bytes are read, so every reader sees the text
as written; UTF-16 and UTF-32 text is refused in one line saying so ("save it as UTF-8")
rather than failing later as some format's odd byte. No binary input of stepramp's can
start with a byte-order mark: a PPMC-312 block starts with its length (≤ 31), an MC-200
packet's low three bits (its mode switch) are ≤ 3. JSON with a key twice in one object is
refused naming the key: readers disagree on which value wins (Python takes the last).
"""

from __future__ import annotations

import json
import math
import os
import re
import stat
import sys
from pathlib import Path
from typing import Any, BinaryIO

from .errors import FormatError, echo

MAX_INPUT_BYTES = 16 * 1024 * 1024
# MC-200 stream files run long (a 4 M-packet move is 144 MB of hex): their readers, which
# go a chunk of lines at a time, allow this much (profiles.mc200.formats).
STREAM_INPUT_MAX_BYTES = 256 * 1024 * 1024
MAX_JSON_DEPTH = 64
# Any real value fits (a double prints in ≤ 24 characters); 1 followed by 309 zeros does not.
MAX_NUMBER_CHARS = 40
STDIN = "-"


def display_path(path: str | Path) -> str:
    """A path as it can be printed on any terminal: bytes that are not UTF-8 (held by
    Python as lone surrogates) are shown as \\xNN escapes instead of breaking a strict
    stdout/stderr encoder."""
    text = os.fspath(path)
    try:
        raw = text.encode("utf-8", "surrogateescape")
    except UnicodeEncodeError:  # a lone surrogate that no byte stands for ("\ud800")
        raw = text.encode("utf-8", "backslashreplace")
    return raw.decode("utf-8", "backslashreplace")


def read_bytes(path: str | Path, *, limit: int = MAX_INPUT_BYTES) -> bytes:
    """A file's bytes (`-` reads stdin); a missing, unreadable, non-regular, oversized or
    empty file is a one-line FormatError."""
    name = display_path(path)
    if os.fspath(path) == "":
        raise FormatError("'': an empty file name (give a path, or - for stdin)")
    if os.fspath(path) == STDIN:
        data = _read_capped(sys.stdin.buffer, limit, "stdin")
    else:
        data = _read_regular(os.fspath(path), name, limit)
    data = without_utf8_bom(data)
    if not data.strip():
        raise FormatError(f"{name}: the file is empty")
    refuse_wide_text(data, name)
    return data


UTF8_BOM = b"\xef\xbb\xbf"
# Byte-order marks of the wide encodings, longest first (UTF-32 LE starts like UTF-16 LE).
_WIDE_BOMS = ((b"\xff\xfe\x00\x00", "UTF-32"), (b"\x00\x00\xfe\xff", "UTF-32"),
              (b"\xff\xfe", "UTF-16"), (b"\xfe\xff", "UTF-16"))
# UTF-16 without a mark: four ASCII characters, each with a zero byte beside it, the first
# printable (a PPMC-312 block's length byte is ≤ 31, an MC-200 packet's reserved byte 2
# is 0, so neither binary input matches).
_BARE_UTF16 = re.compile(rb"\A(?:[\x21-\x7e]\x00(?:[\t\n\r\x20-\x7e]\x00){3}"
                         rb"|\x00[\x21-\x7e](?:\x00[\t\n\r\x20-\x7e]){3})")


def without_utf8_bom(data: bytes) -> bytes:
    """`data` without a leading UTF-8 byte-order mark (a Windows editor's)."""
    return data[len(UTF8_BOM):] if data.startswith(UTF8_BOM) else data


def wide_text_encoding(data: bytes) -> str | None:
    """"UTF-16" or "UTF-32" when `data` is text in a wide encoding (by its byte-order
    mark, or ASCII characters each beside a zero byte), else None."""
    for bom, encoding in _WIDE_BOMS:
        if data.startswith(bom):
            return encoding
    return "UTF-16" if _BARE_UTF16.match(data) else None


def refuse_wide_text(data: bytes, name: str) -> None:
    """The honest one-line refusal of UTF-16/UTF-32 text (Notepad's "Unicode", PowerShell's
    `>`): every stepramp input is UTF-8 or binary."""
    encoding = wide_text_encoding(data)
    if encoding is not None:
        raise FormatError(f"{name}: {encoding} text: save it as UTF-8 (stepramp reads UTF-8 "
                          "text files)")


def _read_regular(path: str, name: str, limit: int) -> bytes:
    # stat before open: a device or socket is refused unopened (/dev/zero never ends, a
    # tape rewinds); a regular file's size is judged before a byte is read.
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise FormatError(f"{name}: no such file") from None
    except (OSError, ValueError) as e:
        raise FormatError(f"{name}: cannot read ({_why(e)})") from None
    pipe = _require_readable(st.st_mode, name)
    if not pipe:
        require_size(st.st_size, name, limit)
    try:
        # A regular file opens with O_NONBLOCK: should the path become a FIFO between stat
        # and open, open returns (and fstat refuses it). A pipe opens blocking, as `cat`
        # does: it waits for its writer (process substitution has one already).
        fd = os.open(path, os.O_RDONLY | (0 if pipe else getattr(os, "O_NONBLOCK", 0)))
    except FileNotFoundError:
        raise FormatError(f"{name}: no such file") from None
    except OSError as e:
        raise FormatError(f"{name}: cannot read ({_why(e)})") from None
    with os.fdopen(fd, "rb") as fh:
        # what was opened, not what was stat'ed
        if _require_readable(os.fstat(fd).st_mode, name) != pipe:
            raise FormatError(f"{name}: changed while it was opened")
        try:
            return _read_capped(fh, limit, name)
        except OSError as e:
            raise FormatError(f"{name}: cannot read ({_why(e)})") from None


def _require_readable(mode: int, name: str) -> bool:
    """Whether a file of `mode` is a pipe (read like stdin); a directory, device or
    socket is refused."""
    if stat.S_ISFIFO(mode):
        return True
    if stat.S_ISDIR(mode):
        raise FormatError(f"{name}: is a directory, not a file")
    if not stat.S_ISREG(mode):
        kind = ("a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a socket"
                if stat.S_ISSOCK(mode) else "special")
        raise FormatError(f"{name}: is {kind}, not a file or a pipe (use - to read stdin)")
    return False


def require_size(size: int, name: str, limit: int = MAX_INPUT_BYTES) -> None:
    """The one-line refusal of an input of `size` bytes past `limit`."""
    if size > limit:
        raise FormatError(f"{name}: {size} bytes is more than the {limit} bytes an input "
                          "may have")


def _read_capped(fh: BinaryIO, limit: int, name: str) -> bytes:
    data = fh.read(limit + 1)  # one byte more tells an oversized stream (or a grown file)
    if data is None:  # a non-blocking stream with nothing to read yet
        return b""
    if len(data) > limit:
        raise FormatError(f"{name}: more than the {limit} bytes an input may have")
    return bytes(data)


def _why(e: BaseException) -> str:
    if isinstance(e, OSError) and e.strerror:
        return e.strerror
    return f"{e.__class__.__name__}: {e}"


# A bracket or the quote that opens a string; the rest of a string up to its closing quote.
# Scanning string by string (anchored) keeps this linear: one regex over the whole text
# with strings as an alternative goes quadratic on `"\"\"\"…` with no closing quote.
_SPECIAL = re.compile(rb'["\[\]{}]')
_STRING_REST = re.compile(rb'[^"\\]*(?:\\.[^"\\]*)*"', re.S)


def json_depth(data: bytes, stop: int | None = None) -> int:
    """The deepest bracket nesting in JSON text (brackets inside strings do not count);
    with `stop`, the scan ends as soon as that depth is reached."""
    depth = deepest = pos = 0
    while (m := _SPECIAL.search(data, pos)) is not None:
        c = data[m.start()]
        if c == 0x22:  # '"': skip the string; unterminated, nothing after it counts
            rest = _STRING_REST.match(data, m.end())
            if rest is None:
                break
            pos = rest.end()
            continue
        if c in (0x5B, 0x7B):  # '[' '{'
            depth += 1
            if depth > deepest:
                deepest = depth
                if stop is not None and deepest >= stop:
                    break
        else:
            depth -= 1
        pos = m.end()
    return deepest


def _number(kind: type[int] | type[float], path: str) -> Any:
    def parse(text: str) -> int | float:
        if len(text) > MAX_NUMBER_CHARS:
            raise FormatError(f"{path}: number {text[:12]}… has {len(text)} characters, more "
                              f"than the {MAX_NUMBER_CHARS} a value may have")
        value = kind(text)
        if isinstance(value, float) and not math.isfinite(value):
            raise FormatError(f"{path}: number {text} is out of range (not a finite double)")
        return value
    return parse


def require_shallow_json(data: bytes, path: str | Path) -> None:
    """Refuse JSON text nested deeper than MAX_JSON_DEPTH (Python's parser would hit its
    recursion limit on it); text that is not a JSON object or array passes untouched."""
    text = without_utf8_bom(data).lstrip()
    if text[:1] not in (b"{", b"["):
        return
    if json_depth(text, stop=MAX_JSON_DEPTH + 1) > MAX_JSON_DEPTH:
        raise FormatError(f"{display_path(path)}: JSON nested more than the "
                          f"{MAX_JSON_DEPTH} levels an input may have")


def utf8_text(data: bytes, path: str | Path, *, encoding: str = "utf-8") -> str:
    """A text input's bytes as text, a UTF-8 byte-order mark dropped (`encoding` is kept
    for callers that name "utf-8-sig"; both read the same); UTF-16/32 text is refused
    saying so, other bytes that are not UTF-8 in one line naming the first."""
    data = without_utf8_bom(data)
    refuse_wide_text(data, display_path(path))
    try:
        return data.decode("utf-8" if encoding in ("utf-8", "utf-8-sig") else encoding)
    except UnicodeDecodeError as e:
        raise FormatError(f"{display_path(path)}: not a UTF-8 text file (byte "
                          f"0x{e.object[e.start]:02x} at offset {e.start})") from None


def parse_json(data: bytes, path: str | Path) -> Any:
    """JSON from a file's bytes (read once); `path` names it in errors."""
    name = display_path(path)
    require_shallow_json(data, path)

    def no_constant(word: str) -> Any:
        raise FormatError(f"{name}: {word} is not a JSON number (NaN and Infinity are refused)")

    def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        out = dict(pairs)
        if len(out) < len(pairs):
            raise FormatError(f"{name}: key {echo(_repeated(pairs))} appears twice in one "
                              "object (JSON readers differ on which value counts: keep one)")
        return out

    text = utf8_text(data, path)
    try:
        return json.loads(text, parse_int=_number(int, name), object_pairs_hook=unique_keys,
                          parse_float=_number(float, name), parse_constant=no_constant)
    except json.JSONDecodeError as e:
        raise FormatError(f"{name}: not valid JSON (line {e.lineno}, column {e.colno}: "
                          f"{e.msg}){_not_json_hint(text, e.pos)}") from None
    except RecursionError:  # unreachable below MAX_JSON_DEPTH; kept as the last guard
        raise FormatError(f"{name}: JSON nested too deeply") from None


def _repeated(pairs: list[tuple[str, Any]]) -> str:
    """The first key of `pairs` met a second time."""
    seen: set[str] = set()
    for key, _ in pairs:
        if key in seen:
            return key
        seen.add(key)
    return ""


def _not_json_hint(text: str, pos: int) -> str:
    """What a file that fails at its first character is instead (another tool's CSV or
    text), so the line says more than "Expecting value"."""
    if text[:pos].strip():
        return ""
    first = next((line.strip() for line in text.splitlines() if line.strip()), "")
    kind = "CSV or text" if "," in first or ";" in first or "\t" in first else "text"
    return f"; it starts {echo(first[:40])}, {kind}, not a JSON document"


def read_json(path: str | Path) -> Any:
    return parse_json(read_bytes(path), path)


def json_text(obj: Any, *, indent: int | None = 1) -> str:
    """JSON for an output: non-finite floats become null (NaN is not JSON), never `NaN`."""
    return json.dumps(_finite(obj), indent=indent, allow_nan=False) + "\n"


def _finite(obj: Any) -> Any:
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite(v) for v in obj]
    return obj


_DOCUMENT_FORMAT = re.compile(rb'\A\s*\{[^{}]*?"format"\s*:\s*"(stepramp\.[a-z0-9-]+/\d+)"')


def document_format(raw: bytes) -> str | None:
    """The "format" of a stepramp JSON document, when it names one early (before any nested
    object): "stepramp.table/1", "stepramp.axes/1", … (None for anything else)."""
    m = _DOCUMENT_FORMAT.match(raw[:4096])
    return m.group(1).decode() if m else None
