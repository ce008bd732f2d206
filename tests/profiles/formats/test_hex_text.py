"""profiles/formats/hex_text.py: bytes as hex digit pairs and back."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from profiles.errors import DecodeError
from profiles.formats.hex_text import hex_bytes, hex_line


@given(st.binary(max_size=30))
def test_hex_text_round_trips(data: bytes) -> None:
    assert hex_bytes(hex_line(data), "line 1") == data


def test_pairs_may_run_together_and_spaces_stand_between_them() -> None:
    assert hex_line(b"\x0a\xff") == "0A FF"
    assert hex_bytes("0aff  10", "line 1") == b"\x0a\xff\x10"


@pytest.mark.parametrize(("text", "words"), [
    ("0A FG", "line 7, column 5: 'G' is not a hex digit"),
    ("0A F", "line 7, column 4: 'F' has an odd number"),
])
def test_errors_name_the_line_and_column(text: str, words: str) -> None:
    with pytest.raises(DecodeError) as e:
        hex_bytes(text, "line 7")
    assert words in str(e.value)
