"""profiles/formats/crc.py: the CRC-32 the files carry, whole or running, and a file's
claim checked against its payload."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from profiles.errors import CorruptedError
from profiles.formats.crc import (
    RunningCrc,
    crc32,
    crc_comment,
    crc_hex,
    find_crc_comment,
    verify_crc,
)
from tests.support.file_checks import flips


def test_crc32_is_the_standard_one() -> None:
    assert crc32(b"123456789") == 0xCBF43926  # the CRC-32 check value of every catalogue
    assert crc_hex(b"123456789") == "CBF43926"


@given(st.lists(st.binary(max_size=40), max_size=6))
def test_a_running_crc_of_the_chunks_is_the_crc_of_their_join(chunks: list[bytes]) -> None:
    running = RunningCrc()
    for chunk in chunks:
        running.update(chunk)
    whole = b"".join(chunks)
    assert running.hex == crc_hex(whole) and running.length == len(whole)
    assert running.comment() == crc_comment(whole)


def test_the_comment_line_is_found_again_and_the_last_one_wins() -> None:
    line = crc_comment(b"abc")
    assert line == f"crc32 {crc_hex(b'abc')}: CRC-32 of the 3 bytes above"
    assert find_crc_comment([" hand-made", f" {line}"]) == crc_hex(b"abc")
    assert find_crc_comment([" crc32 0x0000abcd", " crc32 DEADBEEF"]) == "DEADBEEF"
    assert find_crc_comment([" no check here", " crc32 12345"]) is None


def test_verify_crc_says_verified_absent_or_corrupted() -> None:
    payload = b"\x02\x03\x01"
    assert verify_crc(payload, crc_hex(payload).lower(), "line 3")[0] == "verified"
    assert verify_crc(payload, None, "line 3")[0] == "absent"
    with pytest.raises(CorruptedError, match="line 3 says CRC-32 00000000"):
        verify_crc(payload, "00000000", "line 3")


def test_the_crc_detects_every_single_bit_flip() -> None:
    payload = bytes(range(40))
    good = crc32(payload)
    assert all(crc32(flipped) != good for flipped in flips(payload))
