"""A PPMC-312 slave in ASCII serial mode (manual §12–19): what it answers on the line.

`SerialChip.receive(data)` takes the bytes the master sent (any split: a frame
may arrive a byte at a time) and returns the bytes the chip sends back. The
chip models:
- framing: a frame starts at a control byte (bit 7 set); its length follows
  from the type (a poll is the control byte and a checksum) and, for a command,
  from the command code (`command_size`, every §15–18 command);
- the checksum of every frame, and the error counter the master reads with
  command 4C (framing, overrun and checksum errors);
- init (§15-1); every motion command of `motion.COMMANDS` that starts at once (§16-1…
  §16-11, §15-5), run in emulated time by the model of `command_runs` (serial_motion.py:
  82 timed as `execution.simulate_move` times it; a start refused with the state error
  B0 43 while a motion runs, with no table or inside the window after an init,
  `timing.motion_window`; a speed change with nothing running B0 43; a rate outside the
  table's B0 42, §11-6's 0x20 named in the log; an origin search or return meets /ORG at
  `origin_at`), position read/set (§18-1/2: the 32-bit counter, 0…0xFFFFFFFF,
  wrapping past 0 and past 0xFFFFFFFF, §2-1.6), end status (§18-6),
  error code (§18-10), error count (§18-11), and polls (§19): busy while the
  simulated motion runs, then once the stop report (A0 + end code: 38 its pulses done,
  37 stop, 36 decel stop, 32 /ORG, 39 nothing slower to decelerate along), then ready.
The forms of 80, 81, 87, 88 started at a position or by an event input (8B…8E, 9B…9E,
BB…BE) go into the override buffer (§5-2: 8 deep, FIFO, only its head armed) and take
effect, through the same model, where the counter reaches the position or when the input
fires (`event(n)`, `events_at`): reported B0 21 on the next poll (§19-9); the buffer is
emptied, reported B0 49 (§19-10), when the motion ends first or the model refuses one.
The limit inputs (`limits_at`) are met where the counter reads their position: /FL, /BL
stop at once (33), /FHL, /BHL decelerate at or above 05's speed (34), §7-6; a start the
way one guards from where it is low is refused B0 44 (§19-6).
Documented commands outside that list are answered with the command error
(B0 47, "not modelled"); no part of the chip is faked.

Our readings where the manual is silent (docs/manual-notes.md, "Serial link"):
- a frame with a wrong checksum is answered B0 47 (§13-5 says the chip answers
  a checksum error but lists no code for it; 47 is "an error in the command");
- framing errors in this model are the line faults a byte stream shows: a frame
  cut short by the next control byte, characters outside any frame, a control
  byte with bit 6 set or a slave type. None of them is answered (§13-5);
- the error count is the sum of the three counters, saturating at 0xFFFF;
- error code and error count replies carry the ready control byte (90 + a), as
  §18-10/18-11 print it; the master also accepts a data reply (A0 + a);
- a move inside the window after an init (§7-1: 115 ms linear, 175 ms S-curve) is
  answered with the state error B0 43 (§19-5: a command the chip's state does not
  allow; §2-1.8: the chip enters the normal state, where moves are taken, only once
  the init is processed). The window counts from the init frame's last character.
"""

from __future__ import annotations

import os
import select
import string
import threading
import time
import tty
from collections.abc import Callable, Sequence

from serial.urlhandler import protocol_loop

from ..errors import MotionRefused, StepRampError, require_int
from ..fields import Frame
from .ascii import (
    CONTROL,
    END_CODE_REPLY,
    ERROR_CODE_REPLY,
    ERROR_COUNT_REPLY,
    MAX_ADDRESS,
    POSITION_MODULUS,
    POSITION_REPLY,
    SERIAL_INIT,
    SERIAL_POSITION_READ,
    SERIAL_POSITION_SET,
    SPECIAL_REPLY,
    checksum,
    encode_frame,
)
from .clock import Clock
from .command_runs import SIGNALS, ProgramCommand
from .init_model import init_stage_problem
from .motion import AT, EVENTS, NOW, Command, field_range, read_fields, serial_form
from .serial_motion import (
    OVERRIDE_ABORTED,
    OVERRIDE_DEPTH,
    OVERRIDE_DONE,
    ChipRefusal,
    Override,
    Running,
    rate_problem,
    start_motion,
)
from .table import InitTable
from .timing import Window, motion_window, ms

# (name, mask, value, payload bytes including the code): how long each command's
# frame is, from its code byte alone (manual §15–18). Codes are disjoint (tested).
COMMANDS: tuple[tuple[str, int, int, int], ...] = (
    ("init", 0xF0, 0x00, 8),
    ("in-position setting", 0xCF, 0xC6, 3),
    ("encoder setting", 0xEF, 0xC7, 3),
    ("interlock position setting", 0xFF, 0xC8, 5),
    ("high-speed limit setting", 0xFF, 0x47, 3),
    ("END pin setting", 0xFF, 0xC9, 2),
    ("immediate stop", 0xFF, 0x80, 1),
    ("immediate stop at position", 0xFF, 0x8B, 5),
    ("immediate stop on event 0", 0xFF, 0x9B, 1),
    ("immediate stop on event 1", 0xFF, 0xBB, 1),
    ("decelerate stop", 0xFF, 0x81, 1),
    ("decelerate stop at position", 0xFF, 0x8C, 5),
    ("decelerate stop on event 0", 0xFF, 0x9C, 1),
    ("decelerate stop on event 1", 0xFF, 0xBC, 1),
    ("accel/decel move", 0xDF, 0x83, 7),
    ("constant-speed move", 0xDF, 0x84, 7),
    ("single step", 0xDF, 0x82, 1),
    ("continuous high speed", 0xDF, 0x86, 3),
    ("continuous constant speed", 0xDF, 0x85, 3),
    ("accel speed change", 0xFF, 0x89, 3),
    ("accel speed change at position", 0xFF, 0x8E, 7),
    ("accel speed change on event 0", 0xFF, 0x9E, 3),
    ("accel speed change on event 1", 0xFF, 0xBE, 3),
    ("immediate speed change", 0xFF, 0x88, 3),
    ("immediate speed change at position", 0xFF, 0x8D, 7),
    ("immediate speed change on event 0", 0xFF, 0x9D, 3),
    ("immediate speed change on event 1", 0xFF, 0xBD, 3),
    ("origin search", 0xCF, 0x87, 3),
    ("high-speed origin return", 0xCF, 0x8A, 3),
    ("excitation on", 0xFF, 0xC0, 1),
    ("excitation off", 0xFF, 0xC1, 1),
    ("counter clear", 0xFF, 0xC2, 1),
    ("zero clamp", 0xFF, 0xC3, 1),
    ("alarm clear", 0xFF, 0xC4, 1),
    ("general input", 0xFF, 0x44, 1),
    ("general output", 0xFF, 0x45, 2),
    ("control pin read", 0xFF, 0x46, 1),
    ("mask setting", 0xFF, 0xC5, 2),
    ("position read", 0xDF, 0x42, 1),
    ("position set", 0xDF, 0x43, 5),
    ("interlock", 0xFF, 0x48, 1),
    ("version read", 0xFF, 0x4A, 1),
    ("synchronous monitor", 0xFF, 0x4D, 1),
    ("end status read", 0xFF, 0x40, 1),
    ("event setting", 0xCF, 0x49, 10),
    ("status read", 0xFF, 0x4E, 1),
    ("error code read", 0xFF, 0x41, 1),
    ("error count read", 0xFF, 0x4C, 1),
    ("reset", 0xFF, 0xFF, 1),
)

PARAMETER_ERROR, STATE_ERROR, LIMIT_ERROR, COMMAND_ERROR = 0x42, 0x43, 0x44, 0x47
END_IMMEDIATE_STOP, END_ORIGIN = 0x37, 0x32
COUNT_MAX = 0xFFFF
_HEX = frozenset(string.hexdigits.encode())


def command_of(code: int) -> tuple[str, int] | None:
    """(name, payload bytes) of the command whose code byte is `code`, or None."""
    for name, mask, value, size in COMMANDS:
        if code & mask == value:
            return name, size
    return None


class SerialChip:
    """One PPMC-312 slave at `address` (0–15). `clock_s` gives the time in seconds
    (time.monotonic by default; tests pass their own). `origin_at`: the position counter
    value where /ORG is low, met by an origin search or return (None: nowhere, so they
    run until stopped). `events_at`: (n, counter value) where the event input /EVTn
    fires as a motion passes it (`event(n)` fires it at once). `limits_at`: (signal, counter
    value) where the limit input (`command_runs.SIGNALS`: FL, BL, FHL, BHL) is low: a motion
    the way it guards meets it there (/FL, /BL stop at once; /FHL, /BHL decelerate at or
    above 05's speed, §7-6), and a start that way from there is refused B0 44 (§19-6)."""

    def __init__(self, address: int, *, clock_s: Callable[[], float] = time.monotonic,
                 extck_hz: float | None = None, origin_at: int | None = None,
                 events_at: Sequence[tuple[int, int]] = (),
                 limits_at: Sequence[tuple[str, int]] = ()) -> None:
        self.address = require_int("address", address, 0, MAX_ADDRESS)
        self.origin_at = None if origin_at is None else \
            require_int("origin_at", origin_at, 0, POSITION_MODULUS - 1)
        self.events_at = tuple((require_int("event input", n, 0, 1),
                                require_int("event position", at, 0, POSITION_MODULUS - 1))
                               for n, at in events_at)
        for signal, _ in limits_at:
            if signal not in SIGNALS:
                raise StepRampError(f"limit input {signal!r} is not one of "
                                    f"{', '.join(SIGNALS)}")
        self.limits_at = tuple((signal, require_int("limit position", at, 0,
                                                    POSITION_MODULUS - 1))
                               for signal, at in limits_at)
        self._met: set[int] = set()   # the limits the running motion has met
        self._overrides: list[Override] = []   # the override buffer (§5-2), head first
        self._notices: list[int] = []   # special replies (§19-9, §19-10) the polls carry
        self.limit_rate: int | None = None  # the high-speed limit's rate (05), once set
        self._now = clock_s
        self._extck_hz = extck_hz
        self.table: InitTable | None = None
        self.framing_errors = 0
        self.overrun_errors = 0
        self.checksum_errors = 0
        self.error_code = 0x00        # §18-10 register: the last refusal's code
        self.end_code = 0x00          # §18-6: why the last pulse output stopped
        self.log: list[str] = []      # one line per frame handled, for a console
        self._position = 0
        self._move: Running | None = None
        # The last init taken: when (clock_s time) and the window that followed it.
        self._init_at: tuple[float, Window] | None = None
        self._report: int | None = None   # the stop report the next poll carries
        self._frame: bytearray | None = None
        self._need = 0                # characters still due after the control byte
        self._skip = False            # inside a frame for another slave (or a dead one)
        self._stray = False           # inside a run of characters outside any frame

    # --- state ---------------------------------------------------------------------
    @property
    def error_count(self) -> int:
        return min(COUNT_MAX, self.framing_errors + self.overrun_errors + self.checksum_errors)

    @property
    def busy(self) -> bool:
        self._settle()
        return self._move is not None

    @property
    def position(self) -> int:
        """The pulse position counter, 0…0xFFFFFFFF: 32 bits that wrap (§2-1.6), so a CCW
        move past 0 reads 0xFFFFFFFF next."""
        self._settle()
        if self._move is None:
            return self._position
        return self._move.counter(self._now())

    def _settle(self) -> None:
        """Meet what the motion has reached by now, in the order it reached them (/ORG, the
        override buffer's head at its position or event); finish a motion whose last pulse
        is out: the counter holds, the report waits."""
        move, now = self._move, self._now()
        if move is None:
            return
        while (hit := self._next_hit(move, now)) is not None:
            hit[1](hit[0])
            move.refresh()
        if move.settle(now):
            self._position = move.counter(now)
            self._move = None
            self.end_code = self._report = move.end_code
            self._drop_overrides("the motion ended first")

    def _next_hit(self, move: Running, now: float) -> tuple[int, Callable[[int], None]] | None:
        """(pulses, what happens there) of the first thing the motion has met by `now`."""
        out, _ = move.output(now)
        end = move.end
        hits: list[tuple[int, Callable[[int], None]]] = []
        if move.origin_at is not None and not move.live.stopping:
            hits.append((move.origin_at, lambda at: self._meet_origin(move, at)))
        for i, (signal, pos) in enumerate(self.limits_at):
            if i not in self._met and SIGNALS[signal][0] == (move.sign < 0):
                hits.append((move.reach(pos), self._limit_hit(move, i, signal)))
        head = self._overrides[0] if self._overrides else None
        if head is not None:
            if head.start == AT:
                assert head.position is not None
                spots = [head.position]
            else:
                spots = [pos for n, pos in self.events_at if tuple(EVENTS)[n] == head.start]
            fire: Callable[[int], None] = lambda at: self._fire(move, head, at)  # noqa: E731
            hits += [(at, fire) for at in map(move.reach, spots) if at >= head.armed_from]
        hits = [h for h in hits if h[0] <= out and (end is None or h[0] < end)]
        return min(hits, key=lambda h: h[0]) if hits else None

    def _limit_hit(self, move: Running, i: int, signal: str) -> Callable[[int], None]:
        return lambda at: self._meet_limit(move, i, signal, at)

    def _meet_limit(self, move: Running, i: int, signal: str, at: int) -> None:
        """Limit input `signal` met after `at` pulses (§7-6, `command_runs`' model)."""
        self._met.add(i)
        at = max(at, 1)
        if move.live.stopping:
            if SIGNALS[signal][1]:  # a stop is under way: nothing to decelerate
                self.log.append(f"/{signal} at pulse {at}: ignored, the motion is stopping")
                return
            move.live.halt(at, "STL")
            notes: list[str] = []
        else:
            try:
                notes = move.live.issue(ProgramCommand(signal, at=at))
            except MotionRefused as e:  # the way back of 11: not the way it guards
                self.log.append(f"/{signal} at pulse {at}: ignored: {e}")
                return
        cause = f": {move.live.cause}" if move.live.stopping else ""
        self.log.append("; ".join([f"/{signal} at pulse {at}{cause}", *notes]))

    @staticmethod
    def _meet_origin(move: Running, at: int) -> None:
        move.live.origin(at)
        move.origin_at = None

    def _fire(self, move: Running, entry: Override, at: int) -> None:
        """The override buffer's head takes effect after `at` pulses (§5-2): reported 21 on
        the next poll (§19-9); one the model refuses there aborts the buffer (§19-10)."""
        self._overrides.pop(0)
        at = max(at, 1)  # before the first pulse: with it
        name = entry.command.name
        notes: list[str] = []
        if name == "stop" and move.live.stopping:
            move.live.halt(at)
        elif name == "decel-stop" and move.live.stopping:
            notes = ["ignored, the motion is already stopping (§8-2)"]
        else:
            try:
                notes = move.live.issue(ProgramCommand(name, rate=entry.rate, at=at))
            except MotionRefused as e:
                self._drop_overrides(f"{entry.what} at pulse {at}: {e}", entry)
                return
        move.refresh()
        if self._overrides:
            self._overrides[0].armed_from = at
        self._notices.append(OVERRIDE_DONE)
        self.log.append("; ".join([f"override: {entry.what} at pulse {at}", *notes]))

    def _drop_overrides(self, why: str, failed: Override | None = None) -> None:
        """The override buffer emptied (§5-2 「登録された命令は全て削除されます」), reported
        49 on the next poll (§19-10); nothing when it holds nothing."""
        if failed is None and not self._overrides:
            return
        count = len(self._overrides) + (failed is not None)
        self._overrides.clear()
        self._notices.append(OVERRIDE_ABORTED)
        self.log.append(f"override aborted ({count} command(s) dropped): {why}")

    def event(self, n: int) -> None:
        """The event input /EVTn (0, 1) fires now: the override buffer's head takes effect
        when it waits for it; nothing happens otherwise (§5-2: the head only is armed)."""
        key = tuple(EVENTS)[require_int("event input", n, 0, 1)]
        self._settle()
        move, head = self._move, self._overrides[0] if self._overrides else None
        if move is None or head is None or head.start != key:
            self.log.append(f"/EVT{n}: nothing waits for it")
            return
        out, _ = move.output(self._now())
        self._fire(move, head, out)
        self._settle()

    # --- the byte stream ---------------------------------------------------------------
    def receive(self, data: bytes) -> bytes:
        """Take bytes from the line; return the chip's replies to every frame they complete."""
        out = bytearray()
        for byte in bytes(data):
            out += self._byte(byte)
        return bytes(out)

    def _byte(self, byte: int) -> bytes:
        if byte & 0x80:
            if self._frame is not None:
                self._framing("a frame cut short by the next control byte")
            self._frame, self._skip, self._stray = None, False, False
            if byte & 0x40:
                self._framing(f"0x{byte:02X} is not a control byte (bit 6 set)")
                self._skip = True
                return b""
            fields = CONTROL.decode(bytes([byte]))
            if fields["address"] != self.address:
                self._skip = True
                return b""
            if fields["type"] >= 2:
                self._framing(f"control byte 0x{byte:02X} is a slave's type")
                self._skip = True
                return b""
            self._frame = bytearray([byte])
            self._need = 2 if fields["type"] == 0 else 4  # poll: checksum; command: + code
            return b""
        if self._frame is None:
            if not self._skip and not self._stray:
                self._framing("characters outside any frame")
                self._stray = True
            return b""
        self._frame.append(byte)
        self._need -= 1
        frame = self._frame
        if len(frame) == 3 and frame[0] & 0x30 == 0x10:
            # The command code is in: the chip now knows the frame's length.
            code = int(frame[1:3], 16) if _HEX.issuperset(frame[1:3]) else None
            known = None if code is None else command_of(code)
            if known is None:
                self._frame, self._skip = None, True
                if code is None:  # damaged on the line: counted like a checksum error
                    self.checksum_errors += 1
                    return self._refuse(COMMAND_ERROR, "a command code that is not hex",
                                        register=False)
                return self._refuse(COMMAND_ERROR, f"undefined command 0x{code:02X}")
            self._need = 2 * (known[1] - 1) + 2  # the parameters' characters and the checksum
        if self._need > 0:
            return b""
        self._frame = None
        return self._complete(bytes(frame))

    def _framing(self, why: str) -> None:
        self.framing_errors += 1
        self.log.append(f"framing error: {why}")

    # --- whole frames ---------------------------------------------------------------------
    def _complete(self, frame: bytes) -> bytes:
        chars, sent = frame[1:-2], frame[-2:]
        if not _HEX.issuperset(frame[1:]) or int(sent, 16) != checksum(frame[0], chars):
            self.checksum_errors += 1
            return self._refuse(COMMAND_ERROR, "checksum error", register=False)
        payload = bytes.fromhex(chars.decode("ascii"))
        if frame[0] & 0x30 == 0:
            return self._poll()
        return self._command(payload)

    def _poll(self) -> bytes:
        self._settle()
        if self._notices:  # an override's report first (§19-9, §19-10), oldest first
            code = self._notices.pop(0)
            self.log.append(f"poll: report 0x{code:02X}")
            return self._reply("special", SPECIAL_REPLY, code=code)
        if self._move is not None:
            self.log.append("poll: busy")
            return encode_frame("busy", self.address, b"")
        if self._report is not None:
            code, self._report = self._report, None
            self.log.append(f"poll: stop report 0x{code:02X}")
            return self._reply("data", END_CODE_REPLY, end_code=code)
        self.log.append("poll: ready")
        return encode_frame("ready", self.address, b"")

    def _command(self, payload: bytes) -> bytes:
        code = payload[0]
        found = serial_form(payload)
        if found is not None and found[1] == NOW and found[0].name != "stop":
            return self._motion(found[0], payload)
        if found is not None and found[1] != NOW:
            return self._register(found[0], found[1], payload)
        name, _ = command_of(code) or ("?", 0)
        handler = _HANDLERS.get(name)
        if handler is None:
            return self._refuse(COMMAND_ERROR, f"{name} (0x{code:02X}) is not modelled")
        return handler(self, payload)

    def _ready(self, what: str) -> bytes:
        self.log.append(what)
        return encode_frame("ready", self.address, b"")

    def _reply(self, kind: str, frame: Frame, **values: int) -> bytes:
        return encode_frame(kind, self.address, frame.encode(**values))

    def _refuse(self, code: int, why: str, *, register: bool = True) -> bytes:
        if register:  # line damage is counted, not registered (§18-10 vs §18-11)
            self.error_code = code
        self.log.append(f"refused 0x{code:02X}: {why}")
        return self._reply("special", SPECIAL_REPLY, code=code)

    # --- the modelled commands -----------------------------------------------------------
    def _init(self, payload: bytes) -> bytes:
        if self.busy:
            return self._refuse(STATE_ERROR, "init during pulse output")
        try:
            f = SERIAL_INIT.decode(payload)
            table = InitTable(Clock.from_code(f["clk"], self._extck_hz),
                              "s_curve" if f["fo"] else "linear", f["start_rate"],
                              f["high_rate"], f["accel_pulses"])
        except StepRampError as e:
            self.table = None
            return self._refuse(PARAMETER_ERROR, f"init: {e}")
        problem = init_stage_problem(table)
        if problem is not None:
            self.table = None  # §7-1: a refused table command destroys the table
            return self._refuse(PARAMETER_ERROR, f"init: {problem[1]}")
        self.table = table
        self.limit_rate = None  # §7-6: the table's high rate after an init
        self._init_at = (self._now(), motion_window(table))
        return self._ready(f"init: {table.shape}, start {table.start_rate}, high "
                           f"{table.high_rate}, {table.accel_pulses} pulses")

    def _motion(self, command: Command, payload: bytes) -> bytes:
        """Every motion command that starts at once (§16, §15-5), but 80 (`_stop`)."""
        fields = read_fields(command.serial[NOW], payload)
        try:
            if command.name == "high-speed-limit":
                return self._limit(command, fields)
            if command.name in ("decel-stop", "change-speed", "set-speed"):
                return self._during(command, fields)
            return self._start(command, fields)
        except ChipRefusal as refusal:
            detail = "" if refusal.detail is None else f" (§11-6 0x{refusal.detail:02X})"
            return self._refuse(refusal.code, f"{refusal}{detail}")

    def _start(self, command: Command, fields: dict[str, int]) -> bytes:
        what = "move" if command.name == "accel" else command.label  # 82: the link's word
        if self.busy:
            raise ChipRefusal(STATE_ERROR, f"{what} during pulse output")
        if self.table is None:
            raise ChipRefusal(STATE_ERROR, f"{what} with no table (send init first)")
        early = self._too_early()
        if early is not None:
            raise ChipRefusal(STATE_ERROR, f"{what} {early}")
        ccw = bool(fields.get("dir"))
        for signal, pos in self.limits_at:
            if pos == self._position and SIGNALS[signal][0] == ccw:
                raise ChipRefusal(LIMIT_ERROR, f"{what}: /{signal} is low at {pos}, the way "
                                               "it runs (§19-6)")
        try:
            move = start_motion(command, fields, self.table, now_s=self._now(),
                                position=self._position, origin_at=self.origin_at,
                                limit_rate=self.limit_rate)
        except StepRampError as e:  # 82's high rate, as `simulate_move` checks it
            raise ChipRefusal(PARAMETER_ERROR, f"{what}: {e}", 0x20) from None
        way = "CCW" if fields.get("dir") else "CW"
        if move is None:  # §8-10: /ORG is low where it starts: found before a pulse
            self.end_code = self._report = END_ORIGIN
            return self._ready(f"{what}: {way}, on /ORG at {self._position}: stopped")
        self._move, self._report, self._met = move, None, set()
        pulses = f"{fields['pulses']} pulses " if "pulses" in fields else ""
        rate = f", rate {fields[command.rate_field]}" if command.rate is not None else ""
        return self._ready(f"{what}: {pulses}{way}{rate}")

    def _during(self, command: Command, fields: dict[str, int]) -> bytes:
        """81, 87, 88 during a motion; a decel stop at rest stops nothing (as 80)."""
        what, move = command.label, self._move if self.busy else None
        rate = fields.get("rate", 0)
        if move is None:
            if command.name == "decel-stop":
                return self._ready(f"{what}: no pulse output")
            raise ChipRefusal(STATE_ERROR, f"{what} with no pulse output (§8-8: it changes "
                                           "the rate of the pulses being output)")
        if command.rate is not None:
            assert self.table is not None
            why = rate_problem(command, rate, self.table)
            if why is not None:
                raise ChipRefusal(PARAMETER_ERROR, f"{what}: {why}", 0x20)
        out, _ = move.output(self._now())
        at, end = max(out, 1), move.end  # before the first pulse: with it
        decel = command.name == "decel-stop"
        if end is not None and at >= end:
            if decel:
                return self._ready(f"{what}: ignored, the motion ends with pulse {end}")
            raise ChipRefusal(STATE_ERROR, f"{what}: the motion ends with pulse {end}")
        if decel and move.live.stopping:
            return self._ready(f"{what}: ignored, the motion is already stopping (§8-2)")
        try:
            notes = move.live.issue(ProgramCommand(command.name, rate=rate, at=at))
        except MotionRefused as e:
            raise ChipRefusal(STATE_ERROR, f"{what} at pulse {at}: {e}") from None
        move.refresh()
        return self._ready("; ".join([f"{what}: at pulse {at}", *notes]))

    def _register(self, command: Command, start: str, payload: bytes) -> bytes:
        """A serial form of 80, 81, 87, 88 started at a position or by an event: into the
        override buffer (§5-2), answered ready (命令受付レスポンス, §16) once taken."""
        frame = command.serial[start]
        fields = read_fields(frame, payload)
        entry = Override(command, start, fields.get("rate", 0), fields.get("position"))
        what = entry.what
        try:
            if not self.busy:
                raise ChipRefusal(STATE_ERROR, f"{what} with no pulse output (it acts on the "
                                                "motion under way)")
            assert self._move is not None and self.table is not None
            if command.rate is not None:
                why = rate_problem(command, entry.rate, self.table)
                if why is not None:
                    raise ChipRefusal(PARAMETER_ERROR, f"{what}: {why}", 0x20)
            if entry.position is not None:
                lo, _ = field_range(frame, "position")
                if entry.position < lo:
                    raise ChipRefusal(PARAMETER_ERROR, f"{what}: position {entry.position} is "
                                      f"below {command.serial_section}'s 0x{lo:X}")
            if len(self._overrides) >= OVERRIDE_DEPTH:
                raise ChipRefusal(STATE_ERROR, f"{what}: the override buffer holds "
                                               f"{OVERRIDE_DEPTH} commands (§5-2)")
        except ChipRefusal as refusal:
            detail = "" if refusal.detail is None else f" (§11-6 0x{refusal.detail:02X})"
            return self._refuse(refusal.code, f"{refusal}{detail}")
        if not self._overrides:
            entry.armed_from, _ = self._move.output(self._now())
        self._overrides.append(entry)
        return self._ready(f"{what}: registered ({len(self._overrides)} in the override "
                           "buffer)")

    def _limit(self, command: Command, fields: dict[str, int]) -> bytes:
        """05 (§15-5, §7-6): taken at rest only (as every setting); the speed from which
        /FHL, /BHL decelerate (`limits_at`)."""
        if self.busy:
            raise ChipRefusal(STATE_ERROR, f"{command.label} during pulse output")
        why = rate_problem(command, fields["rate"], self.table)  # its figure's range only
        if why is not None:
            raise ChipRefusal(PARAMETER_ERROR, f"{command.label}: {why}", 0x20)
        self.limit_rate = fields["rate"]
        return self._ready(f"{command.label}: rate {self.limit_rate}")

    def _too_early(self) -> str | None:
        """Why a motion command now comes too early (inside the window after the last
        init), or None when the chip takes it."""
        if self._init_at is None:
            return None
        since, window = self._init_at
        now = self._now()
        if now >= since + window.seconds:
            return None
        return f"{ms(now - since)} ms after the init: {window.why}"

    def _stop(self, payload: bytes) -> bytes:
        if self.busy:
            self._position = self.position
            self._move = None
            self.end_code = self._report = END_IMMEDIATE_STOP
            self._drop_overrides("stopped (80) first")
            return self._ready(f"stop: held at {self._position}")
        return self._ready("stop: no pulse output")

    def _position_read(self, payload: bytes) -> bytes:
        if SERIAL_POSITION_READ.decode(payload)["encoder"]:
            return self._refuse(COMMAND_ERROR, "encoder position (no encoder modelled)")
        position = self.position
        self.log.append(f"position: {position}")
        return self._reply("data", POSITION_REPLY, counter=0, position=position)

    def _position_set(self, payload: bytes) -> bytes:
        f = SERIAL_POSITION_SET.decode(payload)
        if f["encoder"]:
            return self._refuse(COMMAND_ERROR, "encoder position (no encoder modelled)")
        if self.busy:
            return self._refuse(STATE_ERROR, "position set during pulse output")
        self._position = f["position"]
        return self._ready(f"position set: {self._position}")

    def _end_status(self, payload: bytes) -> bytes:
        self._settle()
        return self._reply("data", END_CODE_REPLY, end_code=self.end_code)

    def _error_code(self, payload: bytes) -> bytes:
        return self._reply("ready", ERROR_CODE_REPLY, error_code=self.error_code)

    def _error_count(self, payload: bytes) -> bytes:
        return self._reply("ready", ERROR_COUNT_REPLY, error_count=self.error_count)


_HANDLERS: dict[str, Callable[[SerialChip, bytes], bytes]] = {
    "init": SerialChip._init,
    "immediate stop": SerialChip._stop,
    "position read": SerialChip._position_read,
    "position set": SerialChip._position_set,
    "end status read": SerialChip._end_status,
    "error code read": SerialChip._error_code,
    "error count read": SerialChip._error_count,
}


# --- transports: the chip on a line --------------------------------------------------------
class LoopSerial(protocol_loop.Serial):  # type: ignore[misc]
    """pyserial's in-process `loop://` port with `chip` at the far end: what the
    master writes goes to the chip; the chip's replies are what it reads."""

    def __init__(self, chip: SerialChip, *, timeout: float | None = 1.0) -> None:
        self.chip = chip
        super().__init__("loop://", timeout=timeout)

    def write(self, data: bytes) -> int:
        replies = self.chip.receive(bytes(data))
        if replies:
            super().write(replies)
        return len(data)


class PtyServer:
    """`chip` served on a pseudo-terminal: open `path` as a serial port to talk to it.

    The chip answers from a thread; `stop()` (or leaving the `with` block) ends it.
    `link` makes a symbolic link to the terminal under a stable name, removed on stop.
    """

    POLL_S = 0.05

    def __init__(self, chip: SerialChip, *, link: str | None = None,
                 on_log: Callable[[str], None] | None = None) -> None:
        self.chip = chip
        self.on_log = on_log
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no line editing: bytes pass as sent
        self.path = os.ttyname(self._slave)
        self.link = link
        if link is not None:
            if os.path.lexists(link) and not os.path.islink(link):
                self._close_fds()
                raise StepRampError(f"{link}: exists and is not a symbolic link; not replaced")
            if os.path.lexists(link):
                os.unlink(link)
            os.symlink(self.path, link)
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self.serve, name="ppmc312-pty", daemon=True)

    def start(self) -> PtyServer:
        self._thread.start()
        return self

    def serve(self) -> None:
        """Answer the line until `stop()`; runs in the caller's thread."""
        while not self._stopping.is_set():
            ready, _, _ = select.select([self._master], [], [], self.POLL_S)
            if not ready:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:  # no client has the terminal open (EIO): wait for one
                time.sleep(self.POLL_S)
                continue
            seen = len(self.chip.log)
            replies = self.chip.receive(data)
            if replies:
                os.write(self._master, replies)
            if self.on_log is not None:
                for line in self.chip.log[seen:]:
                    self.on_log(line)

    def request_stop(self) -> None:
        """Make `serve()` return (safe from a signal handler)."""
        self._stopping.set()

    def stop(self) -> None:
        self._stopping.set()
        if self._thread.is_alive():
            self._thread.join()
        if self.link is not None and os.path.islink(self.link):
            os.unlink(self.link)
        self._close_fds()

    def _close_fds(self) -> None:
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass

    def __enter__(self) -> PtyServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
