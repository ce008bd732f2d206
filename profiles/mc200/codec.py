"""MC-200 SPI packets: the checksum, one Frame per layout, packets and byte streams.

Facts: SPEC §3 and `seeds/mc200-spi-ja.txt` (one page per control mode). Every
packet is 12 bytes, little-endian; bytes 10–11 are a checksum over bytes 0–9.
`HostPacket` / `DriverPacket` encode and decode through their `fields.Frame`;
`encode_positions` encodes many position commands at once from the same Frame
(the template and the value's place in it), for streams of millions of packets.
Choices where the manual is silent or contradicts itself: docs/manual-notes.md.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Literal

import numpy as np

from ..errors import DecodeError, FieldRangeError, FormatError, echo
from ..fields import F32, Array, Bit, Bits, Checksum, Frame, Reserved, SInt, UInt

if TYPE_CHECKING:
    from ..progress import Progress

PACKET_SIZE = 12
MAGIC_DEFAULT = 0x0F0F0F0F  # position and current pages; the velocity page says F0F0F0F0
MAGIC_VELOCITY_PAGE = 0xF0F0F0F0
MAGICS = (MAGIC_DEFAULT, MAGIC_VELOCITY_PAGE)
Mode = Literal["position", "velocity", "current"]
MODES: tuple[Mode, Mode, Mode] = ("position", "velocity", "current")
MODE_CODE: dict[str, int] = {"position": 1, "velocity": 2, "current": 3}
ValueKind = Literal["position", "velocity", "current", "raw"]

def checksum(data: bytes) -> int:
    """Sum of bytes 0–9 as five unsigned 16-bit little-endian words, low 15 bits, bit 15 set."""
    row = np.frombuffer(bytes(data[:10]).ljust(10, b"\0"), dtype=np.uint8).reshape(1, 10)
    return int(checksums(row)[0])


def checksums(rows: np.ndarray) -> np.ndarray:
    """`checksum` of every row of an (n, ≥ 10) uint8 array at once."""
    words = np.ascontiguousarray(rows[:, :10]).view("<u2")
    # int32: five 16-bit words sum below 2**19 (half the memory of int64 on long streams)
    return (words.sum(axis=1, dtype=np.int32) & 0x7FFF) | 0x8000


def packet_faults(rows: np.ndarray) -> np.ndarray:
    """Per packet of an (n, 12) uint8 array: True where the host Frame refuses it (bad
    checksum, bits 7, 5, 4 of byte 7 set, mode-switch field > 3; the reserved bytes
    are not read): the Frame's rules, vectorised."""
    crc = rows[:, 10].astype(np.int32) | rows[:, 11].astype(np.int32) << 8
    return (crc != checksums(rows)) | (rows[:, 7] & 0xB0 != 0) | (rows[:, 0] & 0x07 > 3)


def reply_faults(rows: np.ndarray) -> np.ndarray:
    """Per reply of an (n, 12) uint8 array: True where the driver Frame refuses it (bad
    checksum, bits 6–4 of byte 9 set, a mode state above 3): the Frame's rules,
    vectorised."""
    crc = rows[:, 10].astype(np.int32) | rows[:, 11].astype(np.int32) << 8
    return (crc != checksums(rows)) | (rows[:, 9] & 0x70 != 0) | (rows[:, 9] & 0x0F > 3)


def looks_like_replies(payload: bytes) -> bool:
    """Whether packets (back to back) are the driver's replies rather than host packets:
    every one passes the reply Frame's rules and some say a control mode in byte 9 (1–3:
    every reply does), where a host packet's byte 9 is 予約, 0. Both sides share the
    checksum, so a host packet that passes its own check never has byte 9 set."""
    if not payload or len(payload) % PACKET_SIZE:
        return False
    rows = np.frombuffer(payload, dtype=np.uint8).reshape(-1, PACKET_SIZE)
    return bool((rows[:, 9] & 0x0F).any() and not reply_faults(rows).any())


def detect_magic(payload: bytes) -> int:
    """The mode-switch magic a host stream uses: bytes 3–6 of its first packet with a
    mode-switch field, when they are one of the sheet's two (`MAGICS`); else the
    default. A stream is written with one magic (`mc200 stream --magic`), and a file
    cannot say which, so its own first switch tells (`check`, `mc200 decode`)."""
    usable = len(payload) - len(payload) % PACKET_SIZE
    rows = np.frombuffer(payload[:usable], dtype=np.uint8).reshape(-1, PACKET_SIZE)
    switching = np.flatnonzero((rows[:, 0] & 0x07 != 0) & ~packet_faults(rows))
    if len(switching):
        k = int(switching[0]) * PACKET_SIZE
        raw = int.from_bytes(payload[k + 3:k + 7], "little")
        if raw in MAGICS:
            return raw
    return MAGIC_DEFAULT


_HOST_HEADER = Bits("header", 1, (Bit("driver_id", 4, 4), Bit("servo", 3),
                                  Bit("mode_switch", 0, 3, hi=3)))
_HOST_BYTE7 = Bits("control", 1, (Bit("spi_error_reset", 6), Bit("din", 0, 4)))


def _host_frame(kind: ValueKind) -> Frame:
    value: SInt | F32 | UInt
    if kind == "position":
        value = SInt("value", 4, "little")
    elif kind == "raw":
        value = UInt("value", 4, "little")
    else:
        value = F32("value", "little")
    return Frame(f"mc200.host.{kind}", (_HOST_HEADER, Reserved(2), value, _HOST_BYTE7,
                                        Reserved(2), Checksum("checksum", 2, checksum)))


HOST_FRAMES: dict[str, Frame] = {k: _host_frame(k) for k in ("position", "velocity", "current",
                                                             "raw")}
DRIVER_FRAME = Frame("mc200.driver", (
    Bits("header", 1, (Bit("driver_id", 4, 4), Bit("servo_on", 3), Bit("alarm", 2),
                       Bit("limit_alarm", 1), Bit("spi_error", 0))),
    SInt("encoder_pulses", 4, "little"),
    F32("current_a", "little"),
    # byte 9: 位置決め完了状態 | 0 | 0 | 0 | 制御モード状態 (1: 位置、2: 速度、3: 電流): three
    # zeros (bits 6–4), the mode state in the four bits left (3–0), 1–3 defined
    Bits("state", 1, (Bit("in_position", 7), Bit("mode", 0, 4, hi=3))),
    Checksum("checksum", 2, checksum),
))


@dataclass(frozen=True)
class HostPacket:
    """Host → MC-200. `value` is read by `value_kind`: int32 position, float32 velocity or
    current (the mode in force), or `raw` 32 bits (the mode-switch magic)."""

    driver_id: int = 0
    servo: bool = False
    mode_switch: int = 0  # 0 none, 1 position, 2 velocity, 3 current
    value: int | float = 0
    value_kind: ValueKind = "position"
    spi_error_reset: bool = False
    din: int = 0

    def encode(self) -> bytes:
        if self.value_kind not in HOST_FRAMES:
            raise FormatError(f"value_kind: {echo(self.value_kind)} is not one of "
                              f"{', '.join(HOST_FRAMES)}")
        return HOST_FRAMES[self.value_kind].encode(
            driver_id=self.driver_id, servo=self.servo, mode_switch=self.mode_switch,
            value=self.value, spi_error_reset=self.spi_error_reset, din=self.din)

    @property
    def raw_value(self) -> int:
        """Bytes 3–6 as an unsigned 32-bit integer."""
        return int.from_bytes(self.encode()[3:7], "little")

    @classmethod
    def decode(cls, data: bytes, *, mode: Mode = "position", magic: int = MAGIC_DEFAULT,
               block: int | None = None) -> HostPacket:
        """Decode with `mode` the control mode in force; a packet carrying a mode-switch
        command and the magic decodes its value as `raw`."""
        if mode not in MODE_CODE:
            raise FormatError(f"mode: {echo(mode)} is not one of {', '.join(MODES)}")
        d = HOST_FRAMES["raw"].decode(data, block=block)
        kind: ValueKind = "raw" if d["mode_switch"] and d["value"] == magic else mode
        if kind != "raw":
            d = HOST_FRAMES[kind].decode(data, block=block)
        return cls(d["driver_id"], bool(d["servo"]), d["mode_switch"], d["value"], kind,
                   bool(d["spi_error_reset"]), d["din"])


@dataclass(frozen=True)
class DriverPacket:
    """MC-200 → host. The manual gives no unit for the current; amperes assumed."""

    driver_id: int = 0
    servo_on: bool = False
    alarm: bool = False
    limit_alarm: bool = False
    spi_error: bool = False
    encoder_pulses: int = 0
    current_a: float = 0.0
    in_position: bool = False
    mode: int = 0  # 1 position, 2 velocity, 3 current (0 before any mode is known)

    def encode(self) -> bytes:
        return DRIVER_FRAME.encode(
            driver_id=self.driver_id, servo_on=self.servo_on, alarm=self.alarm,
            limit_alarm=self.limit_alarm, spi_error=self.spi_error,
            encoder_pulses=self.encoder_pulses, current_a=self.current_a,
            in_position=self.in_position, mode=self.mode)

    @classmethod
    def decode(cls, data: bytes, *, block: int | None = None) -> DriverPacket:
        d = DRIVER_FRAME.decode(data, block=block)
        return cls(d["driver_id"], bool(d["servo_on"]), bool(d["alarm"]),
                   bool(d["limit_alarm"]), bool(d["spi_error"]), d["encoder_pulses"],
                   d["current_a"], bool(d["in_position"]), d["mode"])

# --- byte streams ------------------------------------------------------------------------------

Direction = Literal["host", "driver"]


def encode_stream(packets: Sequence[HostPacket | DriverPacket]) -> bytes:
    return b"".join(p.encode() for p in packets)


def render_hex(packets: Sequence[HostPacket | DriverPacket]) -> str:
    """One packet per line: 12 bytes as two uppercase hex digits separated by spaces."""
    return hex_lines(encode_stream(packets))


def hex_lines(data: bytes) -> str:
    """`render_hex` of packets already encoded (whole packets, any number)."""
    if len(data) % PACKET_SIZE:
        raise DecodeError(f"{len(data)} bytes is not a whole number of {PACKET_SIZE}-byte "
                          "packets")
    if not data:
        return ""
    text = bytearray(data.hex(" ").upper().encode() + b"\n")
    text[3 * PACKET_SIZE - 1::3 * PACKET_SIZE] = b"\n" * (len(data) // PACKET_SIZE)
    return text.decode()


def encode_positions(template: HostPacket, positions: np.ndarray) -> bytes:
    """Position-command packets, one per position, otherwise equal to `template`, at once
    (`encode_values` of a position template)."""
    if template.value_kind != "position":
        raise FormatError(f"template: a position command, not {echo(template.value_kind)}")
    return encode_values(template, positions)


def encode_values(template: HostPacket, values: np.ndarray) -> bytes:
    """Command packets, one per value, otherwise equal to `template`, at once: int32
    positions, or float32 velocities or currents, by the template's `value_kind`.

    The Frame encodes the template (header, control byte, reserved bytes); the values
    go where the Frame puts its value field, and `checksums` closes each packet: the
    bytes equal `replace(template, value=v).encode()` for every v (a float rounded to
    float32 as the Frame's struct rounds it; non-finite values are refused: a stream
    has no use for them).
    """
    kind = template.value_kind
    if kind not in ("position", "velocity", "current"):
        raise FormatError(f"template: a position, velocity or current command, not "
                          f"{echo(kind)}")
    frame = HOST_FRAMES[kind]
    v = np.asarray(values)
    if v.ndim != 1 or (v.size and not np.issubdtype(v.dtype, np.integer if kind == "position"
                                                    else np.number)):
        raise FormatError(f"{'positions' if kind == 'position' else 'values'}: expected a 1-D "
                          f"array of {'integers' if kind == 'position' else 'numbers'}")
    rows = np.tile(np.frombuffer(template.encode(), dtype=np.uint8), (v.size, 1))
    at = _offset(frame, "value")
    rows[:, at:at + 4] = _value_bytes(frame, v).reshape(-1, 4)
    at = _offset(frame, "checksum")
    rows[:, at:at + 2] = checksums(rows).astype("<u2").view(np.uint8).reshape(-1, 2)
    return rows.tobytes()


def _value_bytes(frame: Frame, v: np.ndarray) -> np.ndarray:
    """The four bytes of every value, as the frame's value field packs one (its range)."""
    if frame.name.endswith("position"):
        lo, hi = -(1 << 31), (1 << 31) - 1
        if v.size and (int(v.min()) < lo or int(v.max()) > hi):
            bad = int(v.min()) if int(v.min()) < lo else int(v.max())
            raise FieldRangeError(f"{frame.name}.value", bad, lo, hi)
        return v.astype("<i4").view(np.uint8)
    with np.errstate(over="ignore", invalid="ignore"):
        single = v.astype("<f4")
    unfit = np.flatnonzero(~np.isfinite(single))
    if len(unfit):  # the float32 maximum, as F32 states its range
        raise FieldRangeError(f"{frame.name}.value", float(v[unfit[0]]), -3.4028235e38,
                              3.4028235e38)
    return single.view(np.uint8)


def _offset(frame: Frame, name: str) -> int:
    """Byte offset of field `name` in a fixed-size frame (read from its description)."""
    at = 0
    for f in frame.fields:
        if f.name == name:
            return at
        assert not isinstance(f, Array), "fixed-size frames only"
        at += f.size
    raise KeyError(name)


def decode_stream(data: bytes | str, direction: Direction = "host", *,
                  mode: Mode = "position",
                  magic: int = MAGIC_DEFAULT) -> list[HostPacket] | list[DriverPacket]:
    """Packets from binary or hex text (`render_hex` output). Binary is recognised by
    bytes ≥ 0x80: every packet's byte 11 has bit 7 set, hex text never does. Host
    packets are decoded with the control mode in force, following mode switches."""
    return list(iter_decode(_stream_bytes(data), direction, mode=mode,  # type: ignore[return-value]
                            magic=magic))


def iter_decode(raw: bytes, direction: Direction = "host", *, mode: Mode = "position",
                magic: int = MAGIC_DEFAULT) -> Iterator[HostPacket | DriverPacket]:
    """The packets of `raw` (packets back to back) one at a time, as `decode_stream`
    reads them: a stream of millions is decoded in constant memory. The length is
    checked before the first packet."""
    if direction not in ("host", "driver"):
        raise FormatError(f"direction: {echo(direction)} is not 'host' or 'driver'")
    if len(raw) % PACKET_SIZE:
        whole = len(raw) // PACKET_SIZE
        raise DecodeError(f"{len(raw)} bytes is not a whole number of {PACKET_SIZE}-byte "
                          "packets", block=whole, byte=len(raw) - whole * PACKET_SIZE)
    return _decode_host(raw, mode, magic) if direction == "host" else (
        DriverPacket.decode(raw[k:k + PACKET_SIZE], block=k // PACKET_SIZE)
        for k in range(0, len(raw), PACKET_SIZE))


def _decode_host(raw: bytes, mode: Mode, magic: int) -> Iterator[HostPacket]:
    in_force: Mode = mode
    armed: int | None = None
    for i, k in enumerate(range(0, len(raw), PACKET_SIZE)):
        c = raw[k:k + PACKET_SIZE]
        pkt = HostPacket.decode(c, mode=in_force, magic=magic, block=i)
        raw_value = int.from_bytes(c[3:7], "little")
        if armed is not None and raw_value == magic and pkt.mode_switch in (0, armed):
            in_force, armed = MODES[armed - 1], None
            pkt = replace(pkt, value=raw_value, value_kind="raw")
        elif pkt.mode_switch and raw_value == magic:
            armed = pkt.mode_switch
        else:
            armed = None
        yield pkt


def decoded_lines(raw: bytes, direction: Direction = "host", fmt: str = "text", *,
                  magic: int = MAGIC_DEFAULT, rows_per_chunk: int = 4096,
                  progress: Progress | None = None) -> Iterator[str]:
    """What `stepramp mc200 decode` prints for `raw` (packets back to back), a chunk of
    packets at a time: `text` (one numbered line of field=value a packet) or `json`
    (the text `json_text({"direction", "packets": [fields…]})` gives, NaN as null).
    Host packets follow the stream's mode switches, `magic` the one they carry.
    Memory is one chunk however long the stream. Every packet is judged before this
    returns: a bad packet raises here, before any line is given. `progress` hears
    (packets listed, packets) as the chunks go out."""
    if fmt not in ("text", "json"):
        raise FormatError(f"format: {echo(fmt)} is not 'text' or 'json'")
    # A bad packet near the end must not leave half a listing behind its error. Host
    # packets are judged at once by the Frame's rules vectorised (the first bad one
    # decoded for its exact error), driver packets by decoding them.
    packets = iter_decode(raw, direction, magic=magic)
    if direction == "host":
        faulty = np.flatnonzero(packet_faults(np.frombuffer(raw, np.uint8).reshape(-1, 12)))
        if len(faulty):
            k = int(faulty[0]) * PACKET_SIZE
            HOST_FRAMES["raw"].decode(raw[k:k + PACKET_SIZE], block=int(faulty[0]))
    else:
        for _ in packets:
            pass
        packets = iter_decode(raw, direction)
    return _lines(packets, direction, fmt, rows_per_chunk, len(raw) // PACKET_SIZE, progress)


def _lines(packets: Iterator[HostPacket | DriverPacket], direction: Direction, fmt: str,
           rows_per_chunk: int, total: int, progress: Progress | None) -> Iterator[str]:
    from dataclasses import asdict

    from ..progress import report
    from ..reading import json_text

    report(progress, 0, total)

    if fmt == "json":
        yield f'{{\n "direction": {json_text(direction, indent=None).strip()},\n "packets": ['
    sep = "\n"
    rows: list[str] = []
    for i, p in enumerate(packets):
        if fmt == "json":
            rows.append(sep + "  " + json_text(asdict(p)).rstrip("\n").replace("\n", "\n  "))
            sep = ",\n"
        else:
            rows.append(f"{i:6d}  " + " ".join(f"{k}={v}" for k, v in asdict(p).items()) + "\n")
        if len(rows) >= rows_per_chunk:
            yield "".join(rows)
            rows = []
            report(progress, i + 1, total)
    yield "".join(rows)
    report(progress, total, total)
    if fmt == "json":
        yield "\n ]\n}\n"


def _stream_bytes(data: bytes | str) -> bytes:
    if isinstance(data, str):
        text = data
    elif isinstance(data, bytes | bytearray | memoryview):
        data = bytes(data)
        if any(b >= 0x80 for b in data) or not data.strip():
            return data
        text = data.decode("ascii")
    else:
        raise FormatError(f"data: expected bytes or hex text, got {type(data).__name__}")
    tokens = text.split()
    out = bytearray()
    for k, tok in enumerate(tokens):
        if len(tok) != 2 or any(ch not in "0123456789abcdefABCDEF" for ch in tok):
            raise DecodeError(f"{echo(tok)} is not a two-digit hex byte", block=k // PACKET_SIZE,
                              byte=k % PACKET_SIZE)
        out.append(int(tok, 16))
    return bytes(out)
