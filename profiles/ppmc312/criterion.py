"""The stall-safety criterion's numbers, judged on what the chip runs.

A table is never run as a table: the chip runs *executions* (profiles.ppmc312.
execution), one per move length, and every speed change an execution emits must
be one the motor follows (docs/manual-notes.md, "Stall-safety criterion"):

- start and stop: the first and the last segment run at ≤ `start_pps` (the motor
  starts and stops there without a ramp);
- top: no segment runs above `motor.top_pps`;
- every step between segments: |Δv| ≤ `motor.jump_pps`, and the ramp through the
  stage corners is within the motor's capability: a step up from v_i to v_(i+1)
  needs Δv / t_i ≤ min a_acc over [v_i, v_(i+1)] with t_i the dwell at the slower
  speed before it (the ramp through stage starts); a step down needs
  Δv / t_(i+1) ≤ min a_dec with t_(i+1) the dwell at the slower speed after it (the
  same rule in reversed time);
- `switch`: the step at a triangle's accel→decel switch is judged by the same rules,
  reported apart because the table itself never shows it (LE=1 triangles can end
  the accel on one stage and start the decel on a slower one).

Every move length is covered without iterating lengths: within a `MoveFamily` the
segment rates are fixed and only partial stages grow with the length, so every need
is largest at the family's shortest move, which is the one judged.

The jerk rule (`max_jerk_pps3`) is a rule of the table's staircases (see
`jerk_problems`); a triangle's peak is a slope reversal any truncated staircase has.

This module computes; `verify.criterion` turns problems into findings with fixes.
Planners use it to prove their own tables (profiles never imports verify).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ..motor import Motor
from .execution import Execution, move_families, simulate_move
from .init_model import as_free_curve
from .move_batch import MOVE_PULSES_MAX
from .table import FreeCurveTable, InitTable

# Planners round pulse counts up with exact float arithmetic; this relative slack
# only absorbs the last-bit difference between their arithmetic and ours.
REL_TOL = 1e-9

Rule = Literal["start-speed", "top-speed", "jump", "accel", "decel", "switch", "jerk"]


@dataclass(frozen=True)
class StepProblem:
    """One speed change of one execution that the motor cannot follow.

    Stages are fastest-first indices into the table (None: a high-rate override's
    cruise, which is no stage). `pulses` is the move length judged (the shortest of
    `family`, the lengths that run the same stages); `kind` says where: `start`,
    `stop`, `top`, `step` (between stages of one side) or `switch`."""

    rule: Rule
    kind: str
    pulses: int
    family: tuple[int, int]
    stage_from: int | None
    stage_to: int | None
    v_from_pps: float
    v_to_pps: float
    dwell_pulses: int | None = None
    dwell_stage: int | None = None
    dwell_side: str | None = None
    need_pps2: float = 0.0
    cap_pps2: float = float("inf")

    @property
    def jump_pps(self) -> float:
        return self.v_to_pps - self.v_from_pps


def execution_problems(execution: Execution, motor: Motor, rates: tuple[int, ...],
                       family: tuple[int, int] | None = None) -> list[StepProblem]:
    """Every speed change of `execution` that breaks the criterion (vectorised)."""
    runs = [(s.phase, s.rate, s.pulses) for s in execution.segments]
    return runs_problems(runs, execution.clock.hz, execution.pulses, motor, rates, family)


def runs_problems(runs: Sequence[tuple[str, int, int]], hz: float, pulses: int, motor: Motor,
                  rates: tuple[int, ...], family: tuple[int, int] | None = None
                  ) -> list[StepProblem]:
    """`execution_problems` on a move's segments given as (phase, rate, pulses)."""
    if not runs:
        return []
    fam = family or (pulses, pulses)
    n = pulses
    index = {r: i for i, r in enumerate(rates)}
    r = np.array([x[1] for x in runs], dtype=float)
    p = np.array([x[2] for x in runs], dtype=float)
    v = hz / r
    t = p / v
    stage = [index.get(x[1]) for x in runs]
    out: list[StepProblem] = []
    tol = 1 + REL_TOL

    def problem(rule: Rule, kind: str, i: int, j: int, **kw: object) -> StepProblem:
        return StepProblem(rule, kind, n, fam, stage[i], stage[j], float(v[i]), float(v[j]),
                           **kw)  # type: ignore[arg-type]

    for i in np.flatnonzero(v > motor.top_pps * tol).tolist():
        out.append(problem("top-speed", "top", i, i))
    if v[0] > motor.start_pps * tol:
        out.append(problem("start-speed", "start", 0, 0, dwell_side=runs[0][0]))
    if v[-1] > motor.start_pps * tol:
        out.append(problem("start-speed", "stop", len(v) - 1, len(v) - 1, dwell_side=runs[-1][0]))
    if len(v) < 2:
        return out
    dv = np.diff(v)
    up = dv > 0
    lo, hi = np.minimum(v[:-1], v[1:]), np.maximum(v[:-1], v[1:])
    cap = np.where(up, motor.min_a_acc_pps2(lo, hi), motor.min_a_dec_pps2(lo, hi))
    dwell = np.where(up, np.arange(len(dv)), np.arange(1, len(dv) + 1))  # the slower segment
    with np.errstate(divide="ignore"):
        need = np.abs(dv) / t[dwell]
    phases = [x[0] for x in runs]
    bad_jump = np.abs(dv) > motor.jump_pps * tol
    bad_cap = (dv != 0) & (need > cap * tol)
    for i in np.flatnonzero(bad_jump | bad_cap).tolist():
        k = int(dwell[i])
        switch = phases[i] == "accel" and phases[i + 1] == "decel"
        kw = dict(dwell_pulses=int(p[k]), dwell_stage=stage[k], dwell_side=phases[k],
                  need_pps2=float(need[i]), cap_pps2=float(cap[i]))
        if switch:
            out.append(problem("switch", "switch", i, i + 1, **kw))
            continue
        if bad_jump[i]:
            out.append(problem("jump", "step", i, i + 1, **kw))
        if bad_cap[i]:
            out.append(problem("accel" if up[i] else "decel", "step", i, i + 1, **kw))
    return out


def all_length_problems(table: FreeCurveTable | InitTable, motor: Motor, *,
                        high_rate: int = 0, exhaustive: bool = False) -> list[StepProblem]:
    """The criterion over every move length 1..0xFFFFFFFF (each family's shortest move).

    A table whose sides have the same stages and whose triangles never switch down
    (`switch_safe`: every symmetric table, and stepramp's LE=1 plans) runs in every
    triangle only steps its trapezoid runs too, with no less dwell, and starts and stops
    on its slowest stage: when its trapezoid passes, every move does (`exhaustive`
    judges every family anyway; the tests hold the two equal)."""
    free = as_free_curve(table)
    if not exhaustive and high_rate == 0 and _same_stages_switch_safe(free):
        longest = simulate_move(free, min(free.accel_total + free.decel_total + 1,
                                          MOVE_PULSES_MAX))
        if not execution_problems(longest, motor, free.rates):
            return jerk_problems(free, motor)
        # unsafe: every family is judged, so each problem names its shortest move
    out: list[StepProblem] = []
    hz = free.clock.hz
    for fam in move_families(free, high_rate=high_rate):
        out += runs_problems(fam.runs(), hz, fam.lo, motor, free.rates, (fam.lo, fam.hi))
    return out + jerk_problems(free, motor)


def _same_stages_switch_safe(table: FreeCurveTable) -> bool:
    if len(table.accel_pulses) != len(table.decel):
        return False
    if table.decel_pulses is None or table.accel_pulses == table.decel_pulses:
        return True
    return switch_safe(np.asarray(table.accel_pulses[::-1]), np.asarray(table.decel[::-1]))


def switch_safe(n: np.ndarray, d: np.ndarray) -> bool:
    """Whether every triangle of an LE=1 table with accel counts `n` and decel counts `d`
    (slowest first, both sides on the same stages) starts its decel on a stage at least
    as fast as the one its accel reached, and never starts a decel-only move above the
    slowest stage (the move model of profiles.ppmc312.execution: shares
    q_a = ⌊rest·a/(a+d)⌋ and q_d = rest − q_a, each from its side's slow end)."""
    return bool(switch_safe_rows(n, np.asarray(d, dtype=np.int64)[None, :])[0])


def switch_safe_rows(n: np.ndarray, d: np.ndarray) -> np.ndarray:
    """`switch_safe` for each row of decel counts `d` (rows × stages) against the same
    accel counts `n`, at once."""
    n = np.asarray(n, dtype=np.int64)
    d = np.asarray(d, dtype=np.int64)
    a = int(n.sum())
    if a == 0:
        return np.zeros(len(d), dtype=bool)
    dd = d.sum(axis=1)
    total = (a + dd)[:, None]
    cn = np.cumsum(n)[:-1][None, :]
    cd = np.cumsum(d, axis=1)[:, :-1]
    rest = -(-(cn + 1) * total // a)                 # first rest whose accel enters j + 1
    q_dec = -(-(rest * dd[:, None]) // total)
    decel_only = -(-(a + dd) // a) - 1                 # longest rest with no accel pulse
    return (dd > 0) & np.all(q_dec >= cd + 1, axis=1) & (decel_only <= d[:, 0])


def length_problems(table: FreeCurveTable | InitTable, motor: Motor, pulses: Iterable[int], *,
                    high_rate: int = 0) -> list[StepProblem]:
    """The criterion over the moves of the given lengths only (the jerk rule when one of
    them runs the whole table, a trapezoid)."""
    free = as_free_curve(table)
    out: list[StepProblem] = []
    trapezoid = False
    for n in sorted(set(pulses)):
        run = simulate_move(free, n, high_rate=high_rate)
        trapezoid |= run.shape == "trapezoid"
        out += execution_problems(run, motor, free.rates)
    return out + (jerk_problems(free, motor) if trapezoid else [])


def all_length_safe(table: FreeCurveTable | InitTable, motor: Motor) -> bool:
    return not all_length_problems(table, motor)


def jerk_problems(table: FreeCurveTable, motor: Motor) -> list[StepProblem]:
    """With `max_jerk_pps3`: per side, slowest first, the slope during stage k is
    σ_k = (f_(k+1) − f_k)/t_k (σ = 0 before the first stage and in the top stage), and
    every stage obeys |σ_k − σ_(k−1)| / t_k ≤ max_jerk_pps3."""
    if motor.max_jerk_pps3 is None:
        return []
    jerk = float(motor.max_jerk_pps3)
    out = []
    for side, counts in (("accel", table.accel_pulses), ("decel", table.decel)):
        f = table.clock.hz / np.asarray(table.rates[: len(counts)], dtype=float)[::-1]
        n = np.asarray(counts, dtype=float)[::-1]
        t = n / f
        m = len(f)
        sigma = np.zeros(m)
        sigma[:-1] = np.diff(f) / t[:-1]
        prev = np.concatenate(([0.0], sigma[:-1]))
        rate = np.abs(sigma - prev) / t
        for i in np.flatnonzero(rate > jerk * (1 + REL_TOL)).tolist():
            k = m - 1 - i  # fastest-first index
            out.append(StepProblem("jerk", "step", 0, (0, 0), k, k, float(prev[i]),
                                   float(sigma[i]), int(n[i]), k, side, float(rate[i]), jerk))
    return out
