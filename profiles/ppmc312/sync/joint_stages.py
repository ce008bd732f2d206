"""line mode, stage durations: the leader's stages as every axis follows them.

Every axis runs the leader's speed profile scaled by its pulse ratio c_i = N_i / N_lead,
on common stage boundaries. Each stage lasts the longest any axis needs (its least
counts at its own rates: the planner's own count rule with the chip's 2-pulse and
256-tick minima). A follower of few pulses may span several of the leader's short
stages with one of its own (`stage_groups`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ...errors import PlanError, SyncError
from ...motor import Motor
from ..clock import INTERNAL_HZ, Clock
from ..limits import MIN_STAGE_TICKS, RATE_MAX, RATE_MIN, STAGE_PULSES_MAX
from ..planner import make_problem
from ..table import FreeCurveTable

Least = Callable[[int, int], tuple[int, int]]   # (r_slow, r_fast) → (accel, decel) counts
LeastMemo = dict[tuple[int, str], Least | None]  # by (axis, clock name)


def clock_for(slowest_pps: float) -> Clock:
    """The fastest internal clock whose rate for the slowest speed fits 16 bits."""
    for name, hz in INTERNAL_HZ.items():
        if math.ceil(hz / slowest_pps) <= RATE_MAX:
            return Clock.internal(name)
    raise SyncError(f"a following axis would run at {slowest_pps:.4g} pps, slower than any "
                    "internal clock allows")


def least_counts(motor: Motor, clock: Clock) -> Least | None:
    """(accel, decel) least stage counts the motor needs to step from rate r_slow up to
    r_fast (r_fast 0: the top stage), with the chip's 2-pulse and 256-tick minima: the
    planner's own count rule."""
    try:
        counts = make_problem(motor, clock, True).counts
    except PlanError:
        return None

    memo: dict[tuple[int, int], tuple[int, int]] = {}

    def least(r_slow: int, r_fast: int) -> tuple[int, int]:
        key = (r_slow, r_fast)
        if key not in memo:   # every candidate top asks the same pairs again
            base = max(2, math.ceil(MIN_STAGE_TICKS / r_slow))
            if r_fast <= 0:
                memo[key] = (base, base)
            else:
                n, d, _ = counts(np.array([r_slow]), np.array([r_fast]))
                big = STAGE_PULSES_MAX + 1
                memo[key] = (int(min(max(n[0], base), big)), int(min(max(d[0], base), big)))
        return memo[key]
    return least


def stage_groups(lead: FreeCurveTable, scale: float, hz: float, jump_pps: float,
                 grouped: bool) -> list[list[int]]:
    """The leader's stages (fastest-first indices) each stage of a follower spans, slowest
    first. Ungrouped: one each. Grouped: a follower of few pulses stays in a stage through
    the leader's next ones until that stage would last its chip's least (2 pulses, 256
    ticks) — many short stages would each be stretched to it, slowing the whole move —
    or its speeds would span a third of its jump limit. The top stage is always its own."""
    n_l = len(lead.rates)
    if not grouped:
        return [[f] for f in range(n_l - 1, -1, -1)]
    hz_l = lead.clock.hz
    out: list[list[int]] = []
    cur: list[int] = []
    span = 0.0
    for f in range(n_l - 1, 0, -1):
        if cur and scale * (hz_l / lead.rates[f] - hz_l / lead.rates[cur[0]]) > jump_pps / 3:
            out.append(cur)
            cur, span = [], 0.0
        cur.append(f)
        span += lead.accel_pulses[f] * lead.rates[f] / hz_l
        rho = lead.rates[f] * hz / (hz_l * scale)
        if span >= max(2, math.ceil(MIN_STAGE_TICKS / rho)) * rho / hz:
            out.append(cur)
            cur, span = [], 0.0
    if cur:
        out.append(cur)
    out.append([0])
    return out


@dataclass(frozen=True)
class Joint:
    """The leader's table as every axis follows it: each axis's pulse ratio, clock, least
    counts and stage groups (slowest first)."""

    lead: FreeCurveTable
    dist: tuple[int, ...]
    lead_i: int
    scale: tuple[float, ...]
    clocks: tuple[Clock, ...]
    leasts: tuple[Least, ...]
    groups: tuple[list[list[int]], ...]

    @property
    def v_lead(self) -> list[float]:
        """The leader's stage speeds [pps], fastest first."""
        return [self.lead.clock.hz / r for r in self.lead.rates]

    def own(self, which: int) -> list[float]:
        """The leader's own stage durations [s] on one side (0 accel, 1 decel)."""
        counts = self.lead.accel_pulses if which == 0 else self.lead.decel
        return [n * r / self.lead.clock.hz for n, r in zip(counts, self.lead.rates, strict=True)]

    def ideal(self, i: int, g: list[int], t: Sequence[float]) -> float:
        """The rate that covers the line's distance over the group's time (one stage: the
        leader's rate scaled, exactly — the leader's own rates stay integers)."""
        hz_l, hz = self.lead.clock.hz, self.clocks[i].hz
        if len(g) == 1:
            return self.lead.rates[g[0]] * hz / (hz_l * self.scale[i])
        v = self.v_lead
        return sum(t[f] for f in g) * hz / (sum(t[f] * v[f] for f in g) * self.scale[i])


def joint_of(lead: FreeCurveTable, dist: Sequence[int], lead_i: int, motors: Sequence[Motor],
             grouped: bool, memo: LeastMemo) -> Joint | None:
    """How every axis follows `lead` (None: the leader's sides differ in stage count, or
    some axis's motor has no count rule on its clock). `memo` keeps each axis's
    least-count rule between calls."""
    n_l = len(lead.rates)
    if len(lead.accel_pulses) != n_l or len(lead.decel) != n_l:
        return None
    hz_l = lead.clock.hz
    scale = tuple(d / dist[lead_i] for d in dist)
    clocks = tuple(lead.clock if i == lead_i else clock_for(hz_l / lead.rates[-1] * scale[i])
                   for i in range(len(dist)))
    for i, (mo, c) in enumerate(zip(motors, clocks, strict=True)):
        if (i, c.name) not in memo:
            memo[(i, c.name)] = least_counts(mo, c)
    leasts = [memo[(i, c.name)] for i, c in enumerate(clocks)]
    if any(x is None for x in leasts):
        return None
    groups = tuple(stage_groups(lead, scale[i], clocks[i].hz, motors[i].jump_pps,
                                grouped and i != lead_i) for i in range(len(dist)))
    return Joint(lead, tuple(dist), lead_i, scale, clocks,
                 tuple(x for x in leasts if x is not None), groups)


def stage_durations(joint: Joint, which: int) -> list[float]:
    """Each leader stage's duration [s] on one side (0 accel, 1 decel): the leader's own,
    stretched until every axis's stage that ends there lasts at least its least count at
    the rate it will roughly run (the scaled rate, rounded)."""
    t = joint.own(which)
    guess = [[max(RATE_MIN, round(joint.ideal(i, g, joint.own(0)))) for g in groups]
             for i, groups in enumerate(joint.groups)]
    for f in range(len(t) - 1, -1, -1):          # slowest first
        for i, groups in enumerate(joint.groups):
            for k, g in enumerate(groups):
                if g[-1] != f:
                    continue                  # f does not end a stage of this axis
                r = guess[i][k]
                nxt = guess[i][k + 1] if k + 1 < len(groups) else 0
                if nxt >= r:
                    nxt = r - 1
                need = joint.leasts[i](r, nxt)[which] * r / joint.clocks[i].hz
                t[f] = max(t[f], need - sum(t[x] for x in g[:-1]))
    return t
