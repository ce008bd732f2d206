"""MC-200 driver behaviour: the host's sequences and a model of the driver reading them.

Facts: SPEC §3 and `seeds/mc200-spi-ja.txt`. Sequences (`servo_on`, `servo_off`,
`mode_switch`, `spi_error_reset`) are checked by feeding them through
`DriverModel`, our reading of the SPI page (docs/manual-notes.md).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..errors import DecodeError, FormatError, echo, require_int
from .codec import (
    HOST_FRAMES,
    MAGIC_DEFAULT,
    MODE_CODE,
    MODES,
    PACKET_SIZE,
    DriverPacket,
    HostPacket,
    Mode,
    packet_faults,
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
        raise FormatError(f"mode: {echo(mode)} is not one of {', '.join(MODES)}")
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
            raise FormatError(f"mode: {echo(mode)} is not one of {', '.join(MODES)}")
        self.magic = magic
        self.driver_id = driver_id
        self._mode = MODE_CODE[mode]
        self._servo = False
        self._run = 0  # consecutive servo bits opposite to the current state
        self._error: str | None = None
        self._armed: int | None = None
        self._command: int | float | None = None
        self.applied = False  # did the last packet consumed set the command value?

    @property
    def state(self) -> DriverState:
        return DriverState(self._servo, self._mode, self._error is not None, self._command,
                           self._armed, self._error)

    def feed(self, packets: Iterable[HostPacket | bytes]) -> DriverState:
        for p in packets:
            self.consume(p)
        return self.state

    def consume(self, packet: HostPacket | bytes) -> DriverState:
        self.applied = False
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
        self.applied = True
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



# --- reading a whole stream --------------------------------------------------------------------

@dataclass(frozen=True)
class StreamReading:
    """What the driver (`DriverModel`) makes of a host stream, packet by packet.

    Packet indices count from 0. Packets refused by their own checks (checksum,
    reserved bits: `bad_packets`) are read as lost: the manual does not say what
    the driver does with one; dropping it is the mildest reading.
    """

    packets: int
    state: DriverState                          # after the last packet
    bad_packets: tuple[tuple[int, str], ...]    # (index, why), the first few
    bad_count: int
    driver_ids: tuple[int, ...]
    servo_on_at: int | None                     # the packet that first turned the servo on
    servo_off_at: tuple[int, ...]               # packets that turned it off again
    mode_switches: tuple[tuple[int, int], ...]  # (packet completing it, new mode 1-3)
    spi_errors: tuple[tuple[int, str], ...]     # (packet, cause) each time it was raised
    ignored: int                                # packets ignored while the SPI error stood
    moved_while_off: int | None                 # first command changing the position, servo off
    reversals: tuple[tuple[int, int, int, int], ...]  # (packet, before, turn, after)
    reversal_count: int
    hold: int  # trailing position commands holding the last target (servo on, no error)
    target: int | None                          # the last position command applied


REPORT_MAX = 5  # examples kept of each kind of event


def read_stream(payload: bytes, *, mode: Mode = "position", magic: int = MAGIC_DEFAULT,
                driver_id: int | None = None) -> StreamReading:
    """Feed a host stream (packets back to back) through `DriverModel` and say what it did.

    Runs of plain commands (servo bit set, no mode switch, no reset) while the
    driver is steady (servo on, no error, no switch armed) change nothing but the
    command value, so they are taken at once: millions of packets read in
    seconds, with the same result as feeding each one (tested).
    """
    if len(payload) % PACKET_SIZE or not payload:
        raise DecodeError(f"{len(payload)} bytes is not a whole, non-zero number of "
                          f"{PACKET_SIZE}-byte packets")
    rows = np.frombuffer(payload, dtype=np.uint8).reshape(-1, PACKET_SIZE)
    n = len(rows)
    faulty = packet_faults(rows)
    plain = ~faulty & (rows[:, 0] & 0x0F == 0x08) & (rows[:, 7] & 0x40 == 0)
    if driver_id is not None:
        plain &= rows[:, 0] >> 4 == driver_id
    breaks = np.flatnonzero(~plain)
    positions = rows[:, 3:7].copy().view("<i4").reshape(-1)
    model = DriverModel(mode=mode, magic=magic, driver_id=driver_id)
    bad: list[tuple[int, str]] = []
    servo_on_at = None
    servo_off: list[int] = []
    switches: list[tuple[int, int]] = []
    errors: list[tuple[int, str]] = []
    ignored = 0
    moved_while_off = None
    applied: list[np.ndarray] = []      # position commands applied, in order
    applied_at: list[np.ndarray] = []   # their packet indices
    i = 0
    while i < n:
        st = model.state
        if plain[i] and st.servo_on and model._run == 0 and not st.spi_error \
                and st.switching_to is None:
            k = int(np.searchsorted(breaks, i))
            j = int(breaks[k]) if k < len(breaks) else n
            if model._mode == 1:
                applied.append(positions[i:j])
                applied_at.append(np.arange(i, j, dtype=np.int32))  # n < 2**31
                model._command = int(positions[j - 1])
            else:
                model.consume(rows[j - 1].tobytes())
            i = j
            continue
        if faulty[i]:
            if len(bad) < REPORT_MAX:
                bad.append((i, _fault(rows[i], i)))
            i += 1
            continue
        before = st
        after = model.consume(rows[i].tobytes())
        if before.spi_error and after.spi_error:
            ignored += 1
        if after.servo_on and not before.servo_on and servo_on_at is None:
            servo_on_at = i
        if before.servo_on and not after.servo_on:
            servo_off.append(i)
        if after.mode != before.mode or (before.switching_to and after.switching_to is None
                                         and not after.spi_error):
            switches.append((i, after.mode))
        if after.spi_error and not before.spi_error:
            errors.append((i, after.spi_error_cause or "SPI error"))
        if model.applied and after.mode == 1:
            value = int(positions[i])
            if not after.servo_on and moved_while_off is None and applied and \
                    int(applied[-1][-1]) != value:
                moved_while_off = i
            applied.append(positions[i:i + 1])
            applied_at.append(np.arange(i, i + 1, dtype=np.int32))
        i += 1
    ids = tuple(sorted({int(x) for x in np.unique(rows[~faulty, 0] >> 4)}))
    reversals, reversal_count, hold, target = _positions_read(applied, applied_at, model, n)
    return StreamReading(n, model.state, tuple(bad), int(faulty.sum()), ids, servo_on_at,
                         tuple(servo_off[:REPORT_MAX]), tuple(switches[:REPORT_MAX]),
                         tuple(errors[:REPORT_MAX]), ignored, moved_while_off, reversals,
                         reversal_count, hold, target)


def _fault(row: np.ndarray, index: int) -> str:
    """Why packet `index` fails its own check (the frame's one-line error)."""
    try:
        HOST_FRAMES["raw"].decode(row.tobytes(), block=index)
    except DecodeError as e:
        return str(e)
    return "refused"  # pragma: no cover - packet_faults follows the Frame


def _positions_read(applied: list[np.ndarray], applied_at: list[np.ndarray],
                    model: DriverModel, n: int
                    ) -> tuple[tuple[tuple[int, int, int, int], ...], int, int, int | None]:
    """Direction changes of the position commands applied, and the final hold."""
    if not applied:
        return (), 0, 0, None
    p = np.concatenate(applied)  # int32 commands
    at = np.concatenate(applied_at)
    # the sign of each step, as int8 (a difference of int32 could wrap)
    d = (p[1:] > p[:-1]).view(np.int8) - (p[1:] < p[:-1]).view(np.int8)
    moving = np.flatnonzero(d)
    turns = moving[1:][d[moving[1:]] != d[moving[:-1]]]  # a step against the step before
    examples = []
    for t in turns[:REPORT_MAX]:
        prev = moving[np.searchsorted(moving, t) - 1]
        examples.append((int(at[t + 1]), int(p[prev]), int(p[t]), int(p[t + 1])))
    st = model.state
    target = int(p[-1])
    hold = 0
    if st.servo_on and not st.spi_error and st.mode == 1 and at[-1] == n - 1:
        same = np.flatnonzero(p != target)
        hold = len(p) - (int(same[-1]) + 1 if len(same) else 0)
        # only the commands of the stream's last packets count: a gap breaks the hold
        gaps = np.flatnonzero(np.diff(at[len(p) - hold:]) != 1)
        if len(gaps):
            hold = hold - int(gaps[-1]) - 1
    return tuple(examples), len(turns), hold, target
