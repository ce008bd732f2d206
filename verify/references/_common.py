"""What every continuous reference shares: the result type, the move's limits and scaling.

The move: rest-to-rest over `pulses` pulses. A stepper jumps from rest straight
to its start speed, so every reference begins and ends at
v0 = min(start_pps, jump_pps) and keeps speed ≤ v_lim (see `MoveLimits`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from profiles.errors import FieldRangeError, FormatError, echo, is_number
from profiles.motor import Motor

#: Pulses accepted for a move: at least one, at most ten billion (beyond that the
#: scaled solvers' limits, ~1e9 in normalised units, are no longer guaranteed).
MIN_PULSES = 1
MAX_PULSES = 10_000_000_000

#: Relative margin below the speed where a_acc reaches 0 (see notes): the approach
#: to that speed is logarithmically slow and the solvers need a_acc(v_lim) > 0.
ZERO_ACCEL_MARGIN = 1e-6


@dataclass
class Reference:
    """One continuous reference trajectory, sampled, in physical units.

    `t_s` is non-decreasing (a repeated time marks an acceleration jump), `x_pulses`
    runs 0 … pulses, `a_pps2` is the acceleration at (just after) each sample.
    `solve_s` is the wall time of the solve, `info` a one-line note on the solve and
    on any capability violation found when re-checking the samples.
    """

    name: str
    duration_s: float
    t_s: np.ndarray
    x_pulses: np.ndarray
    v_pps: np.ndarray
    a_pps2: np.ndarray
    solve_s: float
    info: str

    def position_at(self, t_s: Any) -> Any:
        """Position [pulses] at time(s) `t_s` (linear interpolation of the samples)."""
        return np.interp(t_s, self.t_s, self.x_pulses)

    def speed_at(self, t_s: Any) -> Any:
        """Speed [pps] at time(s) `t_s`."""
        return np.interp(t_s, self.t_s, self.v_pps)

    def speed_at_position(self, x_pulses: Any) -> Any:
        """Speed [pps] when the move has covered `x_pulses`."""
        return np.interp(x_pulses, self.x_pulses, self.v_pps)


@dataclass(frozen=True)
class MoveLimits:
    """Boundary speed, speed cap and the scale used to normalise a move.

    Normalised units: position x/L with L = pulses, time t/t_ref with
    t_ref = sqrt(L / a_acc(0)); v_ref = L/t_ref, a_ref = L/t_ref², j_ref = L/t_ref³.
    """

    pulses: float
    v0_pps: float
    v_lim_pps: float
    v_zero_pps: float
    t_ref_s: float

    @property
    def v_ref_pps(self) -> float:
        return self.pulses / self.t_ref_s

    @property
    def a_ref_pps2(self) -> float:
        return self.pulses / self.t_ref_s**2

    @property
    def j_ref_pps3(self) -> float:
        return self.pulses / self.t_ref_s**3


def check_pulses(pulses: Any) -> float:
    """The move length as a float, or a one-line error naming the field."""
    if not is_number(pulses):
        raise FormatError(f"pulses: expected a number, got {echo(pulses)}")
    value = float(pulses)
    if not math.isfinite(value) or not MIN_PULSES <= value <= MAX_PULSES:
        raise FieldRangeError("pulses", pulses, MIN_PULSES, MAX_PULSES)
    return value


def accel_zero_pps(motor: Motor) -> float:
    """First speed where a_acc(v) reaches 0 (inf if it stays positive to the curve end).

    a_acc is linear between curve points, so the crossing is found exactly.
    """
    v = motor.curve_speed_pps
    a = np.asarray(motor.a_acc_pps2(v), dtype=float)
    bad = np.flatnonzero(a <= 0)
    if len(bad) == 0:
        return math.inf
    i = int(bad[0])  # i ≥ 1: the Motor constructor guarantees a_acc(0) > 0
    return float(v[i - 1] + (v[i] - v[i - 1]) * a[i - 1] / (a[i - 1] - a[i]))


def move_limits(motor: Motor, pulses: Any) -> MoveLimits:
    """v0, v_lim and the normalisation scale of a `pulses`-pulse rest-to-rest move."""
    n = check_pulses(pulses)
    v_zero = accel_zero_pps(motor)
    v_lim = motor.top_pps
    if v_zero <= v_lim:
        v_lim = v_zero * (1.0 - ZERO_ACCEL_MARGIN)
    # A start speed above the reachable cap (a motor whose friction beats its torque
    # early) would leave no room to accelerate: the move then runs at the cap.
    v0 = min(motor.start_pps, motor.jump_pps, v_lim)
    t_ref = math.sqrt(n / float(motor.a_acc_pps2(0.0)))
    return MoveLimits(pulses=n, v0_pps=v0, v_lim_pps=v_lim, v_zero_pps=v_zero, t_ref_s=t_ref)


def capability_violation(motor: Motor, limits: MoveLimits, ref: Reference,
                         rel_tol: float = 1e-3) -> str:
    """Re-check sampled output in physical units; '' if fine, else a short description.

    Speed must stay within [0, v_lim·(1+1e-6)]; acceleration within
    [−a_dec(v), a_acc(v)] up to `rel_tol` of a_acc(0) (the samples of a piecewise
    solution sit on interval ends, where a discretised constraint holds only to
    the grid's resolution). Also checks the boundary conditions and the length.
    """
    problems: list[str] = []
    v = ref.v_pps
    a = ref.a_pps2
    v_cap = limits.v_lim_pps * (1 + 1e-6)
    if np.any(v > v_cap) or np.any(v < -1e-9 * v_cap):
        problems.append(f"speed {float(v.max()):.6g} pps exceeds v_lim {limits.v_lim_pps:.6g}"
                        if np.any(v > v_cap) else f"speed {float(v.min()):.6g} pps below 0")
    tol = rel_tol * float(motor.a_acc_pps2(0.0))
    # Rounding can put a sample a hair above the curve's last point, where the torque
    # drops to 0; the speed excess itself is judged above, so judge accel at the cap.
    v_in = np.minimum(v, limits.v_lim_pps)
    over = a - np.asarray(motor.a_acc_pps2(v_in))
    under = -np.asarray(motor.a_dec_pps2(v_in)) - a
    worst_over = float(over.max())
    worst_under = float(under.max())
    if worst_over > tol:
        problems.append(f"accel exceeds a_acc by {worst_over:.4g} pps²")
    if worst_under > tol:
        problems.append(f"decel exceeds a_dec by {worst_under:.4g} pps²")
    v_tol = 1e-6 * max(limits.v_lim_pps, 1.0)
    if abs(v[0] - limits.v0_pps) > v_tol or abs(v[-1] - limits.v0_pps) > v_tol:
        problems.append(f"ends at {float(v[0]):.6g}/{float(v[-1]):.6g} pps, not v0 "
                        f"{limits.v0_pps:.6g}")
    if abs(ref.x_pulses[-1] - limits.pulses) > 1e-6 * limits.pulses or abs(ref.x_pulses[0]) > 1e-9:
        problems.append(f"covers {float(ref.x_pulses[0]):.9g}..{float(ref.x_pulses[-1]):.9g} "
                        f"pulses, not 0..{limits.pulses:.9g}")
    return "; ".join(problems)
