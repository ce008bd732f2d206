"""The rotor of a hybrid stepper following a commanded staircase: the load-angle model.

A model of the motor (profiles.ppmc312.load_angle_trace turns it into verdicts; planners use it to
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

T_pk between curve points is linear: the torque at the piece's first point plus the
speed past it times the piece's slope (one arithmetic in the model, its kernel and the
oracle; a span finds its piece once, at the command speed).

Numerics: fixed-step RK4 with steps landing exactly on span boundaries (a span is a
constant command: neighbouring segments of one rate are one span; the command speed
is constant within a step), step 1/50 of the natural period at rest
(the stiffest: torque only falls with speed). Within a constant segment
the system is autonomous: once the oscillation has settled (range over a natural
period below `SETTLE_TOL_DEG`) the rest of the segment is skipped with that state.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import FieldRangeError, StepRampError
from .angles import AIM_DEG, PEAK_DEG, SLIP_DEG
from .model import Motor

__all__ = ["AIM_DEG", "PEAK_DEG", "SLIP_DEG"]  # re-exported: the model's landmarks

SETTLE_TOL_DEG = 0.05             # oscillation range that counts as settled
STEPS_PER_NATURAL_PERIOD = 50
MAX_SETTLE_PERIODS = 400          # give up waiting for an undamped rotor to settle
MAX_RK4_STEPS = 2_000_000        # one execution (≈ 10 s of Python): a budget, not a hang


@dataclass(frozen=True)
class Rotor:
    """The motor in pulse units; accelerations in pps/s."""

    c_e: float                 # electrical radians per pulse
    k: float                   # N·m → pps/s
    curve_v: tuple[float, ...]
    curve_t: tuple[float, ...]  # peak restoring torque at curve_v
    friction_pps2: float
    load_pps2: float           # signed: > 0 opposes the move
    damping_per_s: float       # 2·ζ·ω_n0

    @property
    def deg_per_pulse(self) -> float:
        return math.degrees(self.c_e)

    def row(self) -> np.ndarray:
        """The kernel's row of this rotor (profiles.motor.rotor_kernel.ROTOR_FIELDS)."""
        return np.array([self.c_e, self.k, self.friction_pps2, self.load_pps2,
                         self.damping_per_s])

    def curve(self) -> tuple[np.ndarray, np.ndarray]:
        """The pull-out curve as the kernel takes it: (speeds [pps], torques [N·m])."""
        return np.asarray(self.curve_v, dtype=float), np.asarray(self.curve_t, dtype=float)

    def t_peak(self, speed_pps: float) -> float:
        v = abs(speed_pps)
        cv = self.curve_v
        if v >= cv[-1]:
            return self.curve_t[-1] if v == cv[-1] else 0.0
        i = bisect.bisect_right(cv, v) - 1
        slope = (self.curve_t[i + 1] - self.curve_t[i]) / (cv[i + 1] - cv[i])
        return self.curve_t[i] + (v - cv[i]) * slope

    def natural_period_s(self, speed_pps: float) -> float:
        stiffness = self.k * self.c_e * self.t_peak(speed_pps)
        return 2 * math.pi / math.sqrt(stiffness) if stiffness > 0 else math.inf

    def natural_periods_s(self, speeds_pps: np.ndarray) -> np.ndarray:
        """`natural_period_s` at many speeds at once, with the same arithmetic."""
        v = np.abs(np.asarray(speeds_pps, dtype=float))
        cv, ct = self.curve()
        i = np.clip(np.searchsorted(cv, v, side="right") - 1, 0, len(cv) - 2)
        slope = (ct[i + 1] - ct[i]) / (cv[i + 1] - cv[i])
        t = np.where(v >= cv[-1], np.where(v == cv[-1], ct[-1], 0.0),
                     ct[i] + (v - cv[i]) * slope)
        stiffness = self.k * self.c_e * t
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(stiffness > 0, 2 * math.pi / np.sqrt(stiffness), math.inf)

    def step_s(self) -> float:
        """The RK4 step: 1/50 of the natural period at rest (the command is constant within
        a step, so no other time scale enters the model)."""
        step = self.natural_period_s(0.0) / STEPS_PER_NATURAL_PERIOD
        return step if math.isfinite(step) else 1e-4


def rotor_of(motor: Motor, *, direction: int = 1) -> Rotor:
    """The rotor of `motor` on a forward (`direction` 1) or backward (−1) move."""
    return rotors(motor, direction=direction).rotor(0)


@dataclass(frozen=True)
class Rotors:
    """Rotors of one motor's variants (a tolerance box's corners or samples, each
    direction of a loaded move) as the kernel takes them: one row each."""

    c_e: float
    curve_v: np.ndarray   # (P,) speeds [pps], shared
    curve_t: np.ndarray   # (S, P) peak restoring torque [N·m] per rotor
    rows: np.ndarray      # (S, len(ROTOR_FIELDS)): c_e, k, friction, load, damping
    direction: np.ndarray  # (S,) 1 forward, −1 backward

    def __len__(self) -> int:
        return len(self.rows)

    def rotor(self, i: int) -> Rotor:
        c_e, k, friction, load, damping = (float(x) for x in self.rows[i])
        return Rotor(c_e, k, tuple(float(v) for v in self.curve_v),
                     tuple(float(t) for t in self.curve_t[i]), friction, load, damping)

    def periods_at_rest_s(self) -> np.ndarray | None:
        """Each rotor's natural period at rest (`Rotor.natural_period_s(0.0)`, the same
        arithmetic on every row at once: a tolerance box's 1 000 samples made a Rotor
        each); None when the curve does not start at 0 pps (ask each rotor)."""
        if len(self.curve_v) == 0 or self.curve_v[0] != 0.0:
            return None
        stiffness = self.rows[:, 1] * self.rows[:, 0] * self.curve_t[:, 0]  # torque at rest
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(stiffness > 0, 2 * math.pi / np.sqrt(stiffness), math.inf)

    def step_s(self, max_step_s: float | None = None) -> np.ndarray:
        """Each rotor's RK4 step (`Rotor.step_s`), at most `max_step_s`."""
        period = self.periods_at_rest_s()
        if period is None:
            steps = np.asarray([self.rotor(i).step_s() for i in range(len(self))])
        else:
            steps = period / STEPS_PER_NATURAL_PERIOD
            steps = np.where(np.isfinite(steps), steps, 1e-4)
        return steps if max_step_s is None else np.minimum(steps, max_step_s)

    def settle_s(self, steps_s: np.ndarray) -> np.ndarray:
        """Each rotor's `settle_s` with its step `steps_s[i]`, the same arithmetic."""
        period = self.periods_at_rest_s()
        if period is None:
            return np.asarray([settle_s(self.rotor(i), h) for i, h in enumerate(steps_s)])
        return MAX_SETTLE_PERIODS * np.maximum(np.asarray(steps_s) * STEPS_PER_NATURAL_PERIOD,
                                               np.minimum(period, 1.0))

    @staticmethod
    def stack(parts: Sequence[Rotors]) -> Rotors:
        """One set of the rotors of `parts` (same curve speeds and c_e), in order."""
        first = parts[0]
        for p in parts[1:]:
            if p.c_e != first.c_e or not np.array_equal(p.curve_v, first.curve_v):
                raise ValueError("rotors judged together share their curve speeds and c_e")
        return Rotors(first.c_e, first.curve_v, np.concatenate([p.curve_t for p in parts]),
                      np.concatenate([p.rows for p in parts]),
                      np.concatenate([p.direction for p in parts]))


def rotors(motor: Motor, params: Mapping[str, Any] | None = None, *,
           direction: int = 1) -> Rotors:
    """The rotors of `motor` with the given parameter values (keys from
    profiles.motor.TOLERANCE_KEYS, each a number or an array of one length; missing
    ones nominal), on a forward (`direction` 1) or backward (−1) move. Row i is the
    rotor of `tolerance.variant(motor, params at i)`: the torque scale multiplies the
    pull-out curve and the holding torque that caps it."""
    params = dict(params or {})
    size = max((np.size(v) for v in params.values()), default=1)

    def get(key: str) -> np.ndarray:
        value = params.get(key)
        return np.broadcast_to(np.asarray(motor.nominal(key) if value is None else value,
                                          dtype=float), (size,))

    c_e = math.radians(motor.electrical_deg_per_pulse)
    amp = np.asarray(motor.curve_torque_nm, dtype=float)
    if motor.holding_torque_nm is not None:
        amp = np.minimum(amp, motor.holding_torque_nm)
    amp = get("torque_scale")[:, None] * amp[None, :]
    k = motor.steps_per_rev / (2 * math.pi * get("inertia_kgm2"))
    omega_n0 = np.sqrt(np.maximum(k * c_e * amp[:, 0], 0.0))
    rows = np.stack([np.full(size, c_e), k, k * get("friction_torque_nm"),
                     k * get("load_torque_nm") * direction,
                     2 * get("damping_ratio") * omega_n0], axis=1)
    return Rotors(c_e, np.asarray(motor.curve_speed_pps, dtype=float), amp, rows,
                  np.full(size, direction))


@dataclass(frozen=True)
class Trace:
    """A run of the model: per span its largest |lag| and its end state (L, s), and with
    `record` the lag at every RK4 step [pulses] (`t_s` from the start state)."""

    span_max: np.ndarray
    boundary_lag: np.ndarray
    boundary_s: np.ndarray
    slipped: bool
    slip_time_s: float | None
    steps: int
    t_s: np.ndarray
    lag: np.ndarray


def follow(rotor: Rotor, spans: Sequence[tuple[float, float]], *, step_s: float,
           state: tuple[float, float] = (0.0, 0.0), t0_s: float = 0.0,
           previous_pps: float = 0.0, record: bool = True,
           max_steps: int = MAX_RK4_STEPS) -> Trace:
    """Integrate the rotor over `spans` of (duration_s, command speed_pps), starting with
    lag state (L, s) at `t0_s` after a command of `previous_pps`; stops at a pole slip.
    The compiled kernel (profiles.motor.rotor_kernel) does the work."""
    from . import rotor_kernel as rk

    table = np.asarray(spans, dtype=float).reshape(-1, 2)
    dur, vel = np.ascontiguousarray(table[:, 0]), np.ascontiguousarray(table[:, 1])
    count = len(dur)
    out_max, out_lag, out_s = np.zeros(count), np.zeros(count), np.zeros(count)
    no_ref = np.full(count, -1, dtype=np.int64)
    # room for every step the spans can take (settling skips most of a long one)
    room = int(min(np.sum(np.ceil(dur / step_s)) + count, max_steps + count)) if record else 0
    while True:
        rec_t, rec_lag = np.empty(room), np.empty(room)
        done, status, slipped, slip_t, steps, _, recorded = rk.follow_spans(
            *rotor.curve(), rotor.row(), dur, vel, state[0], state[1],
            previous_pps, t0_s, step_s, math.radians(SLIP_DEG) / rotor.c_e,
            math.radians(SETTLE_TOL_DEG) / rotor.c_e, MAX_SETTLE_PERIODS, max_steps, no_ref,
            out_lag, out_s, 0.0, 0.0, out_max, out_lag, out_s, record, rec_t, rec_lag, False,
            out_max, 0.0, 0.0)
        if status != rk.OUT_OF_ROOM:
            break
        room *= 2
    if status == rk.OUT_OF_STEPS:
        raise too_stiff(max_steps, rotor, step_s)
    return Trace(out_max[:done], out_lag[:done], out_s[:done], bool(slipped),
                 slip_t if slipped else None, int(steps),
                 np.concatenate(([t0_s], rec_t[:recorded])),
                 np.concatenate(([state[0]], rec_lag[:recorded])))


def too_stiff(limit: int, rotor: Rotor, step_s: float) -> StepRampError:
    """The refusal of a verdict that would take more than `limit` RK4 steps."""
    return StepRampError(f"load-angle model: more than {limit} RK4 steps of {step_s:.3g} s "
                         f"(natural period {rotor.natural_period_s(0.0):.3g} s at rest): this "
                         "rotor is too stiff, or too lightly damped, for a verdict in "
                         "reasonable time; check the motor's inertia and damping_ratio, or "
                         "judge fewer move lengths (--pulses)")


def settle_s(rotor: Rotor, step_s: float) -> float:
    """How long the rotor is followed after the last pulse (it settles long before)."""
    return MAX_SETTLE_PERIODS * max(step_s * STEPS_PER_NATURAL_PERIOD,
                                    min(rotor.natural_period_s(0.0), 1.0))


def check_step(max_step_s: float | None) -> None:
    if max_step_s is not None and not 1e-9 <= max_step_s <= 1.0:
        raise FieldRangeError("max step [s]", max_step_s, 1e-9, 1.0)
