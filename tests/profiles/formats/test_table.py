"""profiles/formats/table.py: a device's formats looked up by name, alias and extension,
told apart by content, and the whole-list render of a streaming format."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence

import pytest

from profiles.errors import DecodeError, FormatError
from profiles.formats.table import Format, FormatTable, Parsed, RenderOptions, chunked


def _stream(chunks: Iterable[bytes], options: RenderOptions) -> Iterator[bytes]:
    yield f"{options.count} items\n".encode()
    yield from chunks


def _parse_text(raw: bytes) -> Parsed[bytes]:
    return Parsed(raw.split(b"\n")[1:], "text", "none")


TEXT: Format[bytes] = Format("text", "lines", (".txt",),
                             chunked(_stream, lambda items: b"\n".join(items)),
                             _parse_text, lambda raw: raw[:1].isdigit(), render_chunks=_stream)
BIN: Format[bytes] = Format("bin", "bytes", (".bin", ".txt"),
                            lambda items, _: b"".join(items),
                            lambda raw: Parsed([raw], "bin", "none"), lambda raw: True,
                            binary=True)
TABLE = FormatTable("MC-200", [TEXT, BIN], aliases={"lines": "text"})


def test_names_aliases_and_extensions() -> None:
    assert TABLE.names == ("text", "bin", "lines")
    assert TABLE.get("lines") is TEXT
    assert TABLE.for_path("a.BIN") is BIN and TABLE.for_path("a.h") is None
    with pytest.raises(FormatError, match="format: 'srec' is not one of text, bin, lines"):
        TABLE.get("srec")


def test_detection_by_content_the_extension_breaking_ties() -> None:
    assert TABLE.detect(b"2 items") is TEXT
    assert TABLE.detect(b"2 items", "a.bin") is BIN
    assert TABLE.detect(b"x", "a.txt") is BIN  # the only format whose sniff matches
    with pytest.raises(DecodeError, match="not an MC-200 file in any known format"):
        FormatTable("MC-200", [TEXT]).detect(b"x")


def test_a_streaming_render_is_its_chunks_of_the_whole() -> None:
    items: Sequence[bytes] = [b"a", b"b"]
    assert TABLE.render(items, "text") == b"2 items\na\nb"
    assert b"".join(TABLE.render_chunks([b"a\n", b"b"], "text")) == b"None items\na\nb"
    with pytest.raises(FormatError, match="bin cannot be written chunk by chunk"):
        TABLE.render_chunks([b"a"], "bin")


def test_parse_drops_a_byte_order_mark_and_refuses_empty_files() -> None:
    assert TABLE.parse(b"\xef\xbb\xbf2 items\na").items == [b"a"]
    with pytest.raises(DecodeError, match="empty file"):
        TABLE.parse(b" \n")
    with pytest.raises(FormatError, match="parse needs bytes, got str"):
        TABLE.parse("2 items")  # type: ignore[arg-type]
