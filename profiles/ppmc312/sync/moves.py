"""The nouns of a synchronised PPMC-312 move: each axis's table and what its chip runs,
the plan, the move command every chip waits with, and the axes' pulse trains."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from ...errors import SyncError
from ...joint import Mode, SyncTimes
from ...motor import Motor
from ...pulses import Piece, PulseTrain
from ...pulses import line_deviation as trains_deviation
from ..clock import Clock
from ..execution import Execution
from ..table import FreeCurveTable
from ..upload import encode_move

Accept = Callable[[FreeCurveTable, Motor], bool]
TRIGGER_EVENT1 = 0b01      # move command TRG 01: start when event input 1 goes low
MIN_PULSES = 8             # a free-curve move: 2 stages × 2 pulses × 2 sides


@dataclass(frozen=True)
class AxisMove:
    """One axis of a synchronised move: its table and what the chip runs."""

    name: str
    pulses: int              # signed (negative: CCW)
    motor: Motor
    table: FreeCurveTable
    execution: Execution
    fastest_s: float         # its own fastest table's duration (unsynchronised)
    how: str                 # what was done to it, one line

    @property
    def duration_s(self) -> float:
        return self.execution.duration_s

    def pulse_train(self) -> PulseTrain:
        return pulse_train(self.execution)

    def facts(self) -> dict[str, Any]:
        """What the sync report says of this axis's table and move."""
        t, e = self.table, self.execution
        return {"clock": t.clock.name, "stages": len(t.rates), "top_pps": t.clock.hz / t.rates[0],
                "separate_decel": t.separate, "shape": e.shape,
                "first_pulse_latency_s": e.first_pulse_latency_s}

    def speed_steps(self) -> tuple[np.ndarray, np.ndarray, bool]:
        """(t [s], speed [pps], stepped): the chip's exact staircase, a step at each edge."""
        te, _, v = self.execution.edges()
        return te, v, True

    def move_command(self, trigger: int = TRIGGER_EVENT1) -> bytes:
        return move_command(self, trigger)


@dataclass(frozen=True)
class SyncPlan(SyncTimes):
    mode: Mode
    axes: tuple[AxisMove, ...]
    info: str


def move_command(axis: AxisMove, trigger: int = TRIGGER_EVENT1) -> bytes:
    """The accel/decel move (82) of one axis, held in the command buffer until the trigger
    (OV = 1, TRG 01: event input 1 low), so every chip wired to that input starts at once."""
    return encode_move(abs(axis.pulses), ccw=axis.pulses < 0, override=True, trigger=trigger)


def move_commands(plan: SyncPlan) -> list[bytes]:
    """Every axis's move command, in the plan's order (the sync report lists them)."""
    return [move_command(a) for a in plan.axes]


def axis_distance(name: str, pulses: int) -> int:
    """The axis's pulse count, refused below a free curve's least move."""
    n = abs(int(pulses))
    if n < MIN_PULSES:
        raise SyncError(f"axis {name}: {pulses} pulses; a free-curve move needs at least "
                        f"{MIN_PULSES} (2 stages × 2 pulses × 2 sides)")
    return n


def table_of(clock: Clock, rates: Sequence[int], acc: Sequence[int],
             dec: Sequence[int]) -> FreeCurveTable:
    """The table of these stages (fastest first): LE=0 when both sides count alike."""
    same = list(acc) == list(dec)
    return FreeCurveTable(clock, tuple(int(r) for r in rates), tuple(int(a) for a in acc),
                          None if same else tuple(int(d) for d in dec))


def pulse_train(execution: Execution) -> PulseTrain:
    """The chip's pulse instants as pieces, one per segment: pulse j of a segment ends
    rate·(j+1) ticks after its start (the exact ticks of `Execution.pulse_times_s`, any
    number of pulses); its period is exact for the internal clocks."""
    hz = execution.clock.hz
    hz_exact = Fraction(int(hz)) if float(hz).is_integer() else Fraction(hz)
    pieces = []
    before = 0
    for s in execution.segments:
        def times(k: np.ndarray, start: int = s.start_tick, rate: int = s.rate,
                  first: int = before + 1) -> np.ndarray:
            return (start + rate * (k - first + 1)) / hz
        pieces.append(Piece(before + 1, s.pulses, times, Fraction(s.rate) / hz_exact))
        before += s.pulses
    return PulseTrain(pieces)


def line_deviation(executions: Sequence[Execution]) -> tuple[float, np.ndarray, np.ndarray]:
    """The joint path's line deviation of the chips' executions (any number of pulses):
    `profiles.pulses.line_deviation` of their pulse trains."""
    return trains_deviation([pulse_train(e) for e in executions])
