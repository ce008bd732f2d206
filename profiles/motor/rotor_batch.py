"""The load-angle model of `profiles.motor.rotor`, integrated for many motors at once.

The same equation, the same command (spans of constant speed, then rest) and the
same fixed-step RK4 as `profiles.motor.rotor.follow`, with every motor parameter an
array over S motors (a tolerance box's samples or corners): one numpy step
advances all of them. Differences from the scalar model, both on the safe side
of accuracy: the step is the smallest of the motors' steps (each motor's own
would be 1/50 of its natural period at rest; a smaller step only integrates more
finely), and a constant span is skipped once *every* motor has settled (the
scalar model skips per motor). Used by `verify.robust` for Monte Carlo verdicts;
tests hold it to the scalar model.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import StepRampError
from .model import Motor
from .rotor import (
    MAX_RK4_STEPS,
    MAX_SETTLE_PERIODS,
    SETTLE_TOL_DEG,
    SLIP_DEG,
    STEPS_PER_NATURAL_PERIOD,
)


@dataclass(frozen=True)
class BatchRotor:
    """S rotors sharing the motor's curve speeds and electrical angle per pulse."""

    c_e: float
    curve_v: np.ndarray        # (P,)
    amp: np.ndarray            # (S, P) peak restoring torque at curve_v [N·m]
    k: np.ndarray              # (S,) N·m → pps/s
    friction_pps2: np.ndarray  # (S,)
    load_pps2: np.ndarray      # (S,) signed: > 0 opposes the move
    damping_per_s: np.ndarray  # (S,)
    # when every rotor's curve is one curve scaled (no holding-torque cap): that curve and
    # k × scale per rotor, so T_pk is one np.interp (the common case, 3× faster)
    shared_curve: np.ndarray | None = None
    k_scale: np.ndarray | None = None

    @property
    def size(self) -> int:
        return len(self.k)

    def t_peak_pps2(self, speed_pps: np.ndarray) -> np.ndarray:
        """k · T_pk(|speed|) per rotor (linear in each curve segment; 0 beyond the curve)."""
        v = np.abs(speed_pps)
        cv = self.curve_v
        if self.shared_curve is not None and self.k_scale is not None:
            return self.k_scale * np.interp(v, cv, self.shared_curve, right=0.0)
        i = np.clip(np.searchsorted(cv, v, side="right") - 1, 0, len(cv) - 2)
        w = (v - cv[i]) / (cv[i + 1] - cv[i])
        rows = np.arange(self.size)
        t = self.amp[rows, i] + w * (self.amp[rows, i + 1] - self.amp[rows, i])
        t = np.where(v > cv[-1], 0.0, np.where(v == cv[-1], self.amp[:, -1], t))
        return self.k * t

    def natural_period_s(self, speed_pps: float) -> np.ndarray:
        stiffness = self.t_peak_pps2(np.full(self.size, speed_pps)) * self.c_e
        with np.errstate(divide="ignore"):
            return np.where(stiffness > 0, 2 * math.pi / np.sqrt(np.maximum(stiffness, 1e-300)),
                            np.inf)

    def step_s(self) -> float:
        period = self.natural_period_s(0.0)
        finite = period[np.isfinite(period)]
        return float(finite.min()) / STEPS_PER_NATURAL_PERIOD if len(finite) else 1e-4


def batch_rotor(motor: Motor, params: dict[str, np.ndarray], *, direction: int = 1) -> BatchRotor:
    """The rotors of `motor` with the given parameter arrays (keys from
    profiles.motor.TOLERANCE_KEYS, each of one length; missing ones stay nominal),
    exactly as `profiles.motor.rotor.rotor_of` builds one."""
    size = len(next(iter(params.values()))) if params else 1

    def get(key: str) -> np.ndarray:
        value = params.get(key)
        return np.full(size, motor.nominal(key)) if value is None else np.asarray(value, float)

    c_e = math.radians(motor.electrical_deg_per_pulse)
    scale = get("torque_scale")
    amp = np.asarray(motor.curve_torque_nm, dtype=float)[None, :] * scale[:, None]
    if motor.holding_torque_nm is not None:
        amp = np.minimum(amp, (motor.holding_torque_nm * scale)[:, None])
    k = motor.steps_per_rev / (2 * math.pi * get("inertia_kgm2"))
    omega_n0 = np.sqrt(np.maximum(k * c_e * amp[:, 0], 0.0))
    shared = motor.holding_torque_nm is None
    return BatchRotor(c_e, np.asarray(motor.curve_speed_pps, dtype=float), amp, k,
                      k * get("friction_torque_nm"), k * get("load_torque_nm") * direction,
                      2 * get("damping_ratio") * omega_n0,
                      np.asarray(motor.curve_torque_nm, dtype=float) if shared else None,
                      k * scale if shared else None)


@dataclass(frozen=True)
class BatchResult:
    peak_deg: np.ndarray   # (S,) worst |load angle| [electrical °]
    slipped: np.ndarray    # (S,) bool: slipped a pole
    steps: int             # RK4 steps taken (each advances every rotor)


def follow_batch(rotor: BatchRotor, spans: Sequence[tuple[float, float]], *,
                 step_s: float | None = None) -> BatchResult:
    """Integrate every rotor over `spans` of (duration_s, command speed_pps) from rest,
    then rest until all have settled (the scalar model's settle span)."""
    h_max = rotor.step_s() if step_s is None else step_s
    period0 = rotor.natural_period_s(0.0)
    settle = MAX_SETTLE_PERIODS * max(h_max * STEPS_PER_NATURAL_PERIOD,
                                      float(np.min(np.minimum(period0, 1.0))))
    size = rotor.size
    L = np.zeros(size)
    s = np.zeros(size)
    peak = np.zeros(size)
    slipped = np.zeros(size, dtype=bool)
    slip = math.radians(SLIP_DEG) / rotor.c_e
    tol = math.radians(SETTLE_TOL_DEG) / rotor.c_e
    fr, ld, dmp = rotor.friction_pps2, rotor.load_pps2, rotor.damping_per_s
    c_e = rotor.c_e
    previous = 0.0
    steps = 0
    for dur, v in [*spans, (settle, 0.0)]:
        s = s + (v - previous)
        previous = v
        if dur <= 0:
            continue
        n = max(1, math.ceil(dur / h_max))
        h = dur / n
        period = float(np.max(rotor.natural_period_s(v)))
        window = max(8, math.ceil(period / h)) if math.isfinite(period) else n + 1

        def accel(L: np.ndarray, s: np.ndarray, v: float = v) -> np.ndarray:
            u = v - s
            a = rotor.t_peak_pps2(u) * np.sin(c_e * L) + dmp * s - ld
            rest = np.where(np.abs(a) <= fr, 0.0, a - np.copysign(fr, a))
            return np.where(u > 0, a - fr, np.where(u < 0, a + fr, rest))

        lo, hi = L.copy(), L.copy()
        count = windows = 0
        for _ in range(n):
            k1L, k1s = s, -accel(L, s)
            k2L, k2s = s + 0.5 * h * k1s, -accel(L + 0.5 * h * k1L, s + 0.5 * h * k1s)
            k3L, k3s = s + 0.5 * h * k2s, -accel(L + 0.5 * h * k2L, s + 0.5 * h * k2s)
            k4L, k4s = s + h * k3s, -accel(L + h * k3L, s + h * k3s)
            L = L + h / 6 * (k1L + 2 * k2L + 2 * k3L + k4L)
            s = s + h / 6 * (k1s + 2 * k2s + 2 * k3s + k4s)
            steps += 1
            absl = np.abs(L)
            np.maximum(peak, absl, out=peak)
            slipped |= absl > slip
            if slipped.all():
                break
            np.minimum(lo, L, out=lo)
            np.maximum(hi, L, out=hi)
            count += 1
            if count >= window:
                windows += 1
                # settled (or, undamped, shown its extremes): the rest repeats this state
                if np.all((hi - lo < tol) | slipped) or windows >= MAX_SETTLE_PERIODS:
                    break
                lo, hi = L.copy(), L.copy()
                count = 0
            if steps >= MAX_RK4_STEPS:
                raise StepRampError(f"load-angle model: more than {MAX_RK4_STEPS} RK4 steps; "
                                    "raise the motor's damping_ratio")
        if slipped.all():
            break
    return BatchResult(np.degrees(peak * c_e), slipped, steps)
