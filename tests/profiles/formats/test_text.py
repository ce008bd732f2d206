"""profiles/formats/text.py: text files decoded, their content lines, read in chunks of
whole lines, and told from binary."""

from __future__ import annotations

import pytest

from profiles.errors import DecodeError
from profiles.formats.text import (
    content_lines,
    first_content_line,
    looks_like_binary,
    text_chunks,
    text_lines,
    text_of,
)


def test_text_chunks_number_lines_and_locate_a_bad_byte() -> None:
    raw = b"".join(b"line %d\n" % k for k in range(1, 201))
    chunks = list(text_chunks(raw, size=64))
    assert len(chunks) > 10 and "".join(t for _, t in chunks) == raw.decode()
    for first, text in chunks:
        assert text.startswith(f"line {first}\n")
    assert list(text_lines(raw)) == list(enumerate(raw.decode().splitlines(), start=1))
    bad = raw[:1000] + b"\xff" + raw[1000:]
    with pytest.raises(DecodeError, match="byte 1000"):
        list(text_chunks(bad, size=64))


def test_content_lines_keep_their_numbers_and_comments_apart() -> None:
    lines, comments = content_lines(b"# head\n\n0A 0B  # two\n  \n0C\n", first=10)
    assert lines == [(12, "0A 0B  "), (14, "0C")]
    assert comments == [" head", " two"]


def test_text_of_names_the_first_byte_that_is_not_utf8() -> None:
    assert text_of("ä".encode()) == "ä"
    with pytest.raises(DecodeError, match="0xFF"):
        text_of(b"ab\xff")


@pytest.mark.parametrize(("raw", "binary"), [
    (b"02 03 01\n", False), ("motor ä\r\n\t".encode(), False), (b"\x02\x03", True),
    (b"ab\xffcd", True), (b"text\x7f", True), (b"", False)])
def test_looks_like_binary(raw: bytes, binary: bool) -> None:
    assert looks_like_binary(raw) is binary


def test_first_content_line_skips_blank_lines_and_stops_at_binary() -> None:
    assert first_content_line(b"\n  \n  :10000000 \nnext") == ":10000000"
    assert first_content_line(b"\n\n") == ""
    assert first_content_line(b"\xff\xfe") == ""
    assert first_content_line(b"head\n\xff") == "head"
