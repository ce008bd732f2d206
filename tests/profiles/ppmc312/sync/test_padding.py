"""profiles.ppmc312.sync.padding: padding lands within a tick step and only grows counts."""

from __future__ import annotations

from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.sync import (
    pad_to_ticks,
)
from tests.support.sync_checks import NEMA17


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
