"""The stall-safety criterion as findings, judged on every execution the chip runs.

The rules and how every move length is covered without iterating lengths are in
`profiles.ppmc312.criterion`; this module groups its problems (the same step in
many executions is one finding, naming the shortest move that runs it) and says
what to change, with numbers. `stall_margins` is the table's own view: capability
/ need per stage and side, as the trapezoid runs them.
LE=1 tables with different accel and decel stage counts: each side uses the
fastest stages it counts (the table's shared-rate reading).
Stage numbers in messages are fastest-first indices, as in the table.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from profiles.findings import Finding
from profiles.motor import Motor
from profiles.ppmc312.criterion import (
    REL_TOL,
    StepProblem,
    all_length_problems,
    length_problems,
)
from profiles.ppmc312.table import FreeCurveTable


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
