"""The stall-safety criterion (issue #3) as findings.

Stages are read slowest first: speeds f_1 < … < f_N, stage k emits n_k pulses
lasting t_k = n_k / f_k. A table is stall-safe for a motor when
- f_1 ≤ start_pps (the motor can start and stop there without a ramp);
- f_N ≤ motor.top_pps (last point of the pull-out curve, capped by max_pps);
- f_{k+1} − f_k ≤ motor.jump_pps for every step;
- (f_{k+1} − f_k) / t_k ≤ min a(v) over [f_k, f_{k+1}] (a_acc for the accel
  counts, a_dec for the decel counts): the piecewise-linear ramp through the
  stage starts is within the motor's capability, so the staircase (which lags
  that ramp) is too;
- with max_jerk_pps3: the slope during stage k is σ_k = (f_{k+1} − f_k)/t_k,
  σ_0 = 0 before the first stage (rest) and σ_N = 0 in the top stage (cruise);
  every stage k obeys |σ_k − σ_{k−1}| / t_k ≤ max_jerk_pps3.
LE=1 tables with different accel and decel stage counts: each side uses the
fastest stages it counts (the table's shared-rate reading).
Stage numbers in messages are fastest-first indices, as in the table.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from profiles.motor import Motor
from profiles.ppmc312.table import FreeCurveTable

from .findings import Finding

# Planners round pulse counts up with exact float arithmetic; this relative slack
# only absorbs the last-bit difference between their arithmetic and ours.
REL_TOL = 1e-9


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


def check_stall(table: FreeCurveTable, motor: Motor) -> list[Finding]:
    """Every way `table` breaks the stall-safety criterion for `motor`, as error findings."""
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
    hz = table.clock.hz
    top = hz / rates[0]
    if top > motor.top_pps * (1 + REL_TOL):
        need_rate = math.ceil(hz / motor.top_pps)
        out.append(Finding("error", "stall-top-speed",
                           f"fastest stage rates[0] = {rates[0]} runs {top:.6g} pps, above the "
                           f"motor's top usable speed {motor.top_pps:.6g} pps: raise rates[0] to "
                           f"≥ {need_rate}", stage=0))
    start_rate = math.ceil(hz / motor.start_pps * (1 - REL_TOL))
    seen: set[int] = set()
    for side, counts in (("accel", table.accel_pulses), ("decel", table.decel)):
        if not counts or len(counts) - 1 in seen:
            continue  # LE=0 or equal stage counts: one slowest stage, one finding
        k = len(counts) - 1
        seen.add(k)
        f1 = hz / rates[k]
        if f1 > motor.start_pps * (1 + REL_TOL):
            out.append(Finding("error", "stall-start-speed",
                               f"slowest {side} stage rates[{k}] = {rates[k]} runs {f1:.6g} pps, "
                               f"above the start speed {motor.start_pps:.6g} pps: raise rates[{k}] "
                               f"to ≥ {start_rate}", stage=k))
    longest = max(len(table.accel_pulses), len(table.decel))
    speeds = hz / np.asarray(rates[:longest], dtype=float)
    jumps = speeds[:-1] - speeds[1:]
    for k in np.flatnonzero(jumps > motor.jump_pps * (1 + REL_TOL)).tolist():
        slower = k + 1
        out.append(Finding("error", "stall-jump",
                           f"stage {slower} → {slower - 1} steps from {speeds[slower]:.6g} to "
                           f"{speeds[slower - 1]:.6g} pps (+{jumps[k]:.6g}), above the largest "
                           f"jump {motor.jump_pps:.6g} pps: insert a stage between rates "
                           f"{rates[slower]} and {rates[slower - 1]}", stage=slower))
    for side, counts, cap, rule in (
            ("accel", table.accel_pulses, motor.min_a_acc_pps2, "stall-accel"),
            ("decel", table.decel, motor.min_a_dec_pps2, "stall-decel")):
        sp, n = _side(table, counts)
        s = _slopes(sp, n, cap)
        bad = s["need"] > s["cap"] * (1 + REL_TOL)
        for k in np.flatnonzero(bad).tolist():
            capk = float(s["cap"][k])
            head = (f"{side}_pulses[{k}] = {int(n[k])} at {sp[k]:.6g} pps then +{s['delta'][k]:.6g}"
                    f" pps needs {s['need'][k]:.6g} pps/s")
            if capk <= 0:
                out.append(Finding("error", rule, f"{head}, but the motor cannot {side}erate "
                                   f"between {sp[k]:.6g} and {sp[k - 1]:.6g} pps at all: lower the "
                                   f"top speed below {sp[k]:.6g} pps", stage=k))
                continue
            want = math.ceil(s["delta"][k] * sp[k] / capk)
            out.append(Finding("error", rule, f"{head}, the motor gives {capk:.6g} pps/s: raise "
                               f"{side}_pulses[{k}] from {int(n[k])} to ≥ {want}", stage=k))
        if motor.max_jerk_pps3 is not None:
            out.extend(_jerk(side, sp, n, float(motor.max_jerk_pps3)))
    return out


def _jerk(side: str, speeds_fast_first: np.ndarray, counts_fast_first: np.ndarray,
          jerk: float) -> list[Finding]:
    f = speeds_fast_first[::-1]
    n = counts_fast_first[::-1]
    t = n / f
    m = len(f)
    sigma = np.zeros(m)  # slope during each stage (slowest first); the top stage cruises
    sigma[:-1] = np.diff(f) / t[:-1]
    prev = np.concatenate(([0.0], sigma[:-1]))
    rate = np.abs(sigma - prev) / t
    out = []
    for i in np.flatnonzero(rate > jerk * (1 + REL_TOL)).tolist():
        k = m - 1 - i  # fastest-first index
        out.append(Finding("error", "stall-jerk",
                           f"{side} slope changes from {prev[i]:.6g} to {sigma[i]:.6g} pps/s over "
                           f"stage {k} ({t[i] * 1e3:.6g} ms): {rate[i]:.6g} pps/s² exceeds "
                           f"max_jerk_pps3 {jerk:.6g}: raise {side}_pulses[{k}] (and the "
                           "counts around it)", stage=k))
    return out
