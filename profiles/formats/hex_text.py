"""Hex text: bytes as upper-case digit pairs, and back (errors name the column)."""

from __future__ import annotations

from ..errors import DecodeError, echo

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
