"""The serial emulator's motion: every motion command of `motion.COMMANDS` that starts at
once, run in emulated time by the model `command_runs` documents (the one `stepramp
simulate PROGRAM` runs), for `serial_chip.SerialChip`.

What the chip checks before it takes a command (manual §11-6 codes, answered B0 42 in
serial mode, whose reply carries no sub-code: the emulator's log names it), and how long
it takes to start, are here; the readings are in docs/manual-notes.md ("Serial link:
the emulator's motion commands"):

- a rate outside the figure's range, or outside the rates of the table the chip holds
  (0 is the table's high rate where the figure allows it): 0x20 「パルスレートの設定が
  範囲外です」; the origin search's rate lies between the table's high rate and the faster
  of its start and stop rates (§8-10); the high-speed limit (05) is bound by its figure
  only;
- a move of 0 pulses (82, 83): 0x23 「動作パルス数が間違ってます」;
- the first pulse comes `FIRST_PULSE_S` after the command (§8-3's table for 82).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .ascii import POSITION_MODULUS
from .command_runs import FOREVER, LiveMotion, Piece, ProgramCommand, Stairs
from .execution import simulate_move
from .motion import AT, Command
from .table import InitTable

RATE_OUT_OF_RANGE, BAD_PULSE_COUNT = 0x20, 0x23   # §11-6
# E0's cause (command_runs.CAUSES) → the end code of the stop report (§19-14, §18-6).
END_CODES = {"NOS": 0x38, "STP": 0x37, "DEC": 0x36, "ORG": 0x32, "LOW": 0x39,
             "DEL": 0x34, "STL": 0x33}
# Seconds from the command to the first pulse period, (rate given, rate 0): §8-4
# 「パルスを出力するまでに400 μ Sを必要とします」 (83, 86), §8-6/§8-11 「レート指定ありで
# 400 μ S、レート指定無しで60 μ S」 (85, 11). §8-5 and §8-10 give none: the single step
# as the "other commands" of §21-4.4 (100 µs), the origin search as the constant runs
# (400 µs). 82's is §8-3's table (`Execution.first_pulse_latency_s`).
FIRST_PULSE_S: dict[str, tuple[float, float]] = {
    "constant": (400e-6, 400e-6), "continuous-constant": (400e-6, 400e-6),
    "continuous": (400e-6, 60e-6), "origin-return": (400e-6, 60e-6),
    "origin-search": (400e-6, 400e-6), "step": (100e-6, 100e-6)}


class ChipRefusal(Exception):
    """What the chip answers instead of taking a command: `code` (0x42 parameter error,
    0x43 state error) and, for 0x42, the §11-6 `detail` code; `why` is one line."""

    def __init__(self, code: int, why: str, detail: int | None = None) -> None:
        super().__init__(why)
        self.code, self.detail = code, detail


def rate_problem(command: Command, rate: int, table: InitTable | None) -> str | None:
    """Why the chip refuses `rate` for `command` with `table` held (0x20), or None; no
    table: the figure's range only."""
    allowed = command.rate
    if allowed is None:
        return None
    if not allowed.allows(rate):
        return f"rate {rate} is outside {command.serial_section}'s range {allowed.shown}"
    if not allowed.table or rate == 0 or table is None:
        return None
    stairs = Stairs(table)
    lo, hi = stairs.lo, stairs.hi
    if command.name == "origin-search":
        hi = min(stairs.start_rate, stairs.stop_rate)
    if not lo <= rate <= hi:
        return f"rate {rate} is not {allowed.table} ({lo}..{hi})"
    return None


def check_start(command: Command, fields: Mapping[str, Any], table: InitTable) -> None:
    """A start command's parameters as the chip checks them (ChipRefusal 0x42)."""
    if fields.get("pulses", 1) == 0:
        raise ChipRefusal(0x42, f"{command.label}: 0 pulses: a move runs 1..0xFFFFFFFF",
                          BAD_PULSE_COUNT)
    if command.rate is not None:
        why = rate_problem(command, fields[command.rate_field], table)
        if why is not None:
            raise ChipRefusal(0x42, f"{command.label}: {why}", RATE_OUT_OF_RANGE)


@dataclass
class Running:
    """A motion under way: `live` its model, from `start_s` (the first pulse period),
    `sign` +1 CW / −1 CCW, `origin` the counter at the start, `origin_at` the pulses
    output when /ORG is met (None: never)."""

    live: LiveMotion
    start_s: float
    sign: int
    origin: int
    hz: float
    origin_at: int | None = None
    # (ticks, piece) of each piece; an endless cruise has FOREVER pulses
    _pieces: list[tuple[int, Piece]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.refresh()

    def refresh(self) -> None:
        """Re-read the model's pieces (after a command changed what comes)."""
        self._pieces = [(p.rate * p.pulses, p) for p in self.live.pieces]

    @property
    def end(self) -> int | None:
        """The pulses the motion outputs in all as things stand (None: until stopped)."""
        if any(p.pulses == FOREVER for _, p in self._pieces):
            return None
        return sum(p.pulses for _, p in self._pieces)

    def output(self, now_s: float) -> tuple[int, int]:
        """(pulses output by `now_s`, of them run backward) — a pulse counts at the end of
        its period, as `Execution.position_at` counts them."""
        ticks = max(0.0, now_s - self.start_s) * self.hz
        out = back = 0
        for span, p in self._pieces:
            whole = p.pulses != FOREVER and ticks >= span
            # 1e-9: a time that is a pulse instant in float counts that pulse
            n = p.pulses if whole else math.floor(ticks / p.rate + 1e-9)
            if p.pulses != FOREVER:
                n = min(n, p.pulses)
            out += n
            back += n if p.backward else 0
            if not whole:
                break
            ticks -= span
        return out, back

    def reach(self, position: int) -> int:
        """The pulses the motion outputs until its counter reads `position` the way it
        runs (modulo 2³², §2-1.6; 0: it reads it now)."""
        return (self.sign * (position - self.origin)) % POSITION_MODULUS

    def counter(self, now_s: float) -> int:
        out, back = self.output(now_s)
        return (self.origin + self.sign * (out - 2 * back)) % POSITION_MODULUS

    def settle(self, now_s: float) -> bool:
        """Meet /ORG if the motion has reached it; whether the motion is over."""
        out, _ = self.output(now_s)
        if self.origin_at is not None and out >= self.origin_at and not self.live.stopping:
            self.live.origin(self.origin_at)
            self.origin_at = None
            self.refresh()
            out, _ = self.output(now_s)
        end = self.end
        return end is not None and out >= end

    @property
    def end_code(self) -> int:
        return END_CODES[self.live.cause]


OVERRIDE_DEPTH = 8   # §5-2 「8個のコマンドバッファが有り、FIFO」
OVERRIDE_DONE, OVERRIDE_ABORTED = 0x21, 0x49   # §19-9, §19-10
# How a registered form starts → what the emulator's log calls it (the pins of §5-2).
TRIGGERS = {AT: "at position", "evt1": "on /EVT0", "evt2": "on /EVT1"}


@dataclass
class Override:
    """A serial form of 80, 81, 87, 88 registered in the override buffer (§5-2): `start`
    AT (at counter value `position`) or an event input (`motion.EVENTS`'s key: "evt1" is
    /EVT0, "evt2" /EVT1); `armed_from`: the pulses the motion had output when it became the
    buffer's head (only the head waits for its trigger: 「実行された命令は破棄され、次の
    命令が起動待ち状態になります」)."""

    command: Command
    start: str
    rate: int = 0
    position: int | None = None
    armed_from: int = 0

    @property
    def what(self) -> str:
        where = f" {self.position}" if self.position is not None else ""
        return f"{self.command.label} {TRIGGERS[self.start]}{where}"


def start_motion(command: Command, fields: Mapping[str, Any], table: InitTable, *,
                 now_s: float, position: int, origin_at: int | None,
                 limit_rate: int | None = None) -> Running | None:
    """A start command taken at `now_s` with the counter at `position`; `origin_at` the
    counter value where /ORG is low (None: nowhere). None: an origin search or return
    that starts on /ORG, which stops before a pulse (the caller reports 0x32)."""
    check_start(command, fields, table)
    rate = fields.get(command.rate_field, 0) if command.rate is not None else 0
    ccw = bool(fields.get("dir", 0))
    sign = -1 if ccw else 1
    if command.name == "accel":
        # 82 as `simulate_move` runs it (its high-rate rules, §8-3's latency table)
        latency = simulate_move(table, fields["pulses"], high_rate=rate).first_pulse_latency_s
    else:
        latency = FIRST_PULSE_S[command.name][rate == 0]
    start = ProgramCommand(command.name, rate=rate, pulses=fields.get("pulses", 0), ccw=ccw)
    found = None
    if command.name in ("origin-search", "origin-return") and origin_at is not None:
        found = (sign * (origin_at - position)) % POSITION_MODULUS
        if found == 0:
            return None
    return Running(LiveMotion(table, start, limit_rate=limit_rate), now_s + latency, sign, position,
                   table.clock.hz, origin_at=found)


__all__ = ["END_CODES", "FIRST_PULSE_S", "OVERRIDE_ABORTED", "OVERRIDE_DEPTH",
           "OVERRIDE_DONE", "TRIGGERS", "ChipRefusal", "Override", "Running", "check_start",
           "rate_problem", "start_motion"]
