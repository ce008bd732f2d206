"""The load-angle model integrated in plain Python: the test oracle of the compiled one.

This is the integrator `profiles.motor.rotor` used before it was compiled
(`profiles.motor.rotor_kernel`), step for step: fixed-step RK4 landing on span
boundaries, the settling skip, the step budget. Nothing in the tool imports it
(tests/repo/test_layout.py); the tests hold the kernel to it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from profiles.errors import StepRampError
from profiles.motor.rotor import (
    MAX_RK4_STEPS,
    MAX_SETTLE_PERIODS,
    SETTLE_TOL_DEG,
    SLIP_DEG,
    Rotor,
)


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
        if count >= window and (s != v or v == 0.0):  # held by static friction: not settled
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
