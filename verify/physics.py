"""Load-angle check: the rotor simulated against the pulse train the chip emits.

Beyond the stall criterion of `verify.stall` (capability against the table's
accelerations) this integrates the standard load-angle ("pendulum") model of a
hybrid stepper driven by the executed staircase (`profiles.ppmc312.execution.Execution`).
Model, in pulses (one pulse = one commanded step of the driver):

    lag  L = x_cmd(t) − x(t)                [pulses; > 0 when the rotor is behind]
    δ    = c_e · L,  c_e = 2π · Nr / steps_per_rev   [electrical radians]
    J·θ̈ = T_amp(|ω|) · sin δ − T_f · sign(ω) + D · (ω_cmd − ω)

  (at ω = 0 friction is static: it holds the rotor while the drive torque is
  below T_f, and otherwise opposes the drive);

- x_cmd is `Execution.position_linear_at`: the staircase integrated linearly
  within each segment (equal to the exact pulse count at every pulse instant).
  The per-pulse ripple of a real step train is not modelled.
- Nr (rotor teeth, electrical periods per revolution) is `motor.rotor_teeth`,
  or 50 (the 1.8° hybrid rotor) when the motor file does not give it. A full
  step is 90° electrical (2-phase hybrid): steps_per_rev / (4·Nr) pulses.
- T_amp, the peak of the restoring torque, comes from the pull-out curve
  (unscaled by the safety factor: this is the physical motor) divided by
  sin(δ_stall): the largest steady torque the restoring law delivers without
  passing the stall lag is then exactly the pull-out torque. It is capped at
  `motor.holding_torque_nm` when given (the static torque peak bounds it).
- D is the electromagnetic damping of the lag oscillation (relative to the
  field, so it costs no torque at a steady lag): damping ratio `damping_ratio`
  of the small-signal oscillation at standstill.
- Stall: |L| beyond half a full step (the project's criterion, 45° electrical,
  a quarter of the 180° at which a rotor physically slips a pole); the
  integration stops there.

Numerics: fixed-step RK4 in the lag coordinates, steps landing exactly on the
segment boundaries (the command speed is constant within a step), step ≤ 1/50
of the standstill natural period and ≤ 1/10 of the electrical period at the
move's top speed. Within any constant-speed segment (cruise, and long stages)
the system is autonomous: once the lag oscillation has settled (range over a
natural period below `SETTLE_TOL_FULL_STEPS`) the rest of the segment is
skipped with that state. After the last pulse the rotor is followed until it
settles at rest.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

from profiles.errors import FieldRangeError, StepRampError
from profiles.motor import Motor
from profiles.ppmc312.execution import Execution

DEFAULT_ROTOR_TEETH = 50          # 1.8° hybrid: 200 full steps per revolution
FULL_STEP_ELECTRICAL_RAD = math.pi / 2  # 2-phase hybrid: one full step = 90° electrical
STALL_LAG_FULL_STEPS = 0.5        # the project's stall criterion (issue #3)
SETTLE_TOL_FULL_STEPS = 1e-3      # lag oscillation range that counts as settled
STEPS_PER_NATURAL_PERIOD = 50
STEPS_PER_ELECTRICAL_PERIOD = 10
MAX_SETTLE_PERIODS = 400          # give up waiting for an undamped rotor to settle
MAX_RK4_STEPS = 20_000_000


@dataclass(frozen=True)
class PhysicsResult:
    """`worst_lag_full_steps` is the signed lag of largest magnitude (> 0: behind)."""

    worst_lag_full_steps: float
    worst_lag_time_s: float
    stalled: bool
    stall_time_s: float | None
    lag_t_s: np.ndarray
    lag_full_steps: np.ndarray

    def to_json(self) -> dict[str, object]:
        return {"worst_lag_full_steps": self.worst_lag_full_steps,
                "worst_lag_time_s": self.worst_lag_time_s, "stalled": self.stalled,
                "stall_time_s": self.stall_time_s}


@dataclass(frozen=True)
class _Rotor:
    """The motor in pulse units; `accel(L, s, v)` is d²x/dt² of the rotor [pps/s]."""

    c_e: float                 # electrical radians per pulse
    pulses_per_full_step: float
    k: float                   # N·m → pps/s
    curve_v: list[float]
    curve_t: list[float]       # peak restoring torque T_amp at curve_v
    friction_pps2: float
    damping_per_s: float       # 2·ζ·ω_n0

    def t_amp(self, speed_pps: float) -> float:
        v = abs(speed_pps)
        cv = self.curve_v
        if v >= cv[-1]:
            return self.curve_t[-1] if v == cv[-1] else 0.0
        i = bisect.bisect_right(cv, v) - 1
        w = (v - cv[i]) / (cv[i + 1] - cv[i])
        return self.curve_t[i] + w * (self.curve_t[i + 1] - self.curve_t[i])

    def natural_period_s(self, speed_pps: float) -> float:
        stiffness = self.k * self.c_e * self.t_amp(speed_pps)
        return 2 * math.pi / math.sqrt(stiffness) if stiffness > 0 else math.inf


def _rotor(motor: Motor, damping_ratio: float) -> _Rotor:
    teeth = DEFAULT_ROTOR_TEETH if motor.rotor_teeth is None else motor.rotor_teeth
    if isinstance(teeth, bool) or not 1 <= teeth <= motor.steps_per_rev:
        raise FieldRangeError("rotor_teeth", teeth, 1, motor.steps_per_rev)
    c_e = 2 * math.pi * teeth / motor.steps_per_rev
    scale = 1.0 / math.sin(STALL_LAG_FULL_STEPS * FULL_STEP_ELECTRICAL_RAD)
    amp = np.asarray(motor.curve_torque_nm, dtype=float) * scale
    if motor.holding_torque_nm is not None:
        amp = np.minimum(amp, motor.holding_torque_nm)
    k = motor.steps_per_rev / (2 * math.pi * motor.inertia_kgm2)
    omega_n0 = math.sqrt(k * c_e * float(amp[0])) if amp[0] > 0 else 0.0
    return _Rotor(c_e=c_e, pulses_per_full_step=FULL_STEP_ELECTRICAL_RAD / c_e, k=k,
                  curve_v=[float(v) for v in motor.curve_speed_pps],
                  curve_t=[float(t) for t in amp], friction_pps2=k * motor.friction_torque_nm,
                  damping_per_s=2 * damping_ratio * omega_n0)


def load_angle_check(execution: Execution, motor: Motor, *, max_step_s: float | None = None,
                     damping_ratio: float = 0.1) -> PhysicsResult:
    """Integrate the rotor against `execution` (see the module docstring)."""
    if max_step_s is not None and not 1e-9 <= max_step_s <= 1.0:
        raise FieldRangeError("max_step_s", max_step_s, 1e-9, 1.0)
    if not 0 <= damping_ratio <= 10:
        raise FieldRangeError("damping_ratio", damping_ratio, 0, 10)
    rotor = _rotor(motor, damping_ratio)
    hz = execution.clock.hz
    top_pps = max((hz / s.rate for s in execution.segments), default=0.0)
    step_s = rotor.natural_period_s(0.0) / STEPS_PER_NATURAL_PERIOD
    if top_pps > 0:
        step_s = min(step_s, 2 * math.pi / rotor.c_e / top_pps / STEPS_PER_ELECTRICAL_PERIOD)
    if max_step_s is not None:
        step_s = min(step_s, max_step_s)
    if not math.isfinite(step_s):  # no restoring torque at all, no move: nothing to do
        step_s = max_step_s or 1e-4

    run = _Run(rotor, step_s)
    # Each segment commands a constant speed; after the last, the command rests.
    spans = [(s.start_tick / hz, s.end_tick / hz, hz / s.rate) for s in execution.segments]
    settle_s = MAX_SETTLE_PERIODS * max(step_s * STEPS_PER_NATURAL_PERIOD,
                                        min(rotor.natural_period_s(0.0), 1.0))
    spans.append((execution.duration_s, execution.duration_s + settle_s, 0.0))
    previous_v = 0.0
    for i, (t0, t1, v) in enumerate(spans):
        run.s += v - previous_v  # the command's speed steps; the lag is continuous
        previous_v = v
        run.segment(t0, t1, v, mark_end=i < len(spans) - 1)
        if run.stalled:
            break
    t = np.asarray(run.t_s)
    lag = np.asarray(run.lag) / rotor.pulses_per_full_step
    worst = int(np.argmax(np.abs(lag)))
    return PhysicsResult(worst_lag_full_steps=float(lag[worst]),
                         worst_lag_time_s=float(t[worst]), stalled=run.stalled,
                         stall_time_s=run.stall_time_s, lag_t_s=t, lag_full_steps=lag)


class _Run:
    """The integration state: lag L [pulses], relative speed s = v_cmd − v_rotor [pps]."""

    def __init__(self, rotor: _Rotor, step_s: float) -> None:
        self.rotor = rotor
        self.step_s = step_s
        self.L = 0.0
        self.s = 0.0
        self.t_s: list[float] = [0.0]
        self.lag: list[float] = [0.0]
        self.stalled = False
        self.stall_time_s: float | None = None
        self.steps = 0
        self.stall_pulses = STALL_LAG_FULL_STEPS * rotor.pulses_per_full_step

    def _deriv(self, L: float, s: float, v: float) -> tuple[float, float]:
        r = self.rotor
        u = v - s  # rotor speed
        accel = r.k * r.t_amp(u) * math.sin(r.c_e * L) + r.damping_per_s * s
        if u > 0:
            accel -= r.friction_pps2
        elif u < 0:
            accel += r.friction_pps2
        elif abs(accel) <= r.friction_pps2:
            accel = 0.0  # at rest, friction holds the rotor until the drive exceeds it
        else:
            accel -= math.copysign(r.friction_pps2, accel)
        return s, -accel  # dL/dt = s; ds/dt = dv/dt − du/dt = −rotor accel

    def segment(self, t0: float, t1: float, v: float, *, mark_end: bool) -> None:
        """Integrate over [t0, t1] at command speed v (a settled skip to t1 is recorded
        as a point at t1 when `mark_end`)."""
        dur = t1 - t0
        if dur <= 0:
            return
        n = max(1, math.ceil(dur / self.step_s))
        h = dur / n
        window = max(8, math.ceil(self.rotor.natural_period_s(v) / h)
                     if math.isfinite(self.rotor.natural_period_s(v)) else n + 1)
        tol = SETTLE_TOL_FULL_STEPS * self.rotor.pulses_per_full_step
        lo = hi = self.L
        count = windows = 0
        deriv = self._deriv
        L, s = self.L, self.s
        for i in range(1, n + 1):
            k1L, k1s = deriv(L, s, v)
            k2L, k2s = deriv(L + 0.5 * h * k1L, s + 0.5 * h * k1s, v)
            k3L, k3s = deriv(L + 0.5 * h * k2L, s + 0.5 * h * k2s, v)
            k4L, k4s = deriv(L + h * k3L, s + h * k3s, v)
            L += h / 6 * (k1L + 2 * k2L + 2 * k3L + k4L)
            s += h / 6 * (k1s + 2 * k2s + 2 * k3s + k4s)
            t = t0 + i * h
            self.t_s.append(t)
            self.lag.append(L)
            self.steps += 1
            if abs(L) > self.stall_pulses:
                self.stalled, self.stall_time_s = True, t
                break
            lo, hi = min(lo, L), max(hi, L)
            count += 1
            if count >= window:
                windows += 1
                # Settled: the rest of a constant segment repeats this state. An undamped
                # rotor never settles; after MAX_SETTLE_PERIODS windows its (periodic)
                # oscillation has shown its extremes, so it is skipped as well.
                if hi - lo < tol or windows >= MAX_SETTLE_PERIODS:
                    if i < n and mark_end:
                        self.t_s.append(t1)
                        self.lag.append(L)
                    break
                lo = hi = L
                count = 0
            if self.steps >= MAX_RK4_STEPS:
                raise StepRampError(f"load-angle check: more than {MAX_RK4_STEPS} RK4 steps of "
                                    f"{h:.3g} s and the lag still oscillates at t = {t:.6g} s; "
                                    "raise damping_ratio or max_step_s")
        self.L, self.s = L, s
