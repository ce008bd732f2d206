"""line mode, per-axis tables: every axis's table on the leader's stage boundaries.

The stage durations come from `joint_stages`, each follower's accel side from
`joint_rates`; the decel side is matched backwards from the end with the same (shared)
rates (the chip's LE=1 tables share rates between the sides).
"""

from __future__ import annotations

from collections.abc import Sequence

from ...motor import Motor
from ..limits import SIDE_TOTAL_MAX, STAGE_PULSES_MAX
from ..table import FreeCurveTable
from .joint_rates import accel_side
from .joint_stages import Joint, LeastMemo, joint_of, stage_durations
from .moves import table_of


def joint_tables(lead: FreeCurveTable, dist: Sequence[int], lead_i: int,
                 motors: Sequence[Motor], *, common: bool = False, grouped: bool = False,
                 memo: LeastMemo | None = None) -> list[FreeCurveTable] | None:
    """Tables for every axis that follow `lead`'s speed profile scaled by N_i / N_lead, on
    common stage boundaries (see the module docstrings). None if some axis has no legal
    one. `common`: both sides count alike (LE=0 tables; each stage lasts the longer of its
    accel and decel durations). `grouped`: a follower may span several of the leader's
    stages with one of its own. `memo` keeps each axis's least-count rule between calls
    (by axis and clock)."""
    joint = joint_of(lead, dist, lead_i, motors, grouped, {} if memo is None else memo)
    if joint is None:
        return None
    t_acc, t_dec = stage_durations(joint, 0), stage_durations(joint, 1)
    if common:
        t_acc = t_dec = [max(a, d) for a, d in zip(t_acc, t_dec, strict=True)]
    v_lead = joint.v_lead
    s_acc = sum(t * v for t, v in zip(t_acc, v_lead, strict=True)) / dist[lead_i]
    s_dec = sum(t * v for t, v in zip(t_dec, v_lead, strict=True)) / dist[lead_i]
    if s_acc + s_dec > 1:
        return None
    t_cruise = (1 - s_acc - s_dec) * dist[lead_i] / v_lead[0]
    tables = []
    for i in range(len(dist)):
        table = axis_table(joint, i, t_acc, t_dec, (dist[i] * (1 - s_acc - s_dec), t_cruise),
                           common)
        if table is None:
            return None
        tables.append(table)
    return tables


def axis_table(joint: Joint, i: int, t_acc: Sequence[float], t_dec: Sequence[float],
               cruise: tuple[float, float], common: bool) -> FreeCurveTable | None:
    """Axis i's table (None: it has no legal one): its accel side, its decel side matched
    backwards from the end, both within the chip's counts and the move's pulses.
    `cruise`: the follower's cruise pulses and the leader's cruise time [s]."""
    side = accel_side(joint, i, t_acc, cruise[0], cruise[1], common)
    if side is None or len(side[0]) < 2:
        return None
    rates, acc = side
    dec = list(acc) if common else decel_side(joint, i, rates, t_dec)
    rates_f, acc_f, dec_f = rates[::-1], acc[::-1], dec[::-1]
    if (sum(acc_f) + sum(dec_f) > joint.dist[i] or max(acc_f + dec_f) > STAGE_PULSES_MAX
            or max(sum(acc_f), sum(dec_f)) > SIDE_TOTAL_MAX):
        return None
    return table_of(joint.clocks[i], rates_f, acc_f, dec_f)


def decel_side(joint: Joint, i: int, rates: Sequence[int], t_dec: Sequence[float]
               ) -> list[int]:
    """Axis i's decel counts (slowest first = last in time first) at its accel side's
    `rates`, each stage ending where the leader's decel stages of durations `t_dec` end,
    at least the motor's least count for the step."""
    least, hz = joint.leasts[i], joint.clocks[i].hz
    dec: list[int] = []
    u = u_end = 0.0
    for j, r in enumerate(rates):
        u_end += sum(t_dec[f] for f in joint.groups[i][j])
        nxt = rates[j + 1] if j + 1 < len(rates) else 0
        nn = max(round((u_end - u) * hz / r), least(r, nxt)[1])
        dec.append(nn)
        u += nn * r / hz
    return dec
