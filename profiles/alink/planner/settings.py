"""A-Link ALUM settings planner: the fastest stall-safe settings for a motor.

The unit ramps at one constant (or 1 − cos) acceleration between a start and a
high speed, so the planner searches every high speed the unit can run and gives
each the fastest start speed and ramp the motor's torque allows.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ...errors import FieldRangeError, PlanError, StepRampError, require_int, require_number
from ...motor import Motor
from ...result import PlanResult
from ..model import (
    BANDS_BY_HIGH,
    BANDS_BY_MAX,
    MOVE_PULSES_MAX,
    PPS2_PER_INV_PARA,
    SPEED_MAX_PPS,
    STEPS_MAX,
    AlinkSettings,
    UnitMoveShape,
    max_setting,
    move_time_s,
    move_times,
    quantise_settings,
)

S_CURVE_PEAK_FACTOR = math.pi / 2  # peak / average acceleration of the 1 − cos law


def high_speeds(top: float, max_int: int, motor_top: float) -> tuple[np.ndarray, np.ndarray]:
    """Every high speed the unit can set up to `top` [pps] (each whole multiple of its
    multiplier, by the bands of MAX_SPEED `max_int`, 0: unset) and its multiplier."""
    bands = BANDS_BY_HIGH if max_int == 0 else BANDS_BY_MAX
    vh_all, m_all = [], []
    lower = 0
    for upper, m in bands:
        if max_int and not lower < max_int <= upper:
            lower = upper
            continue
        hi = min(upper, top) if max_int == 0 else min(max_int, top)
        first = (lower // m + 1) * m if max_int == 0 else m
        if hi >= first:
            speeds = np.arange(first, math.floor(hi) // m * m + 1, m, dtype=np.int64)
            vh_all.append(speeds)
            m_all.append(np.full(len(speeds), m, dtype=np.int64))
        lower = upper
    if not vh_all:
        raise FieldRangeError("motor.top_pps", motor_top, 2, SPEED_MAX_PPS)
    return np.concatenate(vh_all), np.concatenate(m_all)


def _binds(shape: UnitMoveShape | None, at_fastest: bool, top: float, motor_top: float,
           max_int: int, ramp_limit_s: float | None) -> str:
    """What limits the chosen settings (`ramp_limit_s`: planned without a move length)."""
    if shape == "triangle":
        return "move length (the ramps meet before the high speed)"
    if at_fastest:
        return ("top speed (" + ("the motor's" if top == motor_top else
                                 "MAX_SPEED" if top == max_int else "the unit's maximum")
                + f", {top:g} pps)")
    if ramp_limit_s is not None:
        return f"ramp time limit ({ramp_limit_s:g} s)"
    # a higher speed would need a slower ramp (less torque up there) and lose time
    return "motor torque (a higher speed needs a slower ramp)"


def plan_settings(motor: Motor, *, pulses: int | None = None, max_pps: float = 0,
                  s_curve: bool = False,
                  ramp_limit_s: float = 1.0) -> PlanResult[AlinkSettings]:
    """Fastest stall-safe settings for `motor`.

    Every candidate high speed (each whole multiple of its multiplier up to the motor's
    top speed) gets the fastest start speed ≤ start_pps and jump_pps and the fastest
    para whose constant acceleration stays ≤ min a_acc and ≤ min a_dec over [start, high]
    (for the S-curve the 1 − cos peak, π/2 × average, is held to that bound). With
    `pulses`, the candidate with the shortest predicted move wins; without, the highest
    speed whose ramp lasts at most `ramp_limit_s`.

    `duration_s` is the predicted move (None without `pulses`); `extras`: `shape`
    (trapezoid / triangle, None without `pulses`), `ramp_time_s`, `ramp_pulses`
    (one ramp) and `accel_limit_pps2` (the motor's bound the ramp respects: the
    minimum of a_acc and a_dec over [start, high]).
    """
    started = time.perf_counter()
    if pulses is not None:
        require_int("pulses", pulses, 1, MOVE_PULSES_MAX)
    require_number("ramp_limit_s", ramp_limit_s, 0, 3600, lo_open=True)
    max_int = max_setting(max_pps)
    top = min(motor.top_pps, max_int or SPEED_MAX_PPS, SPEED_MAX_PPS)
    start_cap = min(motor.start_pps, motor.jump_pps)
    vh, mult = high_speeds(top, max_int, motor.top_pps)
    fastest = int(vh[-1])  # the fastest high speed the unit and the motor allow
    v0 = np.floor(start_cap / mult) * mult
    v0 = np.minimum(v0, vh)
    a_lim = np.minimum(motor.min_a_acc_pps2(v0, vh), motor.min_a_dec_pps2(v0, vh))
    peak_factor = S_CURVE_PEAK_FACTOR if s_curve else 1.0
    a_avg_lim = a_lim / peak_factor
    with np.errstate(divide="ignore", invalid="ignore"):
        para_exact = PPS2_PER_INV_PARA / a_avg_lim
        para = np.ceil(para_exact * (1 + 1e-12) / mult) * mult
    para = np.maximum(para, mult)
    ok = (v0 >= mult) & (a_lim > 0) & np.isfinite(para) & (para <= STEPS_MAX * mult)
    if not ok.any():
        raise StepRampError(f"{motor.name or 'motor'}: no A-Link setting is stall-safe (start "
                            f"speed {start_cap:g} pps, acceleration bounds outside "
                            "the para ranges); lower the load or set MAX_SPEED")
    vh, mult, v0, para, a_lim = vh[ok], mult[ok], v0[ok], para[ok], a_lim[ok]
    a = PPS2_PER_INV_PARA / para
    ramp_t = (vh - v0) / a
    if pulses is not None:
        t, _, _, _ = move_times(v0, vh, a, pulses, avoid=False)
        best = int(np.argmin(t))
    else:
        fits = np.flatnonzero(ramp_t <= ramp_limit_s)
        best = int(fits[-1]) if len(fits) else int(np.argmin(ramp_t))
    warnings: list[str] = []
    if pulses is None and ramp_t[best] > ramp_limit_s:
        warnings.append(f"no setting ramps within {ramp_limit_s:g} s; the quickest ramp takes "
                        f"{ramp_t[best]:.3g} s")
    if v0[best] < start_cap:
        warnings.append(f"self-start speed {v0[best]:g} pps (motor allows {start_cap:g}: "
                        f"multiplier ×{mult[best]})")
    settings = AlinkSettings(int(v0[best]), int(vh[best]), int(para[best]), max_int, s_curve,
                             False, tuple(warnings))
    predicted = None
    shape: UnitMoveShape | None = None
    if pulses is not None:
        mt = move_time_s(settings, pulses)
        predicted, shape = mt.duration_s, mt.shape
    binds = _binds(shape, vh[best] == fastest, top, motor.top_pps, max_int,
                   None if pulses is not None else ramp_limit_s)
    ramp_pulses = float((vh[best] ** 2 - v0[best] ** 2) / (2 * a[best]))
    info = (f"×{settings.multiplier}: start {settings.start_pps} pps, high {settings.high_pps} "
            f"pps, UP_TIME para {settings.accel_para} ({settings.accel_pps2:.6g} pps/s, motor "
            f"bound {a_lim[best]:.6g})" + ("" if predicted is None else
                                           f"; {shape} move of {predicted:.6g} s"))
    return PlanResult(settings, predicted, binds, info, pulses, None,
                      time.perf_counter() - started, tuple(warnings),
                      {"shape": shape, "ramp_time_s": float(ramp_t[best]),
                       "ramp_pulses": ramp_pulses, "accel_limit_pps2": float(a_lim[best])})


# --- tightened until the load angle is within the aim ------------------------------------------

START_FACTOR = 0.85   # a start-speed round: L × this (down to one multiplier step)
RAMP_FACTOR = 1.25    # a ramp round: the para × this (a gentler ramp), up to 8000·m
HIGH_FACTOR = 0.9     # at the slowest ramp: the high speed × this
MAX_ROUNDS = 40


@dataclass(frozen=True)
class Judgement:
    """What a settings judge (profiles.alink.safety.settings_judge) says of settings: within
    the load-angle aim or not, the worst angle, the lever it blames ("start": short moves
    and early stops, near the start speed; "ramp": the ramp higher up) and one line."""

    within_aim: bool
    worst_deg: float
    blame: Literal["start", "ramp"]
    what: str


SettingsJudge = Callable[[AlinkSettings], Judgement]


@dataclass(frozen=True)
class Tightened:
    """Settings tightened until a judge finds them within the aim, and the price."""

    settings: AlinkSettings
    before: AlinkSettings
    rounds: int
    judgement: Judgement
    price: str            # plain words: what changed and what it costs ("" when nothing did)


def tighten_settings(motor: Motor, settings: AlinkSettings, judge: SettingsJudge, *,
                     aim_deg: float, pulses: int | None = None) -> Tightened:
    """`settings` made gentler, a lever a round, until `judge` finds them within the aim:
    the start speed L lowered (START_FACTOR) when the judge blames short moves, else the
    ramp made gentler (RAMP_FACTOR on the para), and at the slowest ramp the high speed
    lowered (HIGH_FACTOR). Refused (PlanError, naming what would help) when no lever is
    left. `pulses`: the move whose time the price names (else the shortest that reaches
    the high speed before, and the worst short move)."""
    s = settings
    first: Judgement | None = None
    for rounds in range(MAX_ROUNDS):
        verdict = judge(s)
        first = first or verdict
        if verdict.within_aim:
            return Tightened(s, settings, rounds, verdict,
                             _price(settings, s, (first, verdict), aim_deg, pulses))
        nxt = _gentler(s, verdict.blame, motor)
        if nxt is None:
            break
        s = nxt
    raise PlanError(f"{motor.name or 'motor'}: no A-Link setting keeps every move within "
                    f"{aim_deg:g}°: at L_SPEED {s.start_pps} pps, H_SPEED {s.high_pps} pps, "
                    f"UP_TIME para {s.accel_para} the worst is {verdict.worst_deg:.1f}° "
                    f"({verdict.what}); a lower speed limit (--max-pps), less load inertia, "
                    "a higher drive current or a coarser microstep would help")


def _gentler(s: AlinkSettings, blame: str, motor: Motor) -> AlinkSettings | None:
    """The settings one lever gentler (None: no lever left)."""
    m = s.multiplier
    levers = ("start", "ramp", "high") if blame == "start" else ("ramp", "high", "start")
    for lever in levers:
        start, high, para = s.start_pps, s.high_pps, s.accel_para
        if lever == "start":
            start = max(math.floor(start * START_FACTOR / m) * m, m)
        elif lever == "ramp":
            para = min(math.ceil(para * RAMP_FACTOR / m) * m, STEPS_MAX * m)
        else:
            high = max(math.floor(high * HIGH_FACTOR), start + m)
        if (start, high, para) == (s.start_pps, s.high_pps, s.accel_para):
            continue
        try:
            return quantise_settings(min(start, high), high, para / 100, s.max_pps,
                                     s_curve=s.s_curve,
                                     triangle_avoidance=s.triangle_avoidance)
        except StepRampError:
            continue
    return None


def _price(before: AlinkSettings, after: AlinkSettings, verdicts: tuple[Judgement, Judgement],
           aim_deg: float, pulses: int | None) -> str:
    """What the tightening changed and what it costs, in plain words (`verdicts`: the
    judge's on the settings before and after)."""
    if after == before:
        return ""
    changes = []
    if after.start_pps != before.start_pps:
        changes.append(f"start speed lowered to {after.start_pps} pps (from "
                       f"{before.start_pps})")
    if after.accel_para != before.accel_para:
        changes.append(f"ramp made gentler (UP_TIME para {before.accel_para} → "
                       f"{after.accel_para}, {after.accel_pps2:.6g} pps/s)")
    if after.high_pps != before.high_pps:
        changes.append(f"high speed lowered to {after.high_pps} pps (from {before.high_pps})")
    lengths = [pulses] if pulses is not None else sorted({
        max(1, math.ceil((before.high_pps**2 - before.start_pps**2) / before.accel_pps2)),
        100})
    costs = []
    for n in lengths:
        t0, t1 = move_time_s(before, n).duration_s, move_time_s(after, n).duration_s
        which = ("" if pulses is not None or n == 100 else
                 " (the shortest that reached the high speed)")
        costs.append(f"a move of {n} pulses{which} takes {t1 * 1e3:.4g} ms instead of "
                     f"{t0 * 1e3:.4g} ms ({t1 / t0 - 1:+.1%})")
    was, now = verdicts
    return (", ".join(changes) + f" to keep every move within {aim_deg:g}° (worst "
            f"{was.worst_deg:.1f}° → {now.worst_deg:.1f}°, {was.what}): " + "; ".join(costs))
