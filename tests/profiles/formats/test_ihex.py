"""profiles/formats/ihex.py: Intel HEX written whole or chunk by chunk and read back."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from profiles.errors import CorruptedError, DecodeError, FieldRangeError
from profiles.formats.ihex import (
    IHEX_ADDRESS_MAX,
    looks_like_ihex,
    parse_ihex,
    render_ihex,
    render_ihex_chunks,
)


@given(st.binary(min_size=1, max_size=70), st.integers(0, 0xFFFF_FF00),
       st.lists(st.integers(1, 20), max_size=5))
def test_whole_and_chunked_agree_and_read_back(payload: bytes, base: int,
                                               cuts: list[int]) -> None:
    whole = render_ihex(payload, base)
    chunks, pos = [], 0
    for n in cuts:
        chunks.append(payload[pos:pos + n])
        pos += n
    chunks.append(payload[pos:])
    assert b"".join(render_ihex_chunks(chunks, base)) == whole
    assert parse_ihex(whole) == (payload, base)
    assert looks_like_ihex(whole)


def test_a_record_never_crosses_64_kib_and_the_upper_address_is_extended() -> None:
    text = render_ihex(bytes(8), 0x0001_FFFC).decode().split()
    assert text == [":020000040001F9", ":04FFFC0000000000" + "01",
                    ":020000040002F8", ":0400000000000000FC", ":00000001FF"]


def test_the_base_address_range() -> None:
    with pytest.raises(FieldRangeError, match="base address"):
        render_ihex(b"ab", IHEX_ADDRESS_MAX)
    with pytest.raises(FieldRangeError, match="base address"):
        render_ihex(b"ab", -1)


@pytest.mark.parametrize(("text", "error", "words"), [
    (":0100000041BE\n:00000001FE\n", CorruptedError,
     "line 2: record checksum FE, the record gives FF"),
    (":0100000041BE\n", CorruptedError, "no end-of-file record"),
    (":0100000041BE\n:0100020042BB\n:00000001FF\n", DecodeError, "without gaps"),
    ("0100000041BE\n", DecodeError, "starts with ':'"),
    (":00000001FF\n", DecodeError, "no data"),
])
def test_errors(text: str, error: type[Exception], words: str) -> None:
    with pytest.raises(error, match=words):
        parse_ihex(text.encode())


def test_a_first_part_need_not_be_ended() -> None:
    assert parse_ihex(b":0100000041BE\n", whole=False) == (b"A", 0)
