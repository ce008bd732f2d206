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

This module computes; `profiles.ppmc312.criterion` turns problems into findings with fixes.
Planners use it to prove their own tables (profiles never imports verify).

The findings (the second half, here since issue 34 item 2 put each judge beside its
rules): `check_stall` groups the problems (the same step in many executions is one
finding, naming the shortest move that runs it) and says what to change, with numbers;
`stall_margins` is the table's own view: capability / need per stage and side, as the
trapezoid runs them. LE=1 tables with different accel and decel stage counts: each side
uses the fastest stages it counts (the table's shared-rate reading). Stage numbers in
messages are fastest-first indices, as in the table.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from ..findings import Finding
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


# --- the criterion's problems as findings -----------------------------------------------

def _side(table: FreeCurveTable, counts: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Speeds and counts of one side, fastest first (the fastest len(counts) stages)."""
    speeds = table.clock.hz / np.asarray(table.rates[: len(counts)], dtype=float)
    return speeds, np.asarray(counts, dtype=float)


def _ordered(table: FreeCurveTable) -> bool:
    rates = np.asarray(table.rates, dtype=np.int64)
    return bool(len(rates) == 0 or (rates[0] > 0 and np.all(np.diff(rates) > 0)))


def _slopes(speeds: np.ndarray, counts: np.ndarray, cap: Any) -> dict[str, np.ndarray]:
    """Per stage (fastest first) of one side: the step above it and what it needs/gets."""
    n = len(speeds)
    need = np.zeros(n)
    capab = np.full(n, np.inf)
    delta = np.zeros(n)
    if n >= 2:
        slow, fast = speeds[1:], speeds[:-1]
        delta[1:] = fast - slow
        with np.errstate(divide="ignore", invalid="ignore"):
            need[1:] = delta[1:] * slow / np.maximum(counts[1:], 1e-300)
        capab[1:] = cap(slow, fast)
    return {"delta": delta, "need": need, "cap": capab}


def stall_margins(table: FreeCurveTable, motor: Motor) -> dict[str, Any]:
    """Capability / need per stage (fastest first; inf where the speed does not change).

    Keys: "accel", "decel" (arrays as long as each side), "min" (smallest margin;
    < 1 means the criterion is broken somewhere).
    """
    out: dict[str, Any] = {}
    for name, counts, cap in (("accel", table.accel_pulses, motor.min_a_acc_pps2),
                              ("decel", table.decel, motor.min_a_dec_pps2)):
        speeds, n = _side(table, counts)
        s = _slopes(speeds, n, cap)
        with np.errstate(divide="ignore", invalid="ignore"):
            margin = np.where(s["need"] > 0, s["cap"] / np.where(s["need"] > 0, s["need"], 1.0),
                              np.inf)
        out[name] = margin
    parts = [out["accel"], out["decel"]]
    out["min"] = float(min((float(np.min(p)) for p in parts if len(p)), default=math.inf))
    return out


def check_stall(table: FreeCurveTable, motor: Motor, *, pulses: Iterable[int] | None = None,
                high_rate: int = 0) -> list[Finding]:
    """Every way the chip's executions of `table` break the stall-safety criterion for
    `motor`, as error findings: over every move length 1..0xFFFFFFFF when `pulses` is
    None, else over the moves of those lengths (profiles.ppmc312.criterion)."""
    out: list[Finding] = []
    rates = table.rates
    if not _ordered(table):
        for i in range(len(rates) - 1):
            if not rates[i] < rates[i + 1]:
                out.append(Finding("error", "stall-order",
                                   f"rates[{i}] = {rates[i]} and rates[{i + 1}] = {rates[i + 1]}: "
                                   "rates must strictly increase from the fastest stage to the "
                                   "slowest (speeds strictly fall); sort them and drop repeats",
                                   stage=i + 1))
        if any(r <= 0 for r in rates):
            out.append(Finding("error", "stall-order", "a rate of 0 gives no speed; every rate "
                               "must be ≥ 2"))
        return out  # speeds, steps and slopes mean nothing until the order is fixed
    if not rates:
        return out
    problems = (all_length_problems(table, motor, high_rate=high_rate) if pulses is None
                else length_problems(table, motor, pulses, high_rate=high_rate))
    return findings_from_problems(table, motor, problems)


def _key(p: StepProblem) -> tuple[object, ...]:
    if p.rule == "jump":
        pair = (p.stage_from, p.stage_to)
        return (p.rule, min(pair, key=_idx), max(pair, key=_idx))
    if p.rule in ("accel", "decel"):
        return (p.rule, p.dwell_stage, p.dwell_pulses, p.stage_from, p.stage_to)
    if p.rule == "switch":  # one finding for all switches: they share one cause and fix
        return (p.rule,)
    if p.rule == "jerk":
        return (p.rule, p.dwell_side, p.stage_from)
    return (p.rule, p.stage_from)


def _idx(stage: int | None) -> int:
    return -1 if stage is None else stage


def findings_from_problems(table: FreeCurveTable, motor: Motor,
                           problems: list[StepProblem]) -> list[Finding]:
    """One finding per distinct problem (the same step in many executions is one finding,
    naming the shortest move length that runs it), in a stable order."""
    groups: dict[tuple[object, ...], list[StepProblem]] = {}
    for p in problems:
        groups.setdefault(_key(p), []).append(p)
    out = [_finding(table, motor, g) for g in groups.values()]
    order = {"top-speed": 0, "start-speed": 1, "jump": 2, "accel": 3, "decel": 4, "switch": 5,
             "jerk": 6}
    return sorted(out, key=lambda f: (order[f.rule[len("stall-"):]], _idx(f.stage)))


def _finding(table: FreeCurveTable, motor: Motor, group: list[StepProblem]) -> Finding:
    """The finding of one distinct problem: its message by rule, naming the shortest move
    that runs it (the jerk's names the stage's counts instead)."""
    p = min(group, key=lambda q: q.pulses)
    shortest = f" (shortest move that runs it: {p.pulses} pulses)" if p.pulses else ""
    if p.rule == "jerk":
        return Finding("error", "stall-jerk",
                       f"{p.dwell_side} slope changes from {p.v_from_pps:.6g} to "
                       f"{p.v_to_pps:.6g} pps² over stage {p.stage_from}: {p.need_pps2:.6g} "
                       f"pps³ exceeds max_jerk_pps3 {p.cap_pps2:.6g}: raise "
                       f"{p.dwell_side}_pulses[{p.stage_from}] (and the counts around it)",
                       stage=p.stage_from)
    message, stage = _MESSAGES[p.rule](table, motor, group, p)
    return Finding("error", f"stall-{p.rule}", message + shortest, stage=stage)


def _rate(stage: int | None) -> str:
    return "the high-rate override" if stage is None else f"rates[{stage}]"


def _top_speed(table: FreeCurveTable, motor: Motor, group: list[StepProblem],
               p: StepProblem) -> tuple[str, int | None]:
    need_rate = math.ceil(table.clock.hz / motor.top_pps)
    return (f"stage {_rate(p.stage_from)} runs {p.v_from_pps:.6g} pps, above the motor's top "
            f"usable speed {motor.top_pps:.6g} pps: raise it to ≥ {need_rate}", p.stage_from)


def _start_speed(table: FreeCurveTable, motor: Motor, group: list[StepProblem],
                 p: StepProblem) -> tuple[str, int | None]:
    kinds = {q.kind for q in group}
    verb = ("start and stop" if kinds == {"start", "stop"} else
            "start from rest" if kinds == {"start"} else "stop")
    # The side the move starts (stops) on, as the criterion saw it: an LE=1 move can
    # start on a decel stage (its accel share empty) or stop on an accel one.
    sides = {q.dwell_side for q in group} & {"accel", "decel"}
    side = (sides.pop() if len(sides) == 1 else
            "accel" if kinds == {"start"} else "decel")
    start_rate = math.ceil(table.clock.hz / motor.start_pps * (1 - REL_TOL))
    k = p.stage_from
    slowest = k is not None and k == len(table.accel_pulses if side == "accel"
                                         else table.decel) - 1
    fix = (f"raise {_rate(k)} to ≥ {start_rate}" if slowest else
           "give both sides the same stage count (LE=1 shares the fastest stages), so no "
           "move starts or stops on a faster stage"
           if len(table.accel_pulses) != len(table.decel) else
           f"change the LE=1 pulse counts so that no move {verb.split()[0]}s on this "
           "faster stage" + ("" if k is None else f", or raise {_rate(k)} to ≥ {start_rate}"))
    what = f"slowest {side} stage" if slowest else f"{side} stage"
    return (f"moves {verb} at the {what} {_rate(k)} = "
            f"{'' if k is None else table.rates[k]} ({p.v_from_pps:.6g} pps), above the start "
            f"speed {motor.start_pps:.6g} pps: {fix}", k)


def _jump(table: FreeCurveTable, motor: Motor, group: list[StepProblem],
          p: StepProblem) -> tuple[str, int | None]:
    slow, fast = sorted(((p.stage_from, p.v_from_pps), (p.stage_to, p.v_to_pps)),
                        key=lambda sv: sv[1])
    jump = fast[1] - slow[1]
    return (f"stage {_idx(slow[0])} → {_idx(fast[0])} steps from {slow[1]:.6g} to "
            f"{fast[1]:.6g} pps (+{jump:.6g}), above the largest jump {motor.jump_pps:.6g} pps:"
            f" insert a stage between {_rate(slow[0])} and {_rate(fast[0])}", slow[0])


def _capability(table: FreeCurveTable, motor: Motor, group: list[StepProblem],
                p: StepProblem) -> tuple[str, int | None]:
    side = p.rule
    k = p.dwell_stage
    slow_v = min(p.v_from_pps, p.v_to_pps)
    delta = abs(p.jump_pps)
    head = (f"{side}_pulses[{_idx(k)}] = {p.dwell_pulses} at {slow_v:.6g} pps then "
            f"{'+' if side == 'accel' else '−'}{delta:.6g} pps needs {p.need_pps2:.6g} pps²")
    if p.cap_pps2 <= 0:
        return (f"{head}, but the motor cannot {side}erate between {slow_v:.6g} and "
                f"{max(p.v_from_pps, p.v_to_pps):.6g} pps at all: lower the top speed below "
                f"{slow_v:.6g} pps", k)
    want = math.ceil(delta * slow_v / p.cap_pps2)
    return (f"{head}, the motor gives {p.cap_pps2:.6g} pps²: raise {side}_pulses[{_idx(k)}]"
            f" from {p.dwell_pulses} to ≥ {want}", k)


def _switch(table: FreeCurveTable, motor: Motor, group: list[StepProblem],
            p: StepProblem) -> tuple[str, int | None]:
    worst = max(group, key=lambda q: abs(q.jump_pps))
    lengths = sorted({q.family for q in group})
    span = ", ".join(f"{lo}–{hi}" if hi > lo else f"{lo}" for lo, hi in lengths[:4])
    more = f" and {len(lengths) - 4} more ranges" if len(lengths) > 4 else ""
    why = []
    if abs(p.jump_pps) > motor.jump_pps * (1 + REL_TOL):
        why.append(f"above the largest jump {motor.jump_pps:.6g} pps")
    if p.need_pps2 > p.cap_pps2 * (1 + REL_TOL):
        why.append(f"with {p.dwell_pulses} pulse(s) at {p.v_to_pps:.6g} pps it needs "
                   f"{p.need_pps2:.6g} pps², the motor gives {p.cap_pps2:.6g} pps²")
    return (f"triangle moves of {span}{more} pulses switch from accel stage "
            f"{_idx(p.stage_from)} ({p.v_from_pps:.6g} pps) to decel stage {_idx(p.stage_to)} "
            f"({p.v_to_pps:.6g} pps), {p.jump_pps:+.6g} pps, {'; '.join(why)}: the chip keeps "
            "the accel:decel pulse ratio, so the decel counts must be proportional to the "
            "accel counts from the slow end (stepramp plan makes them so), or use LE=0; "
            f"largest switch jump {worst.jump_pps:+.6g} pps (accel stage "
            f"{_idx(worst.stage_from)} → decel stage {_idx(worst.stage_to)})", p.stage_to)


_MESSAGES = {"top-speed": _top_speed, "start-speed": _start_speed, "jump": _jump,
             "accel": _capability, "decel": _capability, "switch": _switch}


def shortest_failing_pulses(problems: list[StepProblem]) -> int | None:
    """The shortest move length whose execution breaks the criterion (None: none)."""
    lengths = [p.pulses for p in problems if p.pulses]
    return min(lengths) if lengths else (0 if problems else None)
