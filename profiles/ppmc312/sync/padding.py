"""Padding: a table slowed to a target duration by moving pulses from the cruise into
the stages next to the top. More pulses in a stage only lowers the acceleration it asks
of the motor; the jump, start and top speeds are unchanged."""

from __future__ import annotations

from ...errors import SyncError
from ..execution import simulate_move
from ..limits import SIDE_TOTAL_MAX, STAGE_PULSES_MAX
from ..table import FreeCurveTable
from .moves import table_of


def pad_to_ticks(table: FreeCurveTable, pulses: int, target_ticks: int, *,
                 accel_first: bool = True, symmetric: bool = False) -> FreeCurveTable:
    """`table` with pulses moved from the cruise into the stages next to the top until the
    move of `pulses` lasts as close to `target_ticks` clock ticks as possible from below.

    Stage k (fastest first) gains `rates[k] − rates[0]` ticks a pulse; the bulk goes to the
    stage nearest the top that can take it, faster stages refine the rest; each amount is
    split between the accel and decel side (accel first: ceil half). `symmetric`: both
    sides always gain alike (an LE=0 table stays LE=0; the step is then two pulses). The
    move stays a trapezoid (accel + decel ≤ pulses) and every count and side total stays
    in the chip's range. Counts only grow: no stage asks more of the motor.
    """
    acc, dec = list(table.accel_pulses), list(table.decel)
    rates = table.rates
    cruise = pulses - sum(acc) - sum(dec)
    gap = target_ticks - simulate_move(table, pulses).ticks
    if cruise < 0:
        raise SyncError(f"the table's accel + decel pulses exceed the {pulses}-pulse move")
    sides = [acc, dec] if accel_first else [dec, acc]
    d_all = [r - rates[0] for r in rates]
    for k in padding_order(d_all, cruise, gap):
        d = d_all[k]
        if symmetric:
            if k >= len(acc) or k >= len(dec):
                continue
            q = max(min(gap // (2 * d), cruise // 2, room(acc, k), room(dec, k)), 0)
            acc[k] += q
            dec[k] += q
            cruise -= 2 * q
            gap -= 2 * q * d
            continue
        if gap < d or cruise <= 0:
            continue
        # half (rounded up) to the first side, the rest to the other, then any rest the
        # other side had no room for back to the first
        for side, cap in ((sides[0], (min(gap // d, cruise) + 1) // 2), (sides[1], None),
                          (sides[0], None)):
            q = max(min(gap // d, cruise, room(side, k),
                        cap if cap is not None else cruise), 0)
            side[k] += q
            cruise -= q
            gap -= q * d
    return table_of(table.clock, rates, acc, dec)


def padding_order(ticks_a_pulse: list[int], cruise: int, gap: int) -> list[int]:
    """The stages (fastest-first indices, the top excluded) in the order they take pulses:
    the bulk goes to the stage nearest the top whose extra ticks a pulse, times the cruise
    pulses there are, can cover the gap; faster stages then refine the rest (finer
    steps), slower ones only take what is still left."""
    n = len(ticks_a_pulse)
    bulk = next((k for k in range(1, n) if ticks_a_pulse[k] * cruise >= gap), n - 1)
    return [*range(bulk, 0, -1), *range(bulk + 1, n)]


def room(side: list[int], k: int) -> int:
    """Pulses stage k of one side can still take (its own and the side total's limit)."""
    if k >= len(side):
        return 0
    return max(min(STAGE_PULSES_MAX - side[k], SIDE_TOTAL_MAX - sum(side)), 0)
