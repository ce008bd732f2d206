"""line mode: positions stay proportional (a straight joint path).

The axis with the most pulses (L) leads. Its table is planned for an envelope motor
(`profiles.motor.envelope`): in L's pulses, the weakest of every axis's capability scaled
by its pulse ratio, shrunk by a margin that absorbs rate rounding. The other axes follow
on common stage boundaries (`joint_tables`). Cruise speeds are one integer rate per
chip, so L's top rate is searched (up to `top_slack` slower) for the top-rate pair whose
ratio matches the pulse ratio best; every table is then padded to end with the slowest
(split between the sides, so a cruise drift is centred on the line). LE=1 and LE=0 sets
are built; each candidate is scored by the exact deviation of the executed joint path
(`moves.line_deviation`): the least wins, the fastest among those within 0.25 pulse of
it. Every table of the chosen set passes `accept`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from ...errors import PlanError, SyncError
from ...motor import Motor
from ...motor.envelope import envelope_motor
from ..execution import Execution, simulate_move
from ..limits import MIN_STAGE_TICKS
from ..planner import plan_free_curve
from ..table import FreeCurveTable
from .acceptance import accepted
from .joint_stages import LeastMemo
from .joint_tables import joint_tables
from .moves import Accept, AxisMove, SyncPlan, axis_distance, line_deviation, table_of
from .padding import pad_to_ticks
from .time_mode import fastest_table

TOP_SLACK = 0.03           # L's top may be up to 3 % slower to match the ratio
LINE_MARGINS = (0.97, 0.9, 0.75, 0.5)  # envelope shrink tried in turn until accepted
LINE_STAGES = (24, 6, 2)   # fallbacks: fewer leader stages when short axes cannot follow
LINE_TOPS = 24             # top rates tried at most (the fastest ones)
NEAR_BEST_PULSES = 0.25    # line candidates this close to the best deviation: take the fastest
VARIANTS = ((False, False), (True, False), (False, True), (True, True))  # (common, grouped)


@dataclass(frozen=True)
class Axes:
    """The axes of one line-synchronised move: (name, motor, signed pulses), each one's
    distance and pulse ratio to the leader, and its own fastest move [s]."""

    items: Sequence[tuple[str, Motor, int]]
    dist: list[int]
    lead_i: int
    scales: list[float]
    fastest_s: list[float]

    @property
    def motors(self) -> list[Motor]:
        return [m for _, m, _ in self.items]


@dataclass(frozen=True)
class Candidate:
    """One set of tables for every axis: its deviation [pulses], duration [s], leader top."""

    deviation: float
    duration_s: float
    top_rate: int
    tables: list[FreeCurveTable]
    executions: list[Execution]


def cap_top(table: FreeCurveTable, rate: int) -> FreeCurveTable:
    """`table` with its top at `rate` (≥ the current top rate): faster stages dropped, a
    minimal top stage added if `rate` is not a stage rate. Every step is at most the old one,
    every count unchanged: the capability asked never grows."""
    if rate <= table.rates[0]:
        return table
    keep = [k for k, r in enumerate(table.rates) if r > rate]
    top_n = max(2, math.ceil(MIN_STAGE_TICKS / rate))
    rates = [rate] + [table.rates[k] for k in keep]
    acc = [top_n] + [table.accel_pulses[k] for k in keep if k < len(table.accel_pulses)]
    dec = [top_n] + [table.decel[k] for k in keep if k < len(table.decel)]
    if rate in table.rates:
        k = table.rates.index(rate)
        acc[0] = table.accel_pulses[k] if k < len(table.accel_pulses) else top_n
        dec[0] = table.decel[k] if k < len(table.decel) else top_n
    return table_of(table.clock, rates, acc, dec)


def finish_together(tables: Sequence[FreeCurveTable], dist: Sequence[int], *,
                    symmetric: bool = False) -> list[FreeCurveTable] | None:
    """Every table padded to end with the slowest (None if one cannot be)."""
    exes = [simulate_move(t, n) for t, n in zip(tables, dist, strict=True)]
    end = max(e.duration_s for e in exes)
    out = []
    for t, n, e in zip(tables, dist, exes, strict=True):
        if e.duration_s == end:
            out.append(t)
            continue
        try:
            out.append(pad_to_ticks(t, n, math.floor(end * t.clock.hz + 1e-6),
                                    symmetric=symmetric))
        except SyncError:
            return None
    return out


def plan_line_sync(axes: Sequence[tuple[str, Motor, int]], *, top_slack: float = TOP_SLACK,
                   accept: Accept | None = accepted) -> SyncPlan:
    """Positions stay proportional (see the module docstring). `axes`: (name, motor, signed
    pulses); `accept(table, motor)` vets every table."""
    dist = [axis_distance(name, p) for name, _, p in axes]
    lead_i = dist.index(max(dist))
    motors = [m for _, m, _ in axes]
    ax = Axes(axes, dist, lead_i, [d / dist[lead_i] for d in dist],
              [fastest_table(m, d)[1].duration_s for m, d in zip(motors, dist, strict=True)])
    plans: list[tuple[float, SyncPlan]] = []
    for stages in leader_stage_budgets(ax):
        found = first_accepted(ax, stages, top_slack, accept)
        if found is not None:
            plans.append(found)
    if plans:
        best = min(p[0] for p in plans)
        return min((p for p in plans if p[0] <= best + NEAR_BEST_PULSES),
                   key=lambda p: p[1].duration_s)[1]
    for stages in LINE_STAGES:
        found = first_accepted(ax, stages, top_slack, accept)
        if found is not None:
            return found[1]
    raise SyncError("no set of line-synchronised tables passed the stall check; the axes' "
                    "pulse ratio may need speeds below what the clocks can run")


def leader_stage_budgets(ax: Axes) -> list[int]:
    """The leader's stage budgets tried first. Every leader stage must last at least 2
    pulses of every follower: many short stages slow a far shorter axis down, so a leader
    of fewer stages is planned too (about a third of the shortest follower's ramp pulses)
    and the better plan kept."""
    try:
        ramp = plan_free_curve(envelope_motor(ax.motors, ax.scales),
                               pulses=ax.dist[ax.lead_i]).table.accel_total
    except PlanError:
        ramp = 0
    few = max(2, min(127, int(min([s * ramp for s in ax.scales]) / 3)))
    return sorted({127, few}, reverse=True)


def first_accepted(ax: Axes, stages: int, top_slack: float, accept: Accept | None
                   ) -> tuple[float, SyncPlan] | None:
    """The plan of the first envelope margin (gentlest last) whose tables pass `accept`."""
    for margin in LINE_MARGINS:
        found = line_attempt(ax, margin, top_slack, accept, stages)
        if found is not None:
            return found
    return None


def line_attempt(ax: Axes, margin: float, top_slack: float, accept: Accept | None,
                 max_stages: int) -> tuple[float, SyncPlan] | None:
    """The least-deviation accepted set for one envelope margin and stage budget (the
    fastest within NEAR_BEST_PULSES of it), as (deviation, plan); None if none passes."""
    env = envelope_motor(ax.motors, ax.scales, margin=margin)
    try:
        base = plan_free_curve(env, pulses=ax.dist[ax.lead_i], max_stages=max_stages).table
    except PlanError:
        return None
    candidates = line_candidates(ax, base, top_slack)
    chosen = choose_candidate(candidates, ax.motors, accept)
    if chosen is None:
        return None
    out = []
    for i, (name, motor, pulses) in enumerate(ax.items):
        how = (f"leads (envelope of all axes × {margin:g}, top rate {chosen.top_rate})"
               if i == ax.lead_i else
               f"follows at {ax.scales[i]:.6g} × the leader's speed, top rate "
               f"{chosen.tables[i].rates[0]}")
        out.append(AxisMove(name, pulses, motor, chosen.tables[i], chosen.executions[i],
                            ax.fastest_s[i], how))
    lead_name = ax.items[ax.lead_i][0]
    return chosen.deviation, SyncPlan(
        "line", tuple(out), f"line: leader {lead_name} ({len(chosen.tables[ax.lead_i].rates)} "
                            f"stages), {len(candidates)} candidates, deviation "
                            f"{chosen.deviation:.4g} pulses")


def line_candidates(ax: Axes, base: FreeCurveTable, top_slack: float) -> list[Candidate]:
    """Every set of tables that follows `base` with its top capped at each rate up to
    `top_slack` slower: LE=1 and LE=0 tables, followers stage by stage or spanning several
    of the leader's short stages."""
    r0 = base.rates[0]
    tops = list(range(r0, max(r0, math.floor(r0 * (1 + top_slack))) + 1))[:LINE_TOPS]
    memo: LeastMemo = {}
    out = []
    for r_top in tops:
        for common, grouped in VARIANTS:
            joint = joint_tables(cap_top(base, r_top), ax.dist, ax.lead_i, ax.motors,
                                 common=common, grouped=grouped, memo=memo)
            tables = None if joint is None else finish_together(joint, ax.dist,
                                                                symmetric=common)
            if tables is None:
                continue
            exes = [simulate_move(t, n) for t, n in zip(tables, ax.dist, strict=True)]
            out.append(Candidate(line_deviation(exes)[0], max(e.duration_s for e in exes),
                                 r_top, tables, exes))
    return out


def choose_candidate(candidates: list[Candidate], motors: Sequence[Motor],
                     accept: Accept | None) -> Candidate | None:
    """The least deviation that `accept` passes, then the fastest accepted one within
    NEAR_BEST_PULSES of it. The judge (over every move length) is the costly part:
    candidates are judged in order of deviation, then only faster ones near the first."""
    def passes(c: Candidate) -> bool:
        return accept is None or all(accept(t, mo) for t, mo in zip(c.tables, motors,
                                                                      strict=True))

    ordered = sorted(candidates, key=lambda c: (c.deviation, c.duration_s))
    first = next((c for c in ordered if passes(c)), None)
    if first is None:
        return None
    near = sorted((c for c in ordered if c.deviation <= first.deviation + NEAR_BEST_PULSES
                   and c.duration_s < first.duration_s), key=lambda c: c.duration_s)
    return next((c for c in near if passes(c)), first)
