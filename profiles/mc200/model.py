"""MC-200 driver behaviour: the host's sequences and a model of the driver reading them.

Facts: SPEC §3 and `seeds/mc200-spi-ja.txt`. Sequences (`servo_on`, `servo_off`,
`mode_switch`, `spi_error_reset`) are checked by feeding them through
`DriverModel`, our reading of the SPI page (docs/manual-notes.md).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from ..errors import FormatError, require_int
from .codec import (
    HOST_FRAMES,
    MAGIC_DEFAULT,
    MODE_CODE,
    MODES,
    DriverPacket,
    HostPacket,
    Mode,
)

SERVO_ON_COUNT = 3   # consecutive servo bits = 1 to turn on
SERVO_OFF_COUNT = 5  # consecutive servo bits = 0 to turn off
SEQUENCE_MAX = 1_000_000  # packets in one repeated run (servo on/off, hold)

# --- sequences ---------------------------------------------------------------------------------

def _command(driver_id: int, servo: bool, value: int | float, kind: Mode, din: int = 0,
             mode_switch: int = 0, spi_error_reset: bool = False) -> HostPacket:
    packet = HostPacket(driver_id, servo, mode_switch, value, kind, spi_error_reset, din)
    packet.encode()  # refuse a bad field here, with its name
    return packet


def servo_on(driver_id: int, n: int = SERVO_ON_COUNT, *, value: int | float = 0,
             mode: Mode = "position") -> list[HostPacket]:
    """`n` (≥ 3) consecutive packets with the servo bit set."""
    require_int("servo_on.n", n, SERVO_ON_COUNT, SEQUENCE_MAX)
    return [_command(driver_id, True, value, mode)] * n


def servo_off(driver_id: int, n: int = SERVO_OFF_COUNT, *, value: int | float = 0,
              mode: Mode = "position") -> list[HostPacket]:
    """`n` (≥ 5) consecutive packets with the servo bit clear."""
    require_int("servo_off.n", n, SERVO_OFF_COUNT, SEQUENCE_MAX)
    return [_command(driver_id, False, value, mode)] * n


def mode_switch(driver_id: int, mode: Mode, magic: int = MAGIC_DEFAULT, *,
                servo: bool = True) -> list[HostPacket]:
    """The two packets that switch the control mode: the new mode with the magic in
    bytes 3–6, then the magic again. Command values follow, with mode_switch = 0."""
    if mode not in MODE_CODE:
        raise FormatError(f"mode: {mode!r} is not one of {', '.join(MODES)}")
    require_int("magic", magic, 0, 0xFFFFFFFF)
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

