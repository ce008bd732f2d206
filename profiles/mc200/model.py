"""MC-200 driver behaviour: the host's sequences and a model of the driver reading them.

Facts: SPEC §3 and `seeds/mc200-spi-ja.txt`. Sequences (`servo_on`, `servo_off`,
`mode_switch`, `spi_error_reset`) are checked by feeding them through
`DriverModel`, our reading of the SPI page (docs/manual-notes.md).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

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
             mode: Mode = "position", din: int = 0) -> list[HostPacket]:
    """`n` (≥ 3) consecutive packets with the servo bit set (`din`: the DIN0–3 bits, the
    driver's inputs set by its parameters #304–#307, in byte 7)."""
    require_int("servo_on.n", n, SERVO_ON_COUNT, SEQUENCE_MAX)
    return [_command(driver_id, True, value, mode, din)] * n


def servo_off(driver_id: int, n: int = SERVO_OFF_COUNT, *, value: int | float = 0,
              mode: Mode = "position", din: int = 0) -> list[HostPacket]:
    """`n` (≥ 5) consecutive packets with the servo bit clear."""
    require_int("servo_off.n", n, SERVO_OFF_COUNT, SEQUENCE_MAX)
    return [_command(driver_id, False, value, mode, din)] * n


def mode_switch(driver_id: int, mode: Mode, magic: int = MAGIC_DEFAULT, *,
                servo: bool = True, din: int = 0) -> list[HostPacket]:
    """The two packets that switch the control mode: the new mode with the magic in
    bytes 3–6, then the magic again. Command values follow, with mode_switch = 0."""
    if mode not in MODE_CODE:
        raise FormatError(f"mode: {echo(mode)} is not one of {', '.join(MODES)}")
    require_int("magic", magic, 0, 0xFFFFFFFF)
    packet = HostPacket(driver_id, servo, MODE_CODE[mode], magic, "raw", din=din)
    packet.encode()  # refuse a bad driver id or DIN here, with its name
    return [packet, packet]


def spi_error_reset(driver_id: int, *, servo: bool = True, value: int | float = 0,
                    mode: Mode = "position", din: int = 0) -> list[HostPacket]:
    """A packet with the SPI-error reset bit, then one without (the model ignores the
    reset packet's own command value, so it is repeated after it)."""
    return [_command(driver_id, servo, value, mode, din, spi_error_reset=True),
            _command(driver_id, servo, value, mode, din)]


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
class Commands:
    """Every command value the driver applied from a host stream, in order: the packet
    (`at`, from 0), the control mode in force (`mode`, 1 position, 2 velocity, 3 current)
    and bytes 3–6 as sent (`raw`, read by the mode: `values`)."""

    at: np.ndarray    # int32 (a stream holds < 2**31 packets)
    mode: np.ndarray  # int8
    raw: np.ndarray   # uint32

    def __len__(self) -> int:
        return len(self.at)

    def values(self) -> np.ndarray:
        """The commands as numbers (float64): int32 positions [pulses], float32 velocities
        [pps] and currents [A] (stepramp's units: docs/manual-notes.md)."""
        as_int = self.raw.view(np.int32).astype(np.float64)
        return np.where(self.mode == 1, as_int, self.raw.view(np.float32).astype(np.float64))

    def value(self, k: int) -> int | float:
        """Command `k` as the driver reads it: an int position or a float."""
        raw = self.raw[k:k + 1]
        return int(raw.view(np.int32)[0]) if self.mode[k] == 1 else float(raw.view(np.float32)[0])


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
    moved_while_off: int | None                 # first command changing its value, servo off
    reversals: tuple[tuple[int, int, int, int], ...]  # (packet, before, turn, after)
    reversal_count: int
    hold: int  # trailing commands holding the last value (servo on, no error, its mode)
    target: int | float | None                  # the last command applied (in its mode)
    commands: Commands = field(repr=False, compare=False,
                               default_factory=lambda: _commands([], [], []))


REPORT_MAX = 5  # examples kept of each kind of event


def read_stream(payload: bytes, *, mode: Mode = "position", magic: int = MAGIC_DEFAULT,
                driver_id: int | None = None) -> StreamReading:
    """Feed a host stream (packets back to back) through `DriverModel` and say what it did.

    Runs of plain commands (servo bit set, no mode switch, no reset) while the
    driver is steady (servo on, no error, no switch armed) change nothing but the
    command value, so they are taken at once: millions of packets read in
    seconds, with the same result as feeding each one (tested).
    """
    walk = _Walk(payload, mode, magic, driver_id)
    walk.run()
    return walk.reading()


def applied_commands(payload: bytes, *, mode: Mode = "position", magic: int = MAGIC_DEFAULT,
                     driver_id: int | None = None) -> Commands:
    """Every command the driver applies from a host stream (`read_stream`'s reading)."""
    return read_stream(payload, mode=mode, magic=magic, driver_id=driver_id).commands


class _Walk:
    """`read_stream`'s pass over a stream: the model fed packet by packet, runs of plain
    commands at once, the events and the commands applied collected as it goes."""

    def __init__(self, payload: bytes, mode: Mode, magic: int, driver_id: int | None) -> None:
        if len(payload) % PACKET_SIZE or not payload:
            raise DecodeError(f"{len(payload)} bytes is not a whole, non-zero number of "
                              f"{PACKET_SIZE}-byte packets")
        self.rows = rows = np.frombuffer(payload, dtype=np.uint8).reshape(-1, PACKET_SIZE)
        self.n = len(rows)
        self.faulty = packet_faults(rows)
        plain = ~self.faulty & (rows[:, 0] & 0x0F == 0x08) & (rows[:, 7] & 0x40 == 0)
        if driver_id is not None:
            plain &= rows[:, 0] >> 4 == driver_id
        self.plain = plain
        self.breaks = np.flatnonzero(~plain)
        self.raw = rows[:, 3:7].copy().view("<u4").reshape(-1)
        self.model = DriverModel(mode=mode, magic=magic, driver_id=driver_id)
        self.bad: list[tuple[int, str]] = []
        self.servo_on_at: int | None = None
        self.servo_off: list[int] = []
        self.switches: list[tuple[int, int]] = []
        self.errors: list[tuple[int, str]] = []
        self.ignored = 0
        self.moved_while_off: int | None = None
        self.at: list[np.ndarray] = []     # packets whose command was applied, in order
        self.modes: list[np.ndarray] = []  # the mode each was read in
        self.values: list[np.ndarray] = []  # their bytes 3–6

    def run(self) -> None:
        i = 0
        while i < self.n:
            st = self.model.state
            if self.plain[i] and st.servo_on and self.model._run == 0 and not st.spi_error \
                    and st.switching_to is None:
                i = self._plain_run(i)
            elif self.faulty[i]:
                if len(self.bad) < REPORT_MAX:
                    self.bad.append((i, _fault(self.rows[i], i)))
                i += 1
            else:
                self._one(i, st)
                i += 1

    def _plain_run(self, i: int) -> int:
        """Packets i… up to the next that is not plain: each sets the command, no more."""
        k = int(np.searchsorted(self.breaks, i))
        j = int(self.breaks[k]) if k < len(self.breaks) else self.n
        self._applied(i, j, self.model._mode)
        self.model.consume(self.rows[j - 1].tobytes())  # the last one's value stands
        return j

    def _applied(self, i: int, j: int, mode: int) -> None:
        self.at.append(np.arange(i, j, dtype=np.int32))  # n < 2**31
        self.modes.append(np.full(j - i, mode, dtype=np.int8))
        self.values.append(self.raw[i:j])

    def _one(self, i: int, before: DriverState) -> None:
        after = self.model.consume(self.rows[i].tobytes())
        if before.spi_error and after.spi_error:
            self.ignored += 1
        if after.servo_on and not before.servo_on and self.servo_on_at is None:
            self.servo_on_at = i
        if before.servo_on and not after.servo_on:
            self.servo_off.append(i)
        if after.mode != before.mode or (before.switching_to and after.switching_to is None
                                         and not after.spi_error):
            self.switches.append((i, after.mode))
        if after.spi_error and not before.spi_error:
            self.errors.append((i, after.spi_error_cause or "SPI error"))
        if self.model.applied:
            if not after.servo_on and self.moved_while_off is None and self.at and \
                    self.modes[-1][-1] == after.mode and self.values[-1][-1] != self.raw[i]:
                self.moved_while_off = i
            self._applied(i, i + 1, after.mode)

    def reading(self) -> StreamReading:
        commands = _commands(self.at, self.modes, self.values)
        ids = tuple(sorted({int(x) for x in np.unique(self.rows[~self.faulty, 0] >> 4)}))
        reversals, reversal_count = _reversals(commands)
        hold, target = _hold(commands, self.model.state, self.n)
        return StreamReading(self.n, self.model.state, tuple(self.bad),
                             int(self.faulty.sum()), ids, self.servo_on_at,
                             tuple(self.servo_off[:REPORT_MAX]),
                             tuple(self.switches[:REPORT_MAX]),
                             tuple(self.errors[:REPORT_MAX]), self.ignored,
                             self.moved_while_off, reversals, reversal_count, hold, target,
                             commands)


def _commands(at: list[np.ndarray], modes: list[np.ndarray],
              values: list[np.ndarray]) -> Commands:
    if not at:
        return Commands(np.zeros(0, np.int32), np.zeros(0, np.int8), np.zeros(0, np.uint32))
    return Commands(np.concatenate(at), np.concatenate(modes), np.concatenate(values))


def _fault(row: np.ndarray, index: int) -> str:
    """Why packet `index` fails its own check (the frame's one-line error)."""
    try:
        HOST_FRAMES["raw"].decode(row.tobytes(), block=index)
    except DecodeError as e:
        return str(e)
    return "refused"  # pragma: no cover - packet_faults follows the Frame


def _reversals(commands: Commands) -> tuple[tuple[tuple[int, int, int, int], ...], int]:
    """Direction changes of the position commands applied (a velocity or current has no
    direction to keep: only positions are read)."""
    position = commands.mode == 1
    p = commands.raw[position].view(np.int32)
    at = commands.at[position]
    # the sign of each step, as int8 (a difference of int32 could wrap)
    d = (p[1:] > p[:-1]).view(np.int8) - (p[1:] < p[:-1]).view(np.int8)
    moving = np.flatnonzero(d)
    turns = moving[1:][d[moving[1:]] != d[moving[:-1]]]  # a step against the step before
    examples = []
    for t in turns[:REPORT_MAX]:
        prev = moving[np.searchsorted(moving, t) - 1]
        examples.append((int(at[t + 1]), int(p[prev]), int(p[t]), int(p[t + 1])))
    return tuple(examples), len(turns)


def _hold(commands: Commands, st: DriverState, n: int) -> tuple[int, int | float | None]:
    """The commands at the stream's end holding its last value (servo on, no SPI error,
    in the mode in force, up to the last packet with no gap) and that value."""
    if not len(commands):
        return 0, None
    target = commands.value(len(commands) - 1)
    last = commands.raw[-1]
    if not (st.servo_on and not st.spi_error and st.mode == commands.mode[-1]
            and commands.at[-1] == n - 1):
        return 0, target
    other = np.flatnonzero((commands.raw != last) | (commands.mode != commands.mode[-1]))
    hold = len(commands) - (int(other[-1]) + 1 if len(other) else 0)
    # only the commands of the stream's last packets count: a gap breaks the hold
    gaps = np.flatnonzero(np.diff(commands.at[len(commands) - hold:]) != 1)
    if len(gaps):
        hold = hold - int(gaps[-1]) - 1
    return hold, target
