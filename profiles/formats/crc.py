"""CRC-32, the check the files carry that the wire lacks: whole or running (streams),
the text formats' comment line, and a file's claim verified against its payload
(`CorruptedError` on a mismatch)."""

from __future__ import annotations

import re
import zlib
from collections.abc import Sequence
from typing import Literal

from ..errors import CorruptedError

# verified: the file's check matched; absent: the format has a check but this
# file carries none (hand-made); none: the format has no room for one (bin).
Integrity = Literal["verified", "absent", "none"]


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
