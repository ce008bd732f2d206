"""profiles/formats/c_header.py: C symbol prefixes, whole headers, and reading them back."""

from __future__ import annotations

import re

import pytest

from profiles.errors import CorruptedError, DecodeError, FormatError
from profiles.formats.c_header import (
    c_comment,
    c_crc,
    c_define,
    c_header,
    c_name,
    c_name_for,
    c_prefixes,
    c_rows,
    c_values,
    looks_like_c,
)

ARRAY = re.compile(r"const uint8_t (\w+)_rows\[\]\[2\] = \{")


@pytest.mark.parametrize("name", ["", "1axis", "x-axis", "int", "x axis", "a" * 41, "ä"])
def test_c_name_must_be_an_identifier(name: str) -> None:
    with pytest.raises(FormatError, match="--prefix"):
        c_name(name, "--prefix")


@pytest.mark.parametrize(("path", "name"), [
    ("x-axis.upload.h", "x_axis"), ("out/y_axis.h", "y_axis"), ("9.h", "stepramp"),
    (None, "stepramp"), ("int.h", "stepramp"), ("-.h", "stepramp")])
def test_c_name_from_the_output_file(path: str | None, name: str) -> None:
    assert c_name_for(path) == name


def test_a_header_reads_back() -> None:
    body = ["#define X_AXIS_CRC32 0x00ABCDEFUL", "const uint8_t x_axis_rows[][2] = {",
            "    {0x01, 2}, /* one */", "    {255u, 0x00},", "};"]
    text = c_header(["made by a test", "a */ inside"], "x_axis", body).decode()
    assert text.startswith("/* made by a test\n * a * / inside\n */\n#ifndef X_AXIS_H")
    assert looks_like_c(text.encode()) and not looks_like_c(b":00000001FF")
    prefix, rows = c_rows(text, ARRAY, "x_rows[][2]")
    assert prefix == "x_axis" and c_prefixes(text, ARRAY) == ["x_axis"]
    assert [c_values(r, "row", 0xFF) for r in rows] == [[1, 2], [255, 0]]
    assert c_crc(text, "X_AXIS") == "00ABCDEF"
    assert c_define(text, "X_AXIS_H", r"(\w*)") == ""
    assert c_define(text, "Y_AXIS_CRC32") is None


@pytest.mark.parametrize(("row", "words"), [("1, x", "'x' is not a C integer"),
                                            ("256", "not a byte")])
def test_c_values_name_the_row(row: str, words: str) -> None:
    with pytest.raises(DecodeError, match=words):
        c_values(row, "row 3", 0xFF)


def test_rows_of_a_missing_or_cut_array() -> None:
    with pytest.raises(DecodeError, match="declares x_rows"):
        c_rows("int x;", ARRAY, "x_rows")
    with pytest.raises(CorruptedError, match="truncated"):
        c_rows("const uint8_t a_rows[][2] = {\n {1, 2},", ARRAY, "x_rows")


def test_a_comment_cannot_end_early() -> None:
    assert c_comment(["*/ int x;"]) == "/* * / int x;\n */"
