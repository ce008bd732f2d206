"""MC-200 servo driver SPI packets: codec, sequences, a driver state model, streaming.

Facts: SPEC §3 and `seeds/mc200-spi-ja.txt` (one page per control mode). Every
packet is 12 bytes, little-endian; bytes 10–11 are a checksum over bytes 0–9.
Choices where the manual is silent or contradicts itself: docs/manual-notes.md.

- `HostPacket` / `DriverPacket`: one `fields.Frame` per layout serves encode and decode.
- Sequences: `servo_on`, `servo_off`, `mode_switch`, `spi_error_reset`, checked by
  feeding them through `DriverModel`.
- `stream_move`: one integer position command per SPI period for any monotone
  profile (e.g. `ruckig_profile`), never ahead of it, ending exactly at the target.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from .errors import DecodeError, FieldRangeError, FormatError, StepRampError, require_int
from .fields import F32, Bit, Bits, Checksum, Frame, Reserved, SInt, UInt

if TYPE_CHECKING:
    from .motor import Motor
    from .progress import Progress

PACKET_SIZE = 12
MAGIC_DEFAULT = 0x0F0F0F0F  # position and current pages; the velocity page says F0F0F0F0
MAGIC_VELOCITY_PAGE = 0xF0F0F0F0
SERVO_ON_COUNT = 3   # consecutive servo bits = 1 to turn on
SERVO_OFF_COUNT = 5  # consecutive servo bits = 0 to turn off

Mode = Literal["position", "velocity", "current"]
MODES: tuple[Mode, Mode, Mode] = ("position", "velocity", "current")
MODE_CODE: dict[str, int] = {"position": 1, "velocity": 2, "current": 3}
ValueKind = Literal["position", "velocity", "current", "raw"]


def checksum(data: bytes) -> int:
    """Sum of bytes 0–9 as five unsigned 16-bit little-endian words, low 15 bits, bit 15 set."""
    words = np.frombuffer(bytes(data[:10]).ljust(10, b"\0"), dtype="<u2")
    return (int(words.sum()) & 0x7FFF) | 0x8000


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
    Bits("state", 1, (Bit("in_position", 7), Bit("mode", 0, 3, hi=3))),
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
            raise FormatError(f"value_kind: {self.value_kind!r} is not one of "
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
            raise FormatError(f"mode: {mode!r} is not one of {', '.join(MODES)}")
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


# --- sequences ---------------------------------------------------------------------------------

def _count(name: str, n: Any, lo: int) -> int:
    if isinstance(n, bool) or not isinstance(n, int) or not lo <= n <= 1_000_000:
        raise FieldRangeError(name, n, lo, 1_000_000)
    return n


def _command(driver_id: int, servo: bool, value: int | float, kind: Mode, din: int = 0,
             mode_switch: int = 0, spi_error_reset: bool = False) -> HostPacket:
    packet = HostPacket(driver_id, servo, mode_switch, value, kind, spi_error_reset, din)
    packet.encode()  # refuse a bad field here, with its name
    return packet


def servo_on(driver_id: int, n: int = SERVO_ON_COUNT, *, value: int | float = 0,
             mode: Mode = "position") -> list[HostPacket]:
    """`n` (≥ 3) consecutive packets with the servo bit set."""
    _count("servo_on.n", n, SERVO_ON_COUNT)
    return [_command(driver_id, True, value, mode)] * n


def servo_off(driver_id: int, n: int = SERVO_OFF_COUNT, *, value: int | float = 0,
              mode: Mode = "position") -> list[HostPacket]:
    """`n` (≥ 5) consecutive packets with the servo bit clear."""
    _count("servo_off.n", n, SERVO_OFF_COUNT)
    return [_command(driver_id, False, value, mode)] * n


def mode_switch(driver_id: int, mode: Mode, magic: int = MAGIC_DEFAULT, *,
                servo: bool = True) -> list[HostPacket]:
    """The two packets that switch the control mode: the new mode with the magic in
    bytes 3–6, then the magic again. Command values follow, with mode_switch = 0."""
    if mode not in MODE_CODE:
        raise FormatError(f"mode: {mode!r} is not one of {', '.join(MODES)}")
    if isinstance(magic, bool) or not isinstance(magic, int) or not 0 <= magic <= 0xFFFFFFFF:
        raise FieldRangeError("magic", magic, 0, 0xFFFFFFFF)
    packet = HostPacket(driver_id, servo, MODE_CODE[mode], magic, "raw")
    packet.encode()  # refuse a bad driver id here, with its name
    return [packet, packet]


def spi_error_reset(driver_id: int, *, servo: bool = True, value: int | float = 0,
                    mode: Mode = "position") -> list[HostPacket]:
    """A packet with the SPI-error reset bit, then one without (the model ignores the
    reset packet's own command value, so it is repeated after it)."""
    return [_command(driver_id, servo, value, mode, spi_error_reset=True),
            _command(driver_id, servo, value, mode)]


@dataclass(frozen=True)
class DriverState:
    servo_on: bool
    mode: int  # 1 position, 2 velocity, 3 current
    spi_error: bool
    command: int | float | None  # last command value applied
    switching_to: int | None     # mode armed by the first magic packet
    spi_error_cause: str | None = None


class DriverModel:
    """The MC-200's reading of host packets (our model of the SPI page, see notes).

    - servo: on after 3 consecutive servo bits = 1, off after 5 consecutive = 0;
    - a non-zero mode-switch field starts a switch and must carry the magic; the
      next packet must carry the magic again (mode field 0 or the same mode); any
      other packet raises the SPI error;
    - while the SPI error is raised every command is ignored; a packet with the
      reset bit clears it (its own command is not applied).
    """

    def __init__(self, *, mode: Mode = "position", magic: int = MAGIC_DEFAULT,
                 driver_id: int | None = None) -> None:
        if mode not in MODE_CODE:
            raise FormatError(f"mode: {mode!r} is not one of {', '.join(MODES)}")
        self.magic = magic
        self.driver_id = driver_id
        self._mode = MODE_CODE[mode]
        self._servo = False
        self._run = 0  # consecutive servo bits opposite to the current state
        self._error: str | None = None
        self._armed: int | None = None
        self._command: int | float | None = None

    @property
    def state(self) -> DriverState:
        return DriverState(self._servo, self._mode, self._error is not None, self._command,
                           self._armed, self._error)

    def feed(self, packets: Iterable[HostPacket | bytes]) -> DriverState:
        for p in packets:
            self.consume(p)
        return self.state

    def consume(self, packet: HostPacket | bytes) -> DriverState:
        raw = packet.encode() if isinstance(packet, HostPacket) else bytes(packet)
        head = HOST_FRAMES["raw"].decode(raw)
        if self.driver_id is not None and head["driver_id"] != self.driver_id:
            return self.state  # addressed to another driver on the bus
        if self._error is not None:
            if head["spi_error_reset"]:
                self._error = None
                self._armed = None
            return self.state
        self._servo_bit(bool(head["servo"]))
        field, value = head["mode_switch"], head["value"]
        if self._armed is not None:
            if value == self.magic and field in (0, self._armed):
                self._mode, self._armed = self._armed, None
                return self.state
            self._raise(f"mode switch to {MODES[self._armed - 1]} broken: second packet "
                        f"has mode field {field}, bytes 3–6 0x{value:08X}")
            return self.state
        if field:
            if value == self.magic:
                self._armed = field
            else:
                self._raise(f"mode-switch field {field} without the magic 0x{self.magic:08X} "
                            f"(bytes 3–6 0x{value:08X})")
            return self.state
        kind = MODES[self._mode - 1]
        self._command = HOST_FRAMES[kind].decode(raw)["value"]
        return self.state

    def reply(self, *, current_a: float = 0.0) -> DriverPacket:
        """An ideal driver's answer: the encoder at the last position command."""
        at = self._command if self._mode == 1 and isinstance(self._command, int) else 0
        return DriverPacket(self.driver_id or 0, self._servo, False, False,
                            self._error is not None, at, current_a,
                            self._servo and self._mode == 1, self._mode)

    def _servo_bit(self, bit: bool) -> None:
        if bit == self._servo:
            self._run = 0
            return
        self._run += 1
        if self._run >= (SERVO_ON_COUNT if bit else SERVO_OFF_COUNT):
            self._servo, self._run = bit, 0

    def _raise(self, cause: str) -> None:
        self._error, self._armed = cause, None


# --- streaming ---------------------------------------------------------------------------------

PositionFn = Callable[[np.ndarray], np.ndarray]
INT32_MAX = (1 << 31) - 1
PERIOD_US_RANGE = (10.0, 1_000_000.0)
MAX_STREAM_PACKETS = 20_000_000


def stream_move(position_at: PositionFn, duration_s: float, pulses: int, *, period_us: float,
                driver_id: int = 0, start_position: int = 0,
                hold_packets: int = 10) -> list[HostPacket]:
    """Packets for a move of `pulses` along `position_at` (pulses, monotone 0 → pulses).

    Servo on (3 packets holding `start_position`), switch to position mode, one
    command per SPI period sampled at t = k·period, then `hold_packets` (≥ 5) at the
    target. Commands are ⌊profile⌋ (never ahead), so a period's step never exceeds
    ⌈the profile's advance⌉; the last one is exactly the target.
    """
    require_int("pulses", pulses, 1, INT32_MAX)
    require_int("start_position", start_position, -INT32_MAX - 1, INT32_MAX - pulses)
    _count("hold_packets", hold_packets, 5)
    if isinstance(period_us, bool) or not isinstance(period_us, int | float) or not (
            PERIOD_US_RANGE[0] <= period_us <= PERIOD_US_RANGE[1]):
        raise FieldRangeError("period_us", period_us, *PERIOD_US_RANGE)
    if isinstance(duration_s, bool) or not isinstance(duration_s, int | float) or not (
            0 < duration_s < math.inf):
        raise FieldRangeError("duration_s", duration_s, 0, math.inf)
    period_s = period_us * 1e-6
    count = math.ceil(duration_s / period_s - 1e-9)
    if count > MAX_STREAM_PACKETS:
        raise FieldRangeError("duration_s / period", count, 1, MAX_STREAM_PACKETS)
    positions = sample_positions(position_at, duration_s, pulses, period_s)
    preamble = servo_on(driver_id, value=start_position) + mode_switch(driver_id, "position")
    commands = [HostPacket(driver_id, True, 0, start_position + int(p), "position")
                for p in positions[1:]]
    hold = [HostPacket(driver_id, True, 0, start_position + pulses, "position")] * hold_packets
    return preamble + commands + hold


def sample_positions(position_at: PositionFn, duration_s: float, pulses: int,
                     period_s: float) -> np.ndarray:
    """Integer commands at t = 0, period, 2·period, … (the last at `duration_s`):
    ⌊profile⌋ clipped to [0, pulses] and made monotone; the last equals `pulses`."""
    count = max(1, math.ceil(duration_s / period_s - 1e-9))
    t = np.minimum(np.arange(count + 1) * period_s, duration_s)
    try:
        p = np.asarray(position_at(t), dtype=float)
    except (TypeError, ValueError) as e:
        raise FormatError(f"position_at: cannot evaluate the profile ({e})") from None
    if p.shape != t.shape or not np.all(np.isfinite(p)):
        raise FormatError(f"position_at: expected {t.size} finite positions, got shape "
                          f"{p.shape}")
    q = np.floor(np.clip(p, 0, pulses))
    q = np.maximum.accumulate(q).astype(np.int64)
    q[0] = 0
    q[-1] = pulses
    return q


def ruckig_profile(pulses: int, v_max_pps: float, a_max_pps2: float,
                   j_max_pps3: float) -> tuple[PositionFn, float]:
    """A jerk-limited rest-to-rest profile from ruckig, solved in normalised units
    (position / pulses, time / sqrt(pulses / a_max)) and evaluated vectorised."""
    from ruckig import InputParameter, Result, Ruckig, Trajectory

    require_int("pulses", pulses, 1, INT32_MAX)
    for name, value in (("v_max_pps", v_max_pps), ("a_max_pps2", a_max_pps2),
                        ("j_max_pps3", j_max_pps3)):
        if isinstance(value, bool) or not isinstance(value, int | float) or not (
                0 < value < 1e15):
            raise FieldRangeError(name, value, 0, 1e15)
    length = float(pulses)
    t_ref = math.sqrt(length / a_max_pps2)
    inp = InputParameter(1)
    inp.current_position = [0.0]
    inp.target_position = [1.0]
    inp.max_velocity = [v_max_pps * t_ref / length]
    inp.max_acceleration = [1.0]
    inp.max_jerk = [j_max_pps3 * t_ref**3 / length]
    traj = Trajectory(1)
    result = Ruckig(1).calculate(inp, traj)
    if result != Result.Working:
        raise StepRampError(f"ruckig: no profile for {pulses} pulses, v {v_max_pps:g}, "
                            f"a {a_max_pps2:g}, j {j_max_pps3:g} ({result})")
    prof = traj.profiles[0][0]
    if prof.brake.duration > 0:  # never for a start at rest; the evaluator assumes none
        raise StepRampError("ruckig: unexpected brake phase in a rest-to-rest profile")
    durations = np.asarray(prof.t, dtype=float)
    starts = np.concatenate(([0.0], np.cumsum(durations)))[:-1]
    j = np.asarray(prof.j, dtype=float)
    a0, v0, p0 = (np.asarray(x, dtype=float)[:7] for x in (prof.a, prof.v, prof.p))
    total_n = float(traj.duration)

    def position_at(t: np.ndarray) -> np.ndarray:
        tn = np.clip(np.asarray(t, dtype=float) / t_ref, 0.0, total_n)
        k = np.clip(np.searchsorted(starts, tn, side="right") - 1, 0, 6)
        dt = tn - starts[k]
        pn = p0[k] + dt * (v0[k] + dt * (a0[k] / 2 + dt * j[k] / 6))
        return np.clip(pn, 0.0, 1.0) * length

    return position_at, total_n * t_ref


def plan_stream(pulses: int, *, period_us: float, driver_id: int = 0,
                motor: Motor | None = None, v_max_pps: float | None = None,
                a_max_pps2: float | None = None,
                j_max_pps3: float | None = None) -> tuple[list[HostPacket], float]:
    """The packets that run a move of `pulses` and the move's duration [s].

    With `motor`: the PPMC-312's stall-safe planned staircase for this move (the
    profile a chip would run); otherwise ruckig's jerk-limited profile with the
    three limits, which must then all be given.
    """
    position_at: PositionFn
    if motor is not None:
        from profiles.ppmc312.execution import simulate_move
        from profiles.ppmc312.planner import plan_free_curve

        plan = plan_free_curve(motor, pulses=pulses)
        execution = simulate_move(plan.table, pulses)
        position_at, duration_s = execution.position_at, execution.duration_s
    else:
        if v_max_pps is None or a_max_pps2 is None or j_max_pps3 is None:
            raise FormatError("a stream needs a motor, or all of v_max_pps, a_max_pps2 and "
                              "j_max_pps3")
        position_at, duration_s = ruckig_profile(pulses, v_max_pps, a_max_pps2, j_max_pps3)
    packets = stream_move(position_at, duration_s, pulses, period_us=period_us,
                          driver_id=driver_id)
    return packets, duration_s


# --- byte streams ------------------------------------------------------------------------------

Direction = Literal["host", "driver"]


def encode_stream(packets: Sequence[HostPacket | DriverPacket]) -> bytes:
    return b"".join(p.encode() for p in packets)


def render_hex(packets: Sequence[HostPacket | DriverPacket]) -> str:
    """One packet per line: 12 bytes as two uppercase hex digits separated by spaces."""
    return "".join(p.encode().hex(" ").upper() + "\n" for p in packets)


STREAM_FORMATS = ("hex", "bin", "json")


def render_stream(packets: Sequence[HostPacket], fmt: str, *, period_us: float,
                  duration_s: float, pulses: int,
                  progress: Progress | None = None) -> str | bytes:
    """A stream file: `bin` (packets back to back), `hex` (`render_hex`) or `json`
    (the move's numbers and every packet as spaced hex). Encoding a long move takes
    seconds: `progress` hears (packets encoded, packets)."""
    import json

    from .progress import chunks

    if fmt not in STREAM_FORMATS:
        raise FormatError(f"format: {fmt!r} is not one of {', '.join(STREAM_FORMATS)}")
    encoded = [b"".join(p.encode() for p in packets[r.start:r.stop])
               for r in chunks(len(packets), 20_000, progress)]
    raw = b"".join(encoded)
    if fmt == "bin":
        return raw
    rows = [raw[i:i + PACKET_SIZE].hex(" ").upper() for i in range(0, len(raw), PACKET_SIZE)]
    if fmt == "json":
        return json.dumps({"period_us": period_us, "duration_s": duration_s, "pulses": pulses,
                           "packets": rows}, indent=1) + "\n"
    return "".join(row + "\n" for row in rows)


def decode_stream(data: bytes | str, direction: Direction = "host", *,
                  mode: Mode = "position",
                  magic: int = MAGIC_DEFAULT) -> list[HostPacket] | list[DriverPacket]:
    """Packets from binary or hex text (`render_hex` output). Binary is recognised by
    bytes ≥ 0x80: every packet's byte 11 has bit 7 set, hex text never does. Host
    packets are decoded with the control mode in force, following mode switches."""
    if direction not in ("host", "driver"):
        raise FormatError(f"direction: {direction!r} is not 'host' or 'driver'")
    raw = _stream_bytes(data)
    if len(raw) % PACKET_SIZE:
        whole = len(raw) // PACKET_SIZE
        raise DecodeError(f"{len(raw)} bytes is not a whole number of {PACKET_SIZE}-byte "
                          "packets", block=whole, byte=len(raw) - whole * PACKET_SIZE)
    chunks = [raw[i:i + PACKET_SIZE] for i in range(0, len(raw), PACKET_SIZE)]
    if direction == "driver":
        return [DriverPacket.decode(c, block=i) for i, c in enumerate(chunks)]
    out: list[HostPacket] = []
    in_force: Mode = mode
    armed: int | None = None
    for i, c in enumerate(chunks):
        pkt = HostPacket.decode(c, mode=in_force, magic=magic, block=i)
        raw_value = int.from_bytes(c[3:7], "little")
        if armed is not None and raw_value == magic and pkt.mode_switch in (0, armed):
            in_force, armed = MODES[armed - 1], None
            pkt = replace(pkt, value=raw_value, value_kind="raw")
        elif pkt.mode_switch and raw_value == magic:
            armed = pkt.mode_switch
        else:
            armed = None
        out.append(pkt)
    return out


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
            raise DecodeError(f"{tok!r} is not a two-digit hex byte", block=k // PACKET_SIZE,
                              byte=k % PACKET_SIZE)
        out.append(int(tok, 16))
    return bytes(out)
