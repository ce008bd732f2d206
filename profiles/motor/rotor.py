"""The rotor of a hybrid stepper following a commanded staircase: the load-angle model.

A model of the motor (verify.physics turns it into verdicts; planners use it to
tighten). In pulses (one pulse = one commanded step of the driver):

    lag  L = x_cmd(t) − x(t)                  [pulses; > 0 when the rotor is behind]
    δ    = c_e · L,  c_e = 2π · Nr / steps_per_rev     [electrical radians]
    J·θ̈ = T_pk(|ω|) · sin δ − T_f · sign(ω) − T_L + D · (ω_cmd − ω)

- δ is the load angle in electrical degrees, so 2- and 5-phase motors compare: the
  restoring torque peaks at 90° (one full step of a 2-phase motor, 2.5 of a
  5-phase), beyond it the rotor is on the unstable side, at 180° it slips a pole.
- T_pk(v) is the pull-out torque of the speed, unscaled by the safety factor (the
  physical motor: at speed the peak of the torque–angle curve IS the pull-out
  torque), capped at `holding_torque_nm` when given.
- T_L is the motor file's signed `load_torque_nm` (> 0 opposes forward motion);
  a backward move is the forward move with −T_L (`direction=-1`).
- D damps the lag oscillation relative to the field (no torque at a steady lag):
  damping ratio `motor.damping_ratio` of the small-signal oscillation at rest.
- At ω = 0 friction is static: it holds the rotor while the drive torque is below T_f.
- x_cmd is the staircase integrated linearly within each segment (exact at every
  pulse instant); the per-pulse ripple of a real step train is not modelled.

Numerics: fixed-step RK4 with steps landing exactly on segment boundaries (the
command speed is constant within a step), step 1/50 of the natural period at rest
(the stiffest: torque only falls with speed). Within a constant segment
the system is autonomous: once the oscillation has settled (range over a natural
period below `SETTLE_TOL_DEG`) the rest of the segment is skipped with that state.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import FieldRangeError, StepRampError
from .model import Motor

SLIP_DEG = 180.0                  # the rotor slips a pole
PEAK_DEG = 90.0                   # the restoring torque peaks: the stable side ends
TARGET_DEG = 75.0                 # what planners aim at: 15° of margin to the peak
SETTLE_TOL_DEG = 0.05             # oscillation range that counts as settled
STEPS_PER_NATURAL_PERIOD = 50
MAX_SETTLE_PERIODS = 400          # give up waiting for an undamped rotor to settle
MAX_RK4_STEPS = 2_000_000        # one execution (≈ 10 s of Python): a budget, not a hang


@dataclass(frozen=True)
class Rotor:
    """The motor in pulse units; accelerations in pps/s."""

    c_e: float                 # electrical radians per pulse
    k: float                   # N·m → pps/s
    curve_v: list[float]
    curve_t: list[float]       # peak restoring torque at curve_v
    friction_pps2: float
    load_pps2: float           # signed: > 0 opposes the move
    damping_per_s: float       # 2·ζ·ω_n0

    @property
    def deg_per_pulse(self) -> float:
        return math.degrees(self.c_e)

    def t_peak(self, speed_pps: float) -> float:
        v = abs(speed_pps)
        cv = self.curve_v
        if v >= cv[-1]:
            return self.curve_t[-1] if v == cv[-1] else 0.0
        i = bisect.bisect_right(cv, v) - 1
        w = (v - cv[i]) / (cv[i + 1] - cv[i])
        return self.curve_t[i] + w * (self.curve_t[i + 1] - self.curve_t[i])

    def natural_period_s(self, speed_pps: float) -> float:
        stiffness = self.k * self.c_e * self.t_peak(speed_pps)
        return 2 * math.pi / math.sqrt(stiffness) if stiffness > 0 else math.inf

    def step_s(self) -> float:
        """The RK4 step: 1/50 of the natural period at rest (the command is constant within
        a step, so no other time scale enters the model)."""
        step = self.natural_period_s(0.0) / STEPS_PER_NATURAL_PERIOD
        return step if math.isfinite(step) else 1e-4


def rotor_of(motor: Motor, *, direction: int = 1, torque_scale: float = 1.0) -> Rotor:
    """The rotor of `motor` on a forward (`direction` 1) or backward (−1) move."""
    c_e = math.radians(motor.electrical_deg_per_pulse)
    amp = np.asarray(motor.curve_torque_nm, dtype=float) * torque_scale
    if motor.holding_torque_nm is not None:
        amp = np.minimum(amp, motor.holding_torque_nm)
    k = motor.steps_per_rev / (2 * math.pi * motor.inertia_kgm2)
    omega_n0 = math.sqrt(k * c_e * float(amp[0])) if amp[0] > 0 else 0.0
    return Rotor(c_e=c_e, k=k, curve_v=[float(v) for v in motor.curve_speed_pps],
                 curve_t=[float(t) for t in amp], friction_pps2=k * motor.friction_torque_nm,
                 load_pps2=k * motor.load_torque_nm * direction,
                 damping_per_s=2 * motor.damping_ratio * omega_n0)


@dataclass
class Trace:
    """A run of the model: the lag at every RK4 step and at every span boundary."""

    t_s: list[float] = field(default_factory=lambda: [0.0])
    lag: list[float] = field(default_factory=lambda: [0.0])   # pulses
    boundary: list[tuple[float, float]] = field(default_factory=list)  # (L, s) at span ends
    span_max: list[float] = field(default_factory=list)       # max |L| within each span
    slipped: bool = False
    slip_time_s: float | None = None
    steps: int = 0
    record: bool = True       # keep every step (figures); False keeps boundaries only
    budget: StepBudget | None = None  # shared by the executions of one verdict


@dataclass
class StepBudget:
    """RK4 steps a whole verdict may take: a stiff rotor on a long table would otherwise
    keep a check busy for minutes; it is refused with a reason instead."""

    limit: int
    used: int = 0

    def left(self) -> int:
        return self.limit - self.used


def follow(rotor: Rotor, spans: list[tuple[float, float]], *, step_s: float,
           state: tuple[float, float] = (0.0, 0.0), t0_s: float = 0.0,
           previous_pps: float = 0.0, trace: Trace | None = None,
           stop: object = None) -> Trace:
    """Integrate the rotor over `spans` of (duration_s, command speed_pps), starting with
    lag state (L, s) at `t0_s` after a command of `previous_pps`. Stops at a pole slip,
    or when `stop(i, L, s)` returns True at the end of span i."""
    out = trace if trace is not None else Trace(t_s=[t0_s], lag=[state[0]])
    L, s = state
    t = t0_s
    slip = math.radians(SLIP_DEG) / rotor.c_e
    for i, (dur, v) in enumerate(spans):
        s += v - previous_pps  # the command's speed steps; the lag is continuous
        previous_pps = v
        L, s, peak = _segment(rotor, out, t, dur, v, L, s, step_s, slip)
        t += dur
        out.boundary.append((L, s))
        out.span_max.append(peak)
        if out.slipped or (stop is not None and stop(i, L, s)):  # type: ignore[operator]
            break
    return out


def _segment(rotor: Rotor, out: Trace, t0: float, dur: float, v: float, L: float, s: float,
             step_s: float, slip: float) -> tuple[float, float, float]:
    if dur <= 0:
        return L, s, abs(L)
    n = max(1, math.ceil(dur / step_s))
    h = dur / n
    period = rotor.natural_period_s(v)
    window = max(8, math.ceil(period / h)) if math.isfinite(period) else n + 1
    tol = math.radians(SETTLE_TOL_DEG) / rotor.c_e
    r = rotor
    fr, ld, dmp, k, c_e, t_peak = (r.friction_pps2, r.load_pps2, r.damping_per_s, r.k, r.c_e,
                                   r.t_peak)

    def accel(L: float, s: float) -> float:
        u = v - s  # rotor speed
        a = k * t_peak(u) * math.sin(c_e * L) + dmp * s - ld
        if u > 0:
            return a - fr
        if u < 0:
            return a + fr
        if abs(a) <= fr:
            return 0.0  # at rest, friction holds the rotor until the drive exceeds it
        return a - math.copysign(fr, a)

    peak = abs(L)
    limit = MAX_RK4_STEPS if out.budget is None else min(MAX_RK4_STEPS, out.budget.left())
    lo = hi = L
    count = windows = 0
    for i in range(1, n + 1):
        k1L, k1s = s, -accel(L, s)
        k2L, k2s = s + 0.5 * h * k1s, -accel(L + 0.5 * h * k1L, s + 0.5 * h * k1s)
        k3L, k3s = s + 0.5 * h * k2s, -accel(L + 0.5 * h * k2L, s + 0.5 * h * k2s)
        k4L, k4s = s + h * k3s, -accel(L + h * k3L, s + h * k3s)
        L += h / 6 * (k1L + 2 * k2L + 2 * k3L + k4L)
        s += h / 6 * (k1s + 2 * k2s + 2 * k3s + k4s)
        t = t0 + i * h
        if out.record:
            out.t_s.append(t)
            out.lag.append(L)
        out.steps += 1
        peak = max(peak, abs(L))
        if abs(L) > slip:
            out.slipped, out.slip_time_s = True, t
            break
        lo, hi = min(lo, L), max(hi, L)
        count += 1
        if count >= window:
            windows += 1
            # Settled: the rest of a constant segment repeats this state. An undamped
            # rotor never settles; after MAX_SETTLE_PERIODS windows its (periodic)
            # oscillation has shown its extremes, so it is skipped as well.
            if hi - lo < tol or windows >= MAX_SETTLE_PERIODS:
                if i < n and out.record:
                    out.t_s.append(t0 + dur)
                    out.lag.append(L)
                break
            lo = hi = L
            count = 0
        if out.steps >= limit:
            raise StepRampError(f"load-angle model: more than {limit} RK4 steps of {h:.3g} s "
                                f"(natural period {period:.3g} s) by t = {t:.6g} s: this rotor "
                                "is too stiff, or too lightly damped, for a verdict in "
                                "reasonable time; check the motor's inertia and damping_ratio, "
                                "or judge fewer move lengths (--pulses)")
    return L, s, peak


def settle_s(rotor: Rotor, step_s: float) -> float:
    """How long the rotor is followed after the last pulse (it settles long before)."""
    return MAX_SETTLE_PERIODS * max(step_s * STEPS_PER_NATURAL_PERIOD,
                                    min(rotor.natural_period_s(0.0), 1.0))


def check_step(max_step_s: float | None) -> None:
    if max_step_s is not None and not 1e-9 <= max_step_s <= 1.0:
        raise FieldRangeError("max step [s]", max_step_s, 1e-9, 1.0)
