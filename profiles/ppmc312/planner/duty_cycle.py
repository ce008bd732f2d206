"""One table for a machine's mix of move lengths (`plan_duty_cycle`): the mix as arrays,
the lengths candidate tables are planned for, and the time of every length of the mix
with a table, all at once.

Timing is the chip's own move model (`move_batch.moves`, the one `simulate_move` runs),
numpy over moves: a move's ticks are Σ rate × pulses over its segments. A trapezoid
(a move of at least the table's accel + decel totals, SPEC §1.6) runs every stage and
then cruises at the fastest rate, so the trapezoids of a mix differ only in their
cruise: the segments are built for the shorter moves and for the two shortest
trapezoids, whose difference is one cruise pulse; the longer ones follow exactly.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from ...errors import PlanError, require_int, require_number
from ...motor import Motor
from ...motor.batch import MoveBatch
from ...threads import pool
from ..clock import Clock
from ..move_batch import MOVE_PULSES_MAX, moves
from ..table import FreeCurveTable
from .free_curve import plan_free_curve
from .problem import Plan, check_plan_args

MIX_PULSES_MIN = 8          # planner.check_plan_args: the shortest move a table is planned for
MIX_WEIGHT_MAX = 1e12
MIX_ROWS_MAX = 1_000_000    # rows of a mix, equal lengths included
MIX_LENGTHS_MAX = 100_000   # distinct lengths: each is timed on every candidate table
CANDIDATES = 16             # tables planned for a mix (see candidate_lengths)
NEAR = 0.05                 # a geometric candidate this close to a quantile is not planned
_CHUNK = 2048               # moves built at once (a long move has ~2 segments per stage)


def mix_arrays(mix: Sequence[tuple[int, float]]) -> tuple[np.ndarray, np.ndarray]:
    """The mix's distinct lengths, ascending, and each one's weight (the weights of equal
    lengths summed). A length outside 8..0xFFFFFFFF pulses or a weight outside 0..1e12
    is a FieldRangeError naming its row; an empty mix, one of more than MIX_ROWS_MAX rows
    or MIX_LENGTHS_MAX distinct lengths, or one whose weights sum to 0 is a PlanError."""
    if not mix:
        raise PlanError("the move mix is empty: give at least one pulses,weight row")
    if len(mix) > MIX_ROWS_MAX:
        raise PlanError(f"the move mix has {len(mix)} rows, more than the {MIX_ROWS_MAX} "
                        "a duty cycle may have")
    for row, (n, w) in enumerate(mix, start=1):
        require_int(f"move mix row {row}: pulses", n, MIX_PULSES_MIN, MOVE_PULSES_MAX)
        require_number(f"move mix row {row}: weight", w, 0.0, MIX_WEIGHT_MAX)
    lengths, where = np.unique(np.array([int(n) for n, _ in mix], dtype=np.int64),
                               return_inverse=True)
    if len(lengths) > MIX_LENGTHS_MAX:
        raise PlanError(f"the move mix has {len(lengths)} distinct lengths, more than the "
                        f"{MIX_LENGTHS_MAX} a duty cycle may have: merge nearby lengths")
    weights = np.bincount(where, weights=np.array([float(w) for _, w in mix]),
                          minlength=len(lengths))
    if not weights.sum() > 0:
        raise PlanError("the move mix's weights sum to 0: give at least one positive weight")
    return lengths, weights


def candidate_lengths(lengths: np.ndarray, weights: np.ndarray,
                      count: int = CANDIDATES) -> list[int]:
    """At most `count` lengths to plan a table for. A mix of at most count // 2 lengths:
    every length, and the geometric middle of each two neighbours (a table for a length
    between them may serve both better). A larger mix: count // 2 weighted quantiles (at
    the middle of each of count // 2 equal shares of its weight), and the rest spread
    geometrically from its shortest to its longest length, both included, less those
    within NEAR of a quantile (plans for lengths 5 % apart differ little; each costs a
    plan). Ascending, distinct."""
    require_int("candidates", count, 4, 64)
    half = count // 2
    if len(lengths) <= half:
        middles = np.round(np.sqrt(lengths[1:].astype(float) * lengths[:-1]))
        apart = middles > (1 + NEAR) * lengths[:-1]
        return sorted({int(n) for n in lengths} | {int(n) for n in middles[apart]})
    else:
        cumulative = np.cumsum(weights)
        levels = (np.arange(half) + 0.5) / half * cumulative[-1]
        picked = lengths[np.minimum(np.searchsorted(cumulative, levels), len(lengths) - 1)]
    quantiles = np.unique(picked)
    spread = np.round(np.geomspace(float(lengths[0]), float(lengths[-1]), count - half))
    near = np.abs(spread[:, None] - quantiles[None, :]) <= NEAR * quantiles[None, :]
    return sorted({int(n) for n in quantiles} | {int(n) for n in spread[~near.any(axis=1)]})


def move_ticks(table: FreeCurveTable, lengths: np.ndarray) -> np.ndarray:
    """Each move's duration in clock ticks (int64) with `table` (high rate 0): exactly
    `simulate_move(table, n).ticks` for every n of `lengths`."""
    lengths = np.asarray(lengths, dtype=np.int64)
    ticks = np.empty(len(lengths), dtype=np.int64)
    accel = sum(table.accel_pulses)
    full = accel + (accel if table.decel_pulses is None else sum(table.decel_pulses))
    # the shortest trapezoid and the next: one cruise pulse apart
    first, second = _ticks(moves(table, [full, full + 1])).tolist()
    long = lengths >= full
    ticks[long] = first + (lengths[long] - full) * (second - first)
    short = np.flatnonzero(~long)
    for start in range(0, len(short), _CHUNK):
        part = short[start:start + _CHUNK]
        ticks[part] = _ticks(moves(table, lengths[part]))
    return ticks


def _ticks(batch: MoveBatch) -> np.ndarray:
    per_segment = batch.rate.astype(np.int64) * batch.count
    # every move (≥ 1 pulse) has a segment: no two offsets are equal
    return np.add.reduceat(per_segment, batch.offsets[:-1])


def move_times_s(table: FreeCurveTable, lengths: np.ndarray) -> np.ndarray:
    """Each move's duration [s], as `simulate_move(table, n).duration_s` gives it."""
    return move_ticks(table, lengths) / table.clock.hz


def plan_duty_cycle(motor: Motor, mix: list[tuple[int, float]], *, clock: Clock | None = None,
                    max_stages: int = 127, separate_decel: bool | None = None,
                    load_angle_deg: float | None = None, candidates: int = 16,
                    progress: Callable[[int, int], None] | None = None,
                    ) -> tuple[Plan, dict[int, float]]:
    """One table for a machine's mix of moves: `mix` is (pulses, weight) per move length
    (equal lengths' weights summed; the module docstring states the bounds).
    Minimises Σ weight × move time, each length timed as the chip runs it, over the
    tables `plan_free_curve` (same options) plans for at most `candidates` lengths: the
    mix's weighted quantiles, or every length when it has at most candidates // 2, and
    lengths spread geometrically from its shortest to its longest (`candidate_lengths`).
    Guarantee: never worse on the mix than the plan for any of those lengths (so, for a
    mix of at most candidates // 2 lengths, than the plan for any length of it; with
    `load_angle_deg`, than the tightened plan of the first candidate tightened, the
    later ones being tightened from where it ended); the cost is a bounded number of
    plans, each table timed on every length at once. With
    `load_angle_deg`, every candidate is planned by the criterion first, and only those
    whose plain table could still beat the best tightened one so far are tightened,
    best first (tightening makes a table gentler, so its mix is no faster than the
    plain table's: they are the bound); the first from the plain criterion, the later
    ones from the shaping the first ended with (the bands that ring are the motor's:
    one plan each where that shaping keeps them within the aim, instead of a search).
    `progress` hears each candidate planned. Returns the plan (`duration_s` the weighted
    time, `extras["candidates"]` the lengths planned for) and each length's time."""
    from ...progress import track

    check_plan_args(max_stages, None)
    lengths, weights = mix_arrays(mix)
    targets = candidate_lengths(lengths, weights, candidates)
    best: tuple[float, Plan, np.ndarray] | None = None
    plain: list[tuple[float, int]] = []

    def planned(target: int) -> Plan | None:
        try:
            return plan_free_curve(motor, clock=clock, max_stages=max_stages, pulses=target,
                                   separate_decel=separate_decel)
        except PlanError:
            return None  # e.g. too short a move for a table: the other candidates remain

    # the candidates' plans are independent: two at a time (the DP and numpy release the GIL)
    workers = pool("duty-cycle", min(2, os.cpu_count() or 1))
    found = list(track(workers.map(planned, targets), progress, total=len(targets)))
    for target, plan in zip(targets, found, strict=True):
        if plan is None:
            continue
        times = move_times_s(plan.table, lengths)
        total = float(np.dot(weights, times))
        plain.append((total, target))
        if load_angle_deg is None and (best is None or total < best[0]):
            best = (total, plan, times)
    rang = None  # where the first tightened candidate's bands ended: the motor's ringing
    for bound, target in sorted(plain) if load_angle_deg is not None else ():
        if best is not None and bound >= best[0]:
            break  # neither this plain table nor any later one beats the best tightened
        try:
            plan = plan_free_curve(motor, clock=clock, max_stages=max_stages, pulses=target,
                                   separate_decel=separate_decel, load_angle_deg=load_angle_deg,
                                   start_shaping=rang)
        except PlanError:
            continue
        rang = rang or plan.extras["shaping"]
        times = move_times_s(plan.table, lengths)
        total = float(np.dot(weights, times))
        if best is None or total < best[0]:
            best = (total, plan, times)
    if best is None:
        raise PlanError(f"no table could be planned for any of the {len(targets)} candidate "
                        "lengths of the mix")
    total, plan, times = best
    info = (plan.info + f"; duty cycle of {len(lengths)} move lengths, best of "
            f"{len(targets)} candidate tables: weighted time {total:.6g} s")
    extras = {**plan.extras, "candidates": targets}
    return (replace(plan, duration_s=total, pulses=None, info=info, extras=extras),
            dict(zip(lengths.tolist(), times.tolist(), strict=True)))
