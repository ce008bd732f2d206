"""A master for PPMC-312 slaves in ASCII serial mode (manual §13–14, SPEC §1.7).

`Link(port, address)` drives one slave the way §14 asks: one frame in flight,
the reply read before the next frame goes out. Every reply is checked before
it is believed: its control byte (bit 7 set, a slave's type, this slave's
address), its length for the command, its hex characters and its checksum.

Faults, and what the link does about them:
- no reply within `timeout_s` (a frame lost or cut on the line: §13-5 says the
  chip answers nothing then), or a garbled reply: resend, at most `retries` times;
- the chip's command error B0 47 (its answer to a frame with a bad checksum;
  the link only sends well-formed frames): resend, at most `retries` times;
- a move whose reply is lost may still have started: before resending, the link
  polls and reads the position, and resends only when the move did not start
  (never a double move);
- a poll whose stop report was lost: the link remembers that a move ran and,
  when a later poll says ready, reads the end status (§18-6) instead;
- the chip's refusals (B0 42/43/44/46) raise `ChipRefused` at once; replies
  no table knows raise `UnknownReply`; the retries used up raise `LinkTimeout`
  or `GarbledReply`. Every message is one line.

Replies heard: `on_reply` is told of every reply frame the link takes off the line
(`Exchange`: what it was doing, the command the reply answers as `replies.REPLY_TO`
names it, the frame sent, the reply), once the frame passed the checks above and before
the link acts on it, so `stepramp link -v` can print each through the one decoder
(`replies.decode_reply`).

Timing: the chip takes a motion command only some time after an init (manual §7-1:
115 ms linear, 175 ms S-curve; `timing.motion_window`). The link remembers when it
may send one and, before the next move, sleeps out what is left of that window
(`on_note` hears why); `wait_until_motion_accepted()` does it at once, for a caller
about to hand the line over (`stepramp link init` ends so). A stop is never delayed.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Protocol

from ..errors import (
    ChipRefused,
    DecodeError,
    FieldChoiceError,
    FieldRangeError,
    GarbledReply,
    LinkError,
    LinkTimeout,
    UnknownReply,
    require_int,
)
from ..fields import Frame
from .ascii import (
    CONTROL,
    END_CODE_REPLY,
    END_CODES,
    ERROR_CODE_REPLY,
    ERROR_CODES,
    ERROR_COUNT_REPLY,
    MAX_ADDRESS,
    POSITION_REPLY,
    SERIAL_END_STATUS_READ,
    SERIAL_ERROR_CODE_READ,
    SERIAL_ERROR_COUNT_READ,
    SERIAL_POSITION_READ,
    SERIAL_STOP,
    SPECIAL_REPLIES,
    AsciiFrame,
    decode_frame,
    encode_frame,
    encode_serial_init,
    encode_serial_move,
)
from .command_runs import STARTS  # the commands that start pulse output
from .motion import COMMANDS, command_named, encode_command
from .table import FreeCurveTable, InitTable
from .timing import Window, motion_window, ms

BAUD_RATES = (19_200, 38_400, 83_333)  # §13 and SPEC §1.7 (8N1)
COMMAND_ERROR = 0x47
# Reply kinds each exchange accepts, with the payload bytes each carries.
ACK = {"ready": 0, "special": 1}
POLL = {"busy": 0, "ready": 0, "data": 1, "special": 1}
# §18-10/18-11 print the ready control byte on these data replies; accept both.
ERROR_CODE = {"ready": 1, "data": 1, "special": 1}
ERROR_COUNT = {"ready": 2, "data": 2, "special": 1}
POSITION = {"data": 5, "special": 1}
END_STATUS = {"data": 1, "special": 1}
# What each exchange's reply answers, as replies.REPLY_TO names it (a test holds these to
# its keys): a data reply carries no code, so its reader needs the command.
REPLY_TO = {"init": "command", "move": "command", "stop": "command", "poll": "poll",
            "position": "position", "end status": "end-status", "error count": "error-count",
            "error code": "error-code", **{name: "command" for name in COMMANDS}}


class SerialPort(Protocol):
    """What the link needs of a pyserial port (pyserial's `Serial` and URL ports)."""

    timeout: float | None

    def read(self, size: int = 1) -> bytes: ...
    def write(self, data: bytes) -> int | None: ...
    def reset_input_buffer(self) -> None: ...
    def close(self) -> None: ...


@dataclass(frozen=True)
class PollReply:
    """A poll's answer: `busy`, `ready`, `stopped` (a stop report, `code` = end code)
    or `special` (a state report, `code` = the §19 code)."""

    state: str
    code: int | None = None
    text: str = ""

    def __str__(self) -> str:
        if self.code is None:
            return self.state
        return f"{self.state}: {self.text} (0x{self.code:02X})"


@dataclass(frozen=True)
class Exchange:
    """A reply the link took (for `on_reply`): `what` the link was doing (a `REPLY_TO`
    key), `reply_to` the command it answers (a `replies.REPLY_TO` key), the frame `sent`,
    the `reply` frame as it came (control byte, ASCII hex, checksum) and the `attempt`
    (0, then each resend)."""

    what: str
    reply_to: str
    sent: bytes
    reply: bytes
    attempt: int


@dataclass(frozen=True)
class ErrorReport:
    """The §18-11 error count (framing + overrun + checksum errors) and the §18-10 code."""

    error_count: int
    error_code: int

    @property
    def error_text(self) -> str:
        return ERROR_CODES.get(self.error_code, "unknown error code")


class _Failed(Exception):
    """One attempt failed; `kind` says how (timeout, garbled, refused-47)."""

    def __init__(self, kind: str, why: str) -> None:
        super().__init__(why)
        self.kind = kind


class Link:
    """One PPMC-312 slave at `address` on `port` (a device path, a pyserial URL such as
    `loop://`, or an open pyserial-like port object).

    `timeout_s` bounds the wait for each reply; `retries` bounds the resends of one
    command. `stats` counts attempts, resends, timeouts and garbled replies.
    `clock_s` and `sleep_s` time the wait after an init (tests pass their own; reply
    timeouts always run on the port's real time); `on_note` is told, in one line,
    whenever the link waits for the chip; `on_reply` of every reply it takes (`Exchange`).
    """

    def __init__(self, port: str | SerialPort, address: int, *, baud: int = 19_200,
                 timeout_s: float = 0.2, retries: int = 3,
                 clock_s: Callable[[], float] = time.monotonic,
                 sleep_s: Callable[[float], None] = time.sleep,
                 on_note: Callable[[str], None] | None = None,
                 on_reply: Callable[[Exchange], None] | None = None) -> None:
        self.address = require_int("address", address, 0, MAX_ADDRESS)
        if isinstance(timeout_s, bool) or not (isinstance(timeout_s, int | float)
                                               and 0.001 <= timeout_s <= 60):
            raise FieldRangeError("timeout_s", timeout_s, 0.001, 60)
        retries = require_int("retries", retries, 0, 100)
        self.timeout_s = float(timeout_s)
        self.retries = retries
        self.stats = {"attempts": 0, "resends": 0, "timeouts": 0, "garbled": 0}
        self._owns_port = isinstance(port, str)
        self._port: SerialPort = _open(port, baud, self.timeout_s) if isinstance(port, str) \
            else port
        self._move_running = False  # a move was accepted and its stop not yet reported
        self._clock, self._sleep, self._on_note = clock_s, sleep_s, on_note
        self._on_reply = on_reply
        # After an init: when (clock_s time) the chip takes motion commands, and why.
        self._motion_at: tuple[float, Window] | None = None

    # --- lifetime ------------------------------------------------------------------------
    def close(self) -> None:
        if self._owns_port:
            self._port.close()

    def __enter__(self) -> Link:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # --- the commands ----------------------------------------------------------------------
    def init(self, table: InitTable) -> None:
        """Send the §15-1 init command; the serial form has no free curve (UnsupportedError)."""
        if isinstance(table, FreeCurveTable):
            from ..errors import UnsupportedError
            raise UnsupportedError("the free-curve command has no serial form (manual §15): "
                                   "upload free curves over the parallel bus; the serial "
                                   "link sends init tables")
        window = motion_window(table)
        try:
            self._command(encode_serial_init(table, self.address), "init")
        finally:
            # Counted from the last reply (or timeout), which follows the chip's receipt
            # of any init it took: never too early. Kept when the init failed too: the
            # chip may have taken a frame whose reply was lost.
            self._motion_at = (self._clock() + window.seconds, window)

    def wait_until_motion_accepted(self) -> None:
        """Sleep out what is left of the window after the last init (if any): then the
        chip accepts motion commands (§7-1). `move` calls it; so may a caller."""
        if self._motion_at is None:
            return
        at, window = self._motion_at
        self._motion_at = None
        left = at - self._clock()
        if left > 0:
            if self._on_note is not None:
                self._on_note(f"{window.why}: waiting {ms(left)} ms")
            self._sleep(left)

    def move(self, pulses: int, *, ccw: bool = False, high_rate: int = 0) -> None:
        """Start the §16-3 accel/decel move of `pulses` pulses (high_rate 0 = the table's)."""
        frame = encode_serial_move(self.address, pulses, ccw=ccw, high_rate=high_rate)
        before = self.position()
        self.wait_until_motion_accepted()
        self._command(frame, "move", lost=lambda: self._move_started(before))
        self._move_running = True

    def motion(self, name: str, **params: Any) -> None:
        """Send the motion command `name` of `motion.COMMANDS` with `params` (its §16 frame:
        with `override_at` or `on`, the form the chip registers in its override buffer, whose
        effect a later poll reports, B0 21 executed or B0 49 aborted, §19-9/§19-10).
        A start waits out the window after an init and, its reply lost, is resent only
        when it did not start (as `move`); a stop or a speed change is never delayed and
        resent as it is (taking it twice does what taking it once does)."""
        command = command_named(name)
        frame = encode_command(command.name, to="ascii", address=self.address, **params)
        if params.get("override_at") is not None or params.get("on") is not None:
            # Registered twice it would take effect twice, and the chip tells no registration
            # apart: a lost reply is not resent (`_registration_lost`).
            self._command(frame, command.name, lost=lambda: self._registration_lost(command.name))
            return
        if command.name not in STARTS:
            self._command(frame, command.name)
            return
        before = self.position()
        self.wait_until_motion_accepted()
        self._command(frame, command.name, lost=lambda: self._move_started(before))
        self._move_running = True

    def stop(self) -> None:
        """Stop pulse output at once (§16-1)."""
        self._command(encode_frame("command", self.address, SERIAL_STOP.encode()), "stop")

    def poll(self) -> PollReply:
        """Busy, ready, a stop report or a state report (§13-2, §19)."""
        reply = self._exchange(encode_frame("poll", self.address, b""), POLL, "poll")
        if reply.kind == "busy":
            return PollReply("busy")
        if reply.kind == "data":
            self._move_running = False
            return _stopped(_field(END_CODE_REPLY, reply, "end_code"))
        if reply.kind == "special":  # a state report (§15-2…15-4, §19)
            code = reply.payload[0]
            return PollReply("special", code, _special_text(self, "poll", code))
        if self._move_running:
            # The stop report was lost on the line (its poll was resent): the end
            # status register still says why pulse output stopped.
            self._move_running = False
            return _stopped(self.end_status())
        return PollReply("ready")

    def position(self) -> int:
        """The pulse position counter (§18-1): 0…0xFFFFFFFF, the 32-bit counter (§2-1.6), so
        a CCW move past 0 reads 0xFFFFFFFF, not −1."""
        frame = encode_frame("command", self.address, SERIAL_POSITION_READ.encode(encoder=0))
        reply = self._data(frame, POSITION, "position")
        fields = POSITION_REPLY.decode(reply.payload)
        if fields["counter"] != 0:
            what = ("the encoder position (01)" if fields["counter"] == 1
                    else f"counter 0x{fields['counter']:02X}, none of the manual's (00, 01)")
            raise GarbledReply(f"slave {self.address}: position: the reply is for {what}, "
                               "the pulse position (00) was asked")
        return int(fields["position"])

    def end_status(self) -> int:
        """Why pulse output last stopped (§18-6): an `END_CODES` key."""
        frame = encode_frame("command", self.address, SERIAL_END_STATUS_READ.encode())
        return _field(END_CODE_REPLY, self._data(frame, END_STATUS, "end status"), "end_code")

    def errors(self) -> ErrorReport:
        """The chip's line error count (§18-11) and its last error code (§18-10)."""
        count = _field(ERROR_COUNT_REPLY, self._data(encode_frame(
            "command", self.address, SERIAL_ERROR_COUNT_READ.encode()), ERROR_COUNT,
            "error count"), "error_count")
        code = _field(ERROR_CODE_REPLY, self._data(encode_frame(
            "command", self.address, SERIAL_ERROR_CODE_READ.encode()), ERROR_CODE,
            "error code"), "error_code")
        return ErrorReport(count, code)

    # --- exchanges --------------------------------------------------------------------------
    def _command(self, frame: bytes, what: str, lost: Any = None) -> None:
        reply = self._exchange(frame, ACK, what, lost=lost)
        if reply is not None and reply.kind == "special":
            raise self._refused(what, reply.payload[0])

    def _data(self, frame: bytes, accepts: dict[str, int], what: str) -> AsciiFrame:
        reply = self._exchange(frame, accepts, what)
        if reply.kind == "special":
            raise self._refused(what, reply.payload[0])
        return reply

    def _refused(self, what: str, code: int) -> LinkError:
        text = _special_text(self, what, code)
        return ChipRefused(f"slave {self.address}: {what}: the chip refused it: {text} "
                           f"(B{self.address:X} {code:02X})", code)

    def _registration_lost(self, what: str) -> bool:
        raise LinkTimeout(f"slave {self.address}: {what}: no whole reply: it may be registered "
                          "in the override buffer; not resent (taken twice, it would take "
                          "effect twice): poll, or stop the motion to empty the buffer")

    def _move_started(self, before: int) -> bool:
        """After a move's reply was lost: did the chip take the move? Busy, or the counter
        moved (a short move may be over already). A stop report alone proves nothing: it
        may be an earlier move's."""
        if self.poll().state == "busy":
            return True
        return self.position() != before

    def _exchange(self, frame: bytes, accepts: dict[str, int], what: str, *,
                  lost: Any = None) -> AsciiFrame:
        last: _Failed | None = None
        for attempt in range(self.retries + 1):
            if attempt:
                self.stats["resends"] += 1
                self._drain()
            self.stats["attempts"] += 1
            self._port.reset_input_buffer()
            self._port.write(frame)
            try:
                raw, reply = self._read_reply(accepts)
            except _Failed as failed:
                self.stats["timeouts" if failed.kind == "timeout" else "garbled"] += 1
                last = failed
                if lost is not None and lost():
                    return AsciiFrame("ready", self.address, b"")
                continue
            if self._on_reply is not None:
                # Here, once the frame is the chip's (control byte, type, length, hex,
                # checksum and address checked) and before the link acts on it: a 47 it
                # resends and a refusal it raises are heard too. Not before the checks: a
                # frame the line damaged is not the chip's answer, would only fail the
                # decoder again, and the link resends it (and names it if none comes whole).
                self._on_reply(Exchange(what, REPLY_TO[what], frame, raw, attempt))
            if reply.kind == "special" and reply.payload == bytes([COMMAND_ERROR]):
                # The chip's answer to a frame that reached it damaged (a bad checksum).
                last = _Failed("refused", "the chip answered command error 47 (a frame "
                               "damaged on the line, or an undefined command)")
                continue
            return reply
        assert last is not None
        tries = f"{self.retries + 1} attempt{'s' if self.retries else ''}"
        message = f"slave {self.address}: {what}: {last} ({tries})"
        if last.kind == "timeout":
            raise LinkTimeout(message)
        if last.kind == "refused":
            raise ChipRefused(message, COMMAND_ERROR)
        raise GarbledReply(message)

    def _read_reply(self, accepts: dict[str, int]) -> tuple[bytes, AsciiFrame]:
        """The next reply frame, whole, as it came and as read; a `_Failed` when none
        comes whole and checked within the timeout."""
        deadline = time.monotonic() + self.timeout_s
        stray = 0
        while True:
            head = self._read(1, deadline)
            if not head:
                why = "no reply" if not stray else f"{stray} stray byte(s) and no control byte"
                raise _Failed("timeout" if not stray else "garbled",
                              f"{why} within {self.timeout_s:g} s")
            if head[0] & 0x80:
                break
            stray += 1
        control = head[0]
        if stray:
            raise _Failed("garbled", f"{stray} stray byte(s) before control byte "
                                     f"0x{control:02X}")
        if control & 0x40:
            raise _Failed("garbled", f"0x{control:02X} is not a control byte (bit 6 set)")
        kind = ("busy", "ready", "data", "special")[CONTROL.decode(head)["type"]]
        if kind not in accepts:
            raise _Failed("garbled", f"unexpected {kind} reply (control byte 0x{control:02X})")
        want = 2 * accepts[kind] + 2
        body = self._read(want, deadline)
        if len(body) < want:
            raise _Failed("timeout", f"reply cut short: {len(body)} of {want} characters after "
                                     f"control byte 0x{control:02X} within {self.timeout_s:g} s")
        try:
            reply = decode_frame(head + body, from_slave=True)
        except DecodeError as e:
            raise _Failed("garbled", f"garbled reply {(head + body).hex(' ').upper()}: {e}"
                          ) from None
        if reply.address != self.address:
            raise _Failed("garbled", f"a reply from slave {reply.address}")
        return head + body, reply

    def _read(self, size: int, deadline: float) -> bytes:
        data = b""
        while len(data) < size:
            left = deadline - time.monotonic()
            if left <= 0:
                break
            self._port.timeout = left
            chunk = self._port.read(size - len(data))
            if not chunk:
                break
            data += chunk
        return data

    def _drain(self) -> None:
        """Let a damaged exchange's leftovers arrive and drop them before resending."""
        self._port.timeout = min(0.05, self.timeout_s)
        while self._port.read(256):
            pass
        self._port.reset_input_buffer()


def _open(port: str, baud: int, timeout_s: float) -> SerialPort:
    if baud not in BAUD_RATES:
        raise FieldChoiceError("baud", baud, BAUD_RATES)  # not every rate between them
    import serial

    try:
        opened: SerialPort = serial.serial_for_url(port, baudrate=baud, bytesize=8, parity="N",
                                                   stopbits=1, timeout=timeout_s)
    except (serial.SerialException, ValueError) as e:
        raise LinkError(f"{port}: cannot open the serial port: {str(e).splitlines()[0]}"
                        ) from None
    return opened


def _field(frame: Frame, reply: AsciiFrame, name: str) -> int:
    return int(frame.decode(reply.payload)[name])


def _stopped(code: int) -> PollReply:
    return PollReply("stopped", code, END_CODES.get(code, "unknown end code"))


def _special_text(link: Link, what: str, code: int) -> str:
    text = SPECIAL_REPLIES.get(code)
    if text is None:
        raise UnknownReply(f"slave {link.address}: {what}: unknown special reply 0x{code:02X} "
                           "(no code of the manual's §15–19)")
    return text


__all__ = ["BAUD_RATES", "REPLY_TO", "ChipRefused", "ErrorReport", "Exchange", "GarbledReply",
           "Link", "LinkError", "LinkTimeout", "PollReply", "UnknownReply"]
