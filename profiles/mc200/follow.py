"""The following error of a stream against the driver's captured replies.

A reply log is the driver's answers (`DriverPacket`: エンコーダパルス数, モータ電流値, the
in-position bit 位置決め完了状態, servo and alarm bits), one per host packet, in order.
SPI is full duplex: the reply clocked out while the host clocks in packet k was
made before packet k was read, so reply k is paired with the command in force
before packet k, the last one the driver applied among packets 0 … k − 1
(`read_stream`'s reading of the stream, so a refused packet or an SPI error counts as
the driver counts it). Reply k is at t = k·period.

- position commands: the command is the position;
- velocity commands [pps]: the command's position integrates them from the encoder
  where velocity control began (the reply of the packet whose command began it);
- current commands: no position is commanded: no following error.

The error is command − encoder [pulses] where a position is commanded and the reply
says the servo is on. The move's end is the first reply from which the command stays
at its last value; in position is the first reply from the move's end on after which
the in-position bit stays set to the log's end. Choices: docs/manual-notes.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import DecodeError, FormatError, require_number
from .codec import DRIVER_FRAME, PACKET_SIZE, reply_faults
from .model import Commands, read_stream
from .stream import PERIOD_FIELD, PERIOD_US_RANGE

TEXT_ROWS = 20  # rows of the error over time in the text report (evenly spaced)
ALARM_BITS = (("alarm", 0x04), ("limit_alarm", 0x02), ("spi_error", 0x01))


@dataclass(frozen=True)
class Following:
    """A stream's following error against its reply log, reply by reply (`t_s`,
    `command`, `encoder`, `error`, `current_a`, `in_position`, `servo_on`: one entry a
    reply; `command` and `error` NaN where no position is commanded or followed)."""

    period_us: float
    packets: int
    t_s: np.ndarray
    command: np.ndarray
    encoder: np.ndarray
    error: np.ndarray
    current_a: np.ndarray
    in_position: np.ndarray
    servo_on: np.ndarray
    alarms: tuple[tuple[str, int, int], ...]  # (bit, replies with it, the first of them)

    @property
    def replies(self) -> int:
        return len(self.t_s)

    @property
    def followed(self) -> np.ndarray:
        """The replies with a following error (a position commanded, the servo on)."""
        return np.flatnonzero(~np.isnan(self.error))

    @property
    def worst(self) -> int | None:
        """The reply of the largest |error| (the first of equals), None if none."""
        k = self.followed
        return int(k[np.argmax(np.abs(self.error[k]))]) if len(k) else None

    @property
    def move_end(self) -> int | None:
        """The first reply from which the command stays at its last value."""
        if not len(self.command) or np.isnan(self.command[-1]):
            return None
        other = np.flatnonzero(self.command != self.command[-1])  # NaN differs too
        return int(other[-1]) + 1 if len(other) else 0

    @property
    def in_position_at(self) -> int | None:
        """The first reply from the move's end on after which the in-position bit stays
        set to the log's end; None if it is not set at the end."""
        end = self.move_end
        if end is None or not self.in_position[-1]:
            return None
        out = np.flatnonzero(~self.in_position[end:])
        return end + (int(out[-1]) + 1 if len(out) else 0)

    def ms(self, reply: int) -> float:
        return reply * self.period_us * 1e-3

    def describe(self) -> str:
        """The report as text: the summary, then the error over time (`TEXT_ROWS` replies
        evenly spaced over those followed)."""
        lines = [f"following error (command − encoder): {self.replies} replies to "
                 f"{self.packets} packets, one every {self.period_us:g} µs"]
        k = self.followed
        if not len(k):
            lines.append("no reply follows a position: the servo is never on in the replies, "
                         "or no position or velocity is commanded (a current stream)")
        else:
            w = self.worst
            assert w is not None
            lines += [f"followed: replies {k[0]}–{k[-1]} (a position commanded, the servo on)",
                      f"worst: {_signed(self.error[w])} pulses at reply {w} "
                      f"({_ms(self.ms(w))} ms): command {_num(self.command[w])}, encoder "
                      f"{self.encoder[w]}",
                      f"at the end: {_signed(self.error[-1])} pulses (command "
                      f"{_num(self.command[-1])}, encoder {self.encoder[-1]})"]
        lines += self._settling() + [f"{name.replace('_', ' ')}: {n} replies, the first "
                                     f"{first} ({_ms(self.ms(first))} ms)"
                                     for name, n, first in self.alarms]
        if len(k):
            lines += ["over time:", "  t [ms]  command [pulses]  encoder [pulses]  "
                      "error [pulses]  current [A]  in position"]
            for r in k[np.unique(np.linspace(0, len(k) - 1, TEXT_ROWS).round().astype(int))]:
                settled = "yes" if self.in_position[r] else "no"
                lines.append(f"{_ms(self.ms(r)):>8}  {_num(self.command[r]):>16}  "
                             f"{self.encoder[r]:>16}  {_signed(self.error[r]):>14}  "
                             f"{self.current_a[r]:>11.4g}  {settled}")
        return "\n".join(lines) + "\n"

    def _settling(self) -> list[str]:
        end, at = self.move_end, self.in_position_at
        if end is None:
            return []
        out = [f"the command reaches {_num(self.command[end])} pulses at reply {end} "
               f"({_ms(self.ms(end))} ms)"]
        if at is None:
            out.append("in position: not by the log's end (the bit is clear in its last reply)")
        else:
            out.append(f"in position: from reply {at} ({_ms(self.ms(at))} ms), "
                       f"{_ms(self.ms(at - end))} ms after the command's end, to the log's end")
        return out

    def to_json(self) -> dict[str, Any]:
        """The report as JSON (times in ms, positions in pulses, currents in A; the
        series one entry a reply, null where no error is defined)."""
        def at(r: int | None, **more: Any) -> dict[str, Any] | None:
            return None if r is None else {"reply": r, "t_ms": self.ms(r), **more}

        w, end, inpos = self.worst, self.move_end, self.in_position_at
        k = self.followed
        return {
            "period_us": self.period_us, "packets": self.packets, "replies": self.replies,
            "followed": [int(k[0]), int(k[-1])] if len(k) else None,
            "worst": None if w is None else at(
                w, error_pulses=float(self.error[w]), command_pulses=float(self.command[w]),
                encoder_pulses=int(self.encoder[w])),
            "move_end": at(end, command_pulses=None if end is None else
                           float(self.command[end])),
            "in_position": at(inpos, after_move_end_ms=None if inpos is None or end is None
                              else self.ms(inpos - end)),
            "alarms": {name: {"replies": n, "first": first} for name, n, first in self.alarms},
            "series": {"t_ms": (self.t_s * 1e3).tolist(),
                       "command_pulses": self.command.tolist(),
                       "encoder_pulses": self.encoder.tolist(),
                       "error_pulses": self.error.tolist(),
                       "current_a": self.current_a.tolist(),
                       "in_position": self.in_position.tolist(),
                       "servo_on": self.servo_on.tolist()},
        }


def _ms(x: float) -> str:
    """A time in ms as the engineer reads it: up to µs, never in powers of ten (a log of
    an hour is 3600000 ms, not 3.6e+06)."""
    return f"{x:.3f}".rstrip("0").rstrip(".")


def _num(x: float) -> str:
    """A position as the engineer reads it: whole pulses as integers, else 3 decimals."""
    return "-" if np.isnan(x) else f"{int(x)}" if float(x).is_integer() else f"{x:.3f}"


def _signed(x: float) -> str:
    return "-" if np.isnan(x) else ("+" if x > 0 else "") + _num(x)


def following_error(stream: bytes, replies: bytes, *, period_us: float,
                    magic: int | None = None) -> Following:
    """`Following` of a host stream (packets back to back) and its reply log (the
    driver's packets back to back, one per host packet, any number up to the stream's:
    a capture may stop early). `magic`: the stream's mode-switch magic (default: what
    its first switch carries)."""
    from .codec import detect_magic

    require_number(PERIOD_FIELD, period_us, *PERIOD_US_RANGE)
    rows = reply_rows(replies)
    _refuse_swapped(stream, rows)
    reading = read_stream(stream, magic=detect_magic(stream) if magic is None else magic)
    if len(rows) > reading.packets:
        raise FormatError(f"{len(rows)} replies to a stream of {reading.packets} packets: a "
                          "reply log answers the stream's packets, one reply each")
    encoder = rows[:, 1:5].copy().view("<i4").reshape(-1).astype(np.int64)
    current = rows[:, 5:9].copy().view("<f4").reshape(-1).astype(np.float64)
    servo_on = rows[:, 0] & 0x08 != 0
    command = commanded_positions(reading.commands, encoder, period_us * 1e-6)
    error = np.where(servo_on, command - encoder, np.nan)
    alarms = tuple((name, int(np.count_nonzero(hit)), int(np.argmax(hit)))
                   for name, bit in ALARM_BITS if (hit := rows[:, 0] & bit != 0).any())
    t = np.arange(len(rows)) * period_us * 1e-6
    return Following(period_us, reading.packets, t, command, encoder, error, current,
                     rows[:, 9] & 0x80 != 0, servo_on, alarms)


def reply_rows(replies: bytes) -> np.ndarray:
    """The replies as an (n, 12) uint8 array, every one checked by the driver Frame's
    rules (vectorised; the first bad one decoded for the Frame's exact error)."""
    if len(replies) % PACKET_SIZE or not replies:
        whole = len(replies) // PACKET_SIZE
        raise DecodeError(f"{len(replies)} bytes is not a whole, non-zero number of "
                          f"{PACKET_SIZE}-byte replies", block=whole,
                          byte=len(replies) - whole * PACKET_SIZE)
    rows = np.frombuffer(replies, dtype=np.uint8).reshape(-1, PACKET_SIZE)
    bad = np.flatnonzero(reply_faults(rows))
    if len(bad):
        k = int(bad[0])
        DRIVER_FRAME.decode(rows[k].tobytes(), block=k)
    return rows


def _refuse_swapped(stream: bytes, replies: np.ndarray) -> None:
    """Both inputs are 12-byte packets with the same checksum: tell them apart by what
    each side always has. A host packet's bytes 1–2 and 8–9 are 予約 (0); a reply's byte
    9 says the control mode (1–3), so a log none of whose replies does is no reply log."""
    usable = len(stream) - len(stream) % PACKET_SIZE
    host = np.frombuffer(stream[:usable], dtype=np.uint8).reshape(-1, PACKET_SIZE)
    reserved = np.flatnonzero(host[:, [1, 2, 8, 9]].any(axis=1))
    if len(reserved):
        k = int(reserved[0])
        raise FormatError(f"stream packet {k}: its reserved bytes 1–2 and 8–9 are "
                          f"{host[k, [1, 2, 8, 9]].tobytes().hex(' ').upper()}, a host packet's "
                          "are 0 (is the stream the driver's replies?)")
    if not (replies[:, 9] & 0x0F).any():
        raise FormatError("replies: none says the control mode (byte 9: 1 position, 2 "
                          "velocity, 3 current), which every reply of the driver does (are "
                          "they the host's packets?)")


def commanded_positions(commands: Commands, encoder: np.ndarray,
                        period_s: float) -> np.ndarray:
    """The position commanded at each reply (float64 [pulses], NaN where none): the
    last command applied before the reply's packet; a velocity integrated from the
    encoder where velocity control began; none in current mode or before any command."""
    m = len(encoder)
    at = commands.at.astype(np.int64)
    start = _positions_when_applied(commands, encoder, period_s)
    i = np.searchsorted(at, np.arange(m), side="left") - 1  # the command in force
    known = i >= 0
    j = np.where(known, i, 0)
    out = np.full(m, np.nan)
    if not len(at):
        return out
    values = commands.values()
    moving = commands.mode[j] == 2
    elapsed = (np.arange(m) - at[j]) * period_s
    out[known] = (start[j] + np.where(moving, values[j] * elapsed, 0.0))[known]
    return out


def _positions_when_applied(commands: Commands, encoder: np.ndarray,
                            period_s: float) -> np.ndarray:
    """Per command, the position commanded when it is applied: a position command's own
    value; along a run of velocity commands, the encoder at the run's first packet (NaN
    if the log has no reply there) plus each earlier velocity times its time in force;
    NaN for currents. Runs of one mode are few: a loop over them, numpy within each."""
    mode = commands.mode
    values = commands.values()
    out = np.full(len(mode), np.nan)
    edges = np.flatnonzero(np.diff(mode)) + 1
    for s, e in zip(np.r_[0, edges], np.r_[edges, len(mode)], strict=True):
        if mode[s] == 1:
            out[s:e] = values[s:e]
        elif mode[s] == 2:
            first = int(commands.at[s])
            origin = float(encoder[first]) if first < len(encoder) else np.nan
            steps = values[s:e - 1] * np.diff(commands.at[s:e]) * period_s
            out[s:e] = origin + np.concatenate(([0.0], np.cumsum(steps)))
    return out


__all__ = ["TEXT_ROWS", "Following", "commanded_positions", "following_error", "reply_rows"]
