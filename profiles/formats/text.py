"""Text files: decoded (a clear error at the first byte that is not UTF-8), their
content lines and `#` comments, read a chunk of whole lines at a time, and told from
binary (sniffing: `looks_like_binary`, `first_content_line`)."""

from __future__ import annotations

import re
from collections.abc import Iterator

from ..errors import DecodeError


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


def text_lines(raw: bytes) -> Iterator[tuple[int, str]]:
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
