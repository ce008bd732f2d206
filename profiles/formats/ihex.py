"""Intel HEX (I32HEX): a payload rendered as records, whole or chunk by chunk, and
parsed back as one run of bytes with every record's checksum verified."""

from __future__ import annotations

from collections.abc import Iterable, Iterator

from ..errors import CorruptedError, DecodeError, FieldRangeError
from .hex_text import hex_bytes
from .text import first_content_line, text_lines

IHEX_RECORD_BYTES = 16
IHEX_ADDRESS_MAX = 0xFFFFFFFF


def _ihex_record(kind: int, address: int, data: bytes) -> str:
    body = bytes([len(data), address >> 8 & 0xFF, address & 0xFF, kind]) + data
    return ":" + body.hex().upper() + f"{-sum(body) & 0xFF:02X}"


def render_ihex(payload: bytes, base_address: int) -> bytes:
    """Intel HEX (I32HEX): 16-byte data records from `base_address`, an extended linear
    address record (04) wherever the upper 16 address bits change, the EOF record."""
    if isinstance(base_address, bool) or not isinstance(base_address, int) or not (
            0 <= base_address <= IHEX_ADDRESS_MAX - max(len(payload) - 1, 0)):
        raise FieldRangeError("base address", base_address, 0,
                              IHEX_ADDRESS_MAX - max(len(payload) - 1, 0))
    return b"".join(render_ihex_chunks([payload], base_address))


def render_ihex_chunks(chunks: Iterable[bytes], base_address: int) -> Iterator[bytes]:
    """`render_ihex` of a payload given in chunks, the records of each chunk as they
    are complete (a record is cut where the whole payload's would be, never at a
    chunk's edge). A payload running past address 0xFFFFFFFF raises FieldRangeError
    when it gets there."""
    if isinstance(base_address, bool) or not isinstance(base_address, int) or not (
            0 <= base_address <= IHEX_ADDRESS_MAX):
        raise FieldRangeError("base address", base_address, 0, IHEX_ADDRESS_MAX)
    upper: int | None = None
    address = base_address
    data = b""

    def records(final: bool) -> Iterator[str]:
        nonlocal upper, address, data
        pos = 0
        while pos < len(data):
            # A record never crosses a 64 KiB boundary (its address is 16 bits).
            full = min(IHEX_RECORD_BYTES, 0x10000 - (address & 0xFFFF))
            n = min(full, len(data) - pos)
            if n < full and not final:
                break  # wait for the next chunk: the whole payload's record is longer
            if address + n - 1 > IHEX_ADDRESS_MAX:
                raise FieldRangeError("base address", base_address, 0, max(
                    0, IHEX_ADDRESS_MAX - (address - base_address + n) + 1))
            if address >> 16 != upper:
                upper = address >> 16
                yield _ihex_record(0x04, 0, upper.to_bytes(2, "big"))
            yield _ihex_record(0x00, address & 0xFFFF, data[pos:pos + n])
            pos += n
            address += n
        data = data[pos:]

    for chunk in chunks:
        data += bytes(chunk)
        lines = list(records(final=False))
        if lines:
            yield ("\n".join(lines) + "\n").encode("ascii")
    lines = [*records(final=True), _ihex_record(0x01, 0, b"")]
    yield ("\n".join(lines) + "\n").encode("ascii")


def parse_ihex(raw: bytes, *, whole: bool = True) -> tuple[bytes, int]:
    """The contiguous payload of an Intel HEX file and its start address. Every
    record's checksum is verified (`CorruptedError`); the data must be one run
    without gaps or overlaps, ended by the EOF record (`whole=False`: `raw` is the
    file's first lines, to tell what it holds, and need not be ended)."""
    base = 0
    start: int | None = None
    payload = bytearray()
    ended = False
    for number, line in text_lines(raw):
        line = line.strip()
        if not line:
            continue
        where = f"line {number}"
        if ended:
            raise DecodeError(f"{where}: data after the end-of-file record")
        if not line.startswith(":"):
            raise DecodeError(f"{where}: an Intel HEX record starts with ':'")
        body = hex_bytes(line[1:], where)
        if len(body) < 5 or len(body) != 5 + body[0]:
            raise CorruptedError(f"{where}: the record is {len(body)} bytes, its length byte "
                                 f"says {5 + body[0] if body else 5}")
        if sum(body) & 0xFF:
            want = -sum(body[:-1]) & 0xFF
            raise CorruptedError(f"{where}: record checksum {body[-1]:02X}, the record gives "
                                 f"{want:02X}")
        kind, address, data = body[3], int.from_bytes(body[1:3], "big"), body[4:-1]
        if kind == 0x00:
            full = base + address
            if start is None:
                start = full
            elif full != start + len(payload):
                raise DecodeError(f"{where}: data at 0x{full:08X}, expected 0x"
                                  f"{start + len(payload):08X} (the upload is one run of "
                                  "bytes, without gaps)")
            payload += data
        elif kind == 0x01:
            ended = True
        elif kind in (0x02, 0x04):  # extended segment (× 16) / linear (× 65536) address
            if len(data) != 2:
                raise DecodeError(f"{where}: an extended address record carries 2 bytes")
            base = int.from_bytes(data, "big") << (4 if kind == 0x02 else 16)
        elif kind in (0x03, 0x05):
            pass  # start addresses: nothing to upload
        else:
            raise DecodeError(f"{where}: record type {kind:02X} is not Intel HEX (00-05)")
    if whole and not ended:
        raise CorruptedError("no end-of-file record (:00000001FF): the file is truncated")
    if start is None:
        raise DecodeError("the Intel HEX file holds no data records")
    return bytes(payload), start


def looks_like_ihex(raw: bytes) -> bool:
    return first_content_line(raw).startswith(":")
