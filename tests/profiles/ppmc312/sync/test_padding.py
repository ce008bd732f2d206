"""Synchronised axes (issue 11): axes files, time and line synchronisation, ruckig.

Finish spread and line deviation are recomputed here independently of the library:
each axis's pulse instants are rebuilt from its table's execution segments in pure
Python (no pulse_times_s / searchsorted), positions at each instant counted with
Execution.position_at (the segment model), and the distance to the line taken as the
2-D cross product |x·N_y − y·N_x| / |N| (the library projects onto the line).
"""

from __future__ import annotations

from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.sync import (
    pad_to_ticks,
)

MOTORS = [load_motor(p) for p in bundled_motor_paths()]


NEMA17, NEMA23, PK566 = MOTORS


def test_padding_lands_within_a_tick_step_and_only_grows_counts() -> None:
    table = plan_free_curve(NEMA17, pulses=8000).table
    base = simulate_move(table, 8000)
    target = base.ticks + 123_457
    padded = pad_to_ticks(table, 8000, target)
    run = simulate_move(padded, 8000)
    assert run.ticks <= target and target - run.ticks < padded.rates[1] - padded.rates[0] + 1
    assert all(p >= q for p, q in zip(padded.accel_pulses, table.accel_pulses, strict=True))
    assert padded.rates == table.rates
    sym = pad_to_ticks(table, 8000, target, symmetric=True)
    assert sym.accel_pulses == sym.decel or sym.decel_pulses is not None
