"""Whole moves and decel stops by the plain-Python oracle (tests/support/rotor_oracle.py), shared by
the tests and bench/bench_safety.py: one move of a table integrated from rest until settled, its
worst angle over the directions the verdict judges, and the compiled verdict's RK4 step
counts (read from its kernel, which reports them only for its step budget)."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator

import numpy as np

from profiles.motor import Motor
from profiles.motor.rotor import rotor_of
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.load_angle import directions, spans_of
from profiles.ppmc312.table import FreeCurveTable
from tests.support import rotor_oracle as oracle


def whole_move(table: FreeCurveTable, motor: Motor, pulses: int, direction: int = 1
               ) -> tuple[float, int]:
    """The move of `pulses` integrated whole from rest until settled: (worst |load
    angle| [electrical °], RK4 steps)."""
    rotor = rotor_of(motor, direction=direction)
    step = rotor.step_s()
    trace = oracle.follow(rotor, spans_of(simulate_move(table, pulses), rotor, step),
                          step_s=step, trace=oracle.Trace(record=False))
    return math.degrees(rotor.c_e * max(trace.span_max)), trace.steps


def whole_stop(table: FreeCurveTable, motor: Motor, stage: int, dwell: int) -> float:
    """A decel stop (profiles.ppmc312.stops: `dwell` pulses at accel stage `stage`'s rate)
    integrated whole from rest until settled, its worst |load angle| over the directions
    the verdict judges."""
    from profiles.ppmc312.stops import stop_execution

    worst = 0.0
    for direction in directions(motor):
        rotor = rotor_of(motor, direction=direction)
        step = rotor.step_s()
        trace = oracle.follow(rotor, spans_of(stop_execution(table, stage, dwell), rotor, step),
                              step_s=step, trace=oracle.Trace(record=False))
        worst = max(worst, math.degrees(rotor.c_e * max(trace.span_max)))
    return worst


def worst_whole_move(table: FreeCurveTable, motor: Motor, pulses: int) -> float:
    """The worst angle of the move over every direction the verdict judges (both when
    the motor has a load)."""
    return max(whole_move(table, motor, pulses, d)[0] for d in directions(motor))


@contextlib.contextmanager
def kernel_step_counts() -> Iterator[list[np.ndarray]]:
    """The per-cell RK4 step counts of every verdict judged inside (each judge's
    `executions` calls, one per range of cells on threads, fill one array: read it when
    the judge is done)."""
    from profiles.motor import rotor_kernel as rk

    seen: list[np.ndarray] = []
    original = rk.executions

    def counting(*args: object) -> None:
        original(*args)
        used = args[-1]
        if not any(u is used for u in seen):
            seen.append(used)  # type: ignore[arg-type]

    rk.executions = counting
    try:
        yield seen
    finally:
        rk.executions = original
