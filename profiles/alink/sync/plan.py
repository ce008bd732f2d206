"""The A-Link ALUM's two axes, one move: synchronised settings (issue 11).

The unit runs each axis from its own settings (self-start speed, high speed,
UP_TIME para; one constant acceleration for both ramps), speeds whole multiples
of the axis's multiplier, the para a whole multiple of it too. Its motion is the
continuous trapezoid of `profiles.alink.move_time_s`; the pulse instants here
come from that model (the k-th pulse when the trapezoid's position reaches k), a
model like the duration itself. Both axes start on the unit's simultaneous
start (MODE_SIG D5 = STA, manual 11-8): see docs/manual-notes.md.

time mode: the slower axis keeps its fastest settings (`plan_settings`); for the
other, the trapezoid's time is linear in the para for a given high speed,

    T = N / v_h + para · 1e-8 · (v_h − v_0)² / v_h     (trapezoid),

so every high speed (each multiple of its multiplier up to its own fastest)
gets the largest para that is a multiple of the multiplier and keeps T ≤ the
target, no faster than stall-safe; the one ending closest to the target wins.

line mode: settings proportional to the pulses (v_0, v_h and the acceleration
each scaled by N_i / N_lead) keep the two trapezoids proportional, so the
path is straight up to quantisation. The leader's settings are planned for the
envelope motor of both axes; the leader's high speed and para are then searched
near the fastest for the pair whose quantised ratios give the smallest
deviation of the modelled joint path.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from ...errors import AlinkSyncError, echo
from ...joint import Mode, SyncTimes
from ...motor import Motor
from ...motor.envelope import envelope_motor
from ...pulses import Piece, PulseTrain, line_deviation
from .. import (
    PARA_RANGE,
    PPS2_PER_INV_PARA,
    STEPS_MAX,
    AlinkSettings,
    move_time_s,
    multiplier,
    plan_settings,
)
from ..planner import SettingsJudge, tighten_settings

SPEED_POINTS = 400          # an axis's modelled speed: between this many of its pulses
LINE_HIGH_CANDIDATES = 24   # leader high speeds tried (the fastest multiples)
LINE_PARA_CANDIDATES = 12   # leader paras tried (from the stall-safe least up)
MODE_SIG_STA = 1 << 5       # MODE_SIG D5: all axes start on the STA input


@dataclass(frozen=True)
class AlinkAxisMove:
    name: str
    pulses: int   # signed
    motor: Motor
    settings: AlinkSettings
    fastest_s: float
    how: str

    @property
    def duration_s(self) -> float:
        return move_time_s(self.settings, abs(self.pulses)).duration_s

    def pulse_times_s(self) -> np.ndarray:
        return pulse_times_s(self.settings, abs(self.pulses))

    def pulse_train(self) -> PulseTrain:
        return pulse_train(self.settings, abs(self.pulses))

    def facts(self) -> dict[str, Any]:
        """What the sync report says of this axis's settings."""
        s = self.settings
        return {"start_pps": s.start_pps, "high_pps": s.high_pps, "up_time_para": s.accel_para,
                "multiplier": s.multiplier}

    def speed_steps(self, points: int = SPEED_POINTS) -> tuple[np.ndarray, np.ndarray, bool]:
        """(t [s], speed [pps], stepped): the modelled speed between pulses spread evenly
        over the move (`points` of them), drawn as a line."""
        train = self.pulse_train()
        k = np.unique(np.linspace(1, train.count, points).astype(np.int64))
        tk = train.time_of(k)
        if len(k) < 2:
            return tk[:0], tk[:0], False
        return tk[1:], np.diff(k) / np.diff(tk), False


@dataclass(frozen=True)
class AlinkSyncPlan(SyncTimes):
    mode: Mode
    axes: tuple[AlinkAxisMove, ...]
    info: str


def pulse_times_s(settings: AlinkSettings, pulses: int) -> np.ndarray:
    """The instant of each pulse k = 1..pulses: when the modelled trapezoid (or triangle)
    reaches position k. Linear ramps (the S-curve has the same time but other instants)."""
    return pulse_train(settings, pulses).time_of(np.arange(1, pulses + 1))


def pulse_train(settings: AlinkSettings, pulses: int) -> PulseTrain:
    """`pulse_times_s` as pieces (any number of pulses): the ramps, and the cruise at
    exactly 1/high speed between them."""
    v0, vh, a = float(settings.start_pps), float(settings.high_pps), settings.accel_pps2
    n = float(pulses)
    ramp = (vh * vh - v0 * v0) / (2 * a)
    cruise = 2 * ramp <= n
    if not cruise:                        # triangle: the peak where the ramps meet
        vh = math.sqrt(v0 * v0 + a * n)
        ramp = n / 2
    t_ramp = (vh - v0) / a
    total = 2 * t_ramp + (n - 2 * ramp) / vh

    def up(x: np.ndarray) -> np.ndarray:  # time to cover x pulses from v0 at acceleration a
        return 2 * x / (v0 + np.sqrt(v0 * v0 + 2 * a * x))

    def times(k: np.ndarray) -> np.ndarray:
        kf = k.astype(float)
        return np.where(kf <= ramp, up(kf),
                        np.where(kf <= n - ramp, t_ramp + (kf - ramp) / vh,
                                 total - up(np.maximum(n - kf, 0.0))))

    k1 = min(math.floor(ramp), pulses)            # the last pulse of the up ramp
    k2 = max(min(math.floor(n - ramp), pulses), k1)  # the last pulse of the cruise
    return PulseTrain([Piece(1, k1, times),
                       Piece(k1 + 1, k2 - k1, times,
                             Fraction(1, settings.high_pps) if cruise else None),
                       Piece(k2 + 1, pulses - k2, times)])


def is_stall_safe(settings: AlinkSettings, motor: Motor) -> bool:
    """The rule `plan_settings` plans by: start ≤ the motor's start and jump speeds, high ≤
    its top, the constant acceleration ≤ min a_acc and min a_dec over [start, high]."""
    v0, vh = settings.start_pps, settings.high_pps
    a = settings.accel_pps2
    cap = min(float(motor.min_a_acc_pps2(v0, vh)), float(motor.min_a_dec_pps2(v0, vh)))
    return (v0 <= min(motor.start_pps, motor.jump_pps) * (1 + 1e-9)
            and vh <= motor.top_pps * (1 + 1e-9) and a <= cap * (1 + 1e-9))


def _least_para(motor: Motor, v0: int, vh: int, m: int) -> int | None:
    cap = min(float(motor.min_a_acc_pps2(v0, vh)), float(motor.min_a_dec_pps2(v0, vh)))
    if cap <= 0:
        return None
    para = max(math.ceil(PPS2_PER_INV_PARA / cap * (1 - 1e-12) / m) * m, PARA_RANGE[m][0])
    return para if para <= PARA_RANGE[m][1] else None


def slow_to(motor: Motor, pulses: int, target_s: float, fastest: AlinkSettings, *,
            start_cap: int | None = None) -> AlinkSettings:
    """Settings whose move lasts closest to `target_s` without exceeding it (see module);
    `start_cap`: a start speed no higher (a tightened axis's)."""
    best: tuple[float, AlinkSettings] = (target_s - move_time_s(fastest, pulses).duration_s,
                                         fastest)
    m_top = fastest.multiplier
    for vh in range(fastest.high_pps, 0, -1):
        m = multiplier(vh)
        if vh % m or m > m_top:
            continue
        v0 = min(int(min(motor.start_pps, motor.jump_pps, start_cap or math.inf)) // m * m,
                 vh)
        if v0 < m:
            continue
        least = _least_para(motor, v0, vh, m)
        if least is None:
            continue
        if vh == v0:
            t_flat = pulses / vh
            para = least
        else:
            slope = (vh - v0) ** 2 / vh / PPS2_PER_INV_PARA
            para = math.floor((target_s - pulses / vh) / slope / m) * m
            para = min(para, PARA_RANGE[m][1] // m * m,
                       math.floor(pulses * PPS2_PER_INV_PARA / (vh * vh - v0 * v0) / m) * m)
            if para < least:
                continue
            t_flat = 0.0
        s = AlinkSettings(v0, vh, int(para))
        gap = target_s - move_time_s(s, pulses).duration_s
        if 0 <= gap < best[0]:
            best = (gap, s)
        if t_flat and gap < 0:
            break
        if best[0] < 1e-7:
            break
    return best[1]


JudgeFor = Callable[[Motor], SettingsJudge]   # a motor's load-angle judge
TIGHTEN_ROUNDS = 4   # a tightened follower that ends late makes a new target, this often


def plan_time_sync(axes: Sequence[tuple[str, Motor, int]],
                   judge_for: JudgeFor | None = None, aim_deg: float = 75.0
                   ) -> AlinkSyncPlan:
    """Both axes end together: the slower keeps its fastest settings. With `judge_for`
    (a motor's load-angle judge, `tighten_settings`' levers), each axis's fastest settings
    are tightened first, and a follower slowed to the target that the judge still finds
    past the aim is tightened too; when it then ends later, that is the new target."""
    fastest = [plan_settings(m, pulses=abs(p)).table for _, m, p in axes]
    judges = [None if judge_for is None else judge_for(m) for _, m, _ in axes]

    def tight(i: int, s: AlinkSettings) -> AlinkSettings:
        judge = judges[i]
        if judge is None or judge(s).within_aim:
            return s
        _, motor, p = axes[i]
        return tighten_settings(motor, s, judge, aim_deg=aim_deg, pulses=abs(p)).settings

    fastest = [tight(i, s) for i, s in enumerate(fastest)]
    times = [move_time_s(s, abs(p)).duration_s
             for s, (_, _, p) in zip(fastest, axes, strict=True)]
    target = max(times)
    chosen = list(fastest)
    for i, ((_, motor, p), t) in enumerate(zip(axes, times, strict=True)):
        if t >= target:
            continue
        base = fastest[i]
        for _ in range(TIGHTEN_ROUNDS):  # slowed, judged, tightened, slowed from there
            slowed = slow_to(motor, abs(p), target, base,
                             start_cap=None if judges[i] is None else base.start_pps)
            chosen[i] = tight(i, slowed)
            if chosen[i] == slowed or move_time_s(chosen[i], abs(p)).duration_s > target:
                break
            base = chosen[i]
    out = []
    for (name, motor, p), s, best, t in zip(axes, chosen, fastest, times, strict=True):
        how = (f"high {s.high_pps} pps (fastest {best.high_pps}), para {s.accel_para} "
               f"(fastest {best.accel_para})" if s != best else
               "slowest axis: fastest settings")
        out.append(AlinkAxisMove(name, p, motor, s, t, how))
    return AlinkSyncPlan("time", tuple(out), f"time: both axes end at {target * 1e3:.6g} ms")


def _scaled(lead: AlinkSettings, c: float) -> AlinkSettings | None:
    """The leader's settings scaled by c, each quantised to the nearest multiple."""
    vh_ideal = lead.high_pps * c
    for _ in range(3):
        m = multiplier(max(1, round(vh_ideal)))
        vh = max(m, round(vh_ideal / m) * m)
        if multiplier(vh) == m:
            break
    m = multiplier(vh)
    v0 = min(max(m, round(lead.start_pps * c / m) * m), vh)
    para = round(lead.accel_para / c / m) * m
    lo, hi = PARA_RANGE[m]
    if not lo <= para <= hi or vh > m * STEPS_MAX:
        return None
    return AlinkSettings(v0, vh, para)


def plan_line_sync(axes: Sequence[tuple[str, Motor, int]]) -> AlinkSyncPlan:
    """Settings proportional to the pulses (see the module docstring)."""
    dist = [abs(p) for _, _, p in axes]
    lead_i = int(np.argmax(dist))
    scales = [d / dist[lead_i] for d in dist]
    motors = [m for _, m, _ in axes]
    fastest = [move_time_s(plan_settings(m, pulses=d).table, d).duration_s
               for m, d in zip(motors, dist, strict=True)]
    env = envelope_motor(motors, scales)
    base = plan_settings(env, pulses=dist[lead_i]).table
    m_l = base.multiplier
    best = None
    for vh in range(base.high_pps, max(m_l, base.high_pps - LINE_HIGH_CANDIDATES * m_l), -m_l):
        if multiplier(vh) != m_l:
            continue
        v0 = min(base.start_pps, vh)
        least = _least_para(env, v0, vh, m_l)
        if least is None:
            continue
        for para in range(least, least + LINE_PARA_CANDIDATES * m_l, m_l):
            if para > PARA_RANGE[m_l][1]:
                break
            lead = AlinkSettings(v0, vh, para)
            settings = [lead if i == lead_i else _scaled(lead, scales[i])
                        for i in range(len(axes))]
            if any(s is None or not is_stall_safe(s, mo)
                   for s, mo in zip(settings, motors, strict=True)):
                continue
            chosen = [s for s in settings if s is not None]
            dev = line_deviation([pulse_train(s, d)
                                        for s, d in zip(chosen, dist, strict=True)])[0]
            t = max(move_time_s(s, d).duration_s for s, d in zip(chosen, dist, strict=True))
            if best is None or (dev, t) < (best[0], best[1]):
                best = (dev, t, chosen)
    if best is None:
        raise AlinkSyncError("no proportional A-Link settings are stall-safe for both axes")
    dev, _, chosen = best
    out = [AlinkAxisMove(name, p, mo, s, f, "leads" if i == lead_i else
                         f"follows at {scales[i]:.6g} × the leader")
           for i, ((name, mo, p), s, f) in enumerate(zip(axes, chosen, fastest, strict=True))]
    return AlinkSyncPlan("line", tuple(out), f"line: modelled deviation {dev:.4g} pulses")


def plan_sync(axes: Sequence[tuple[str, Motor, int]], mode: Mode,
              judge_for: JudgeFor | None = None) -> AlinkSyncPlan:
    """The two axes' settings for `mode`; `judge_for` (time mode): tightened on it."""
    if len(axes) > 2:
        raise AlinkSyncError(f"an A-Link ALUM unit has two axes, not {len(axes)}")
    if mode == "time":
        return plan_time_sync(axes, judge_for)
    if mode == "line":
        return plan_line_sync(axes)
    raise AlinkSyncError(f"mode: {echo(mode)} is not 'time' or 'line'")
