"""MC-200 command values along a profile: positions, velocities and currents.

A stream samples the profile it follows once per SPI period, at t = k·period
(k = 0 … count, the last sample at the move's end). What each mode sends:

- position (page 1, int32 [pulses]): ⌊profile⌋, monotone, never ahead
  (`iter_positions`, in `stream`);
- velocity (page 2, float32; the sheet gives no unit, stepramp writes pulses per
  second of the position page's pulses [pps]): the period's mean speed,
  v_k = (x(k+1) − x(k)) / period, so the velocities integrate to the profile's
  position at every sample and to the move exactly at its end;
- current (page 3, float32; no unit printed, stepramp writes amperes [A], the unit
  the replies' モータ電流値 is read in): the torque the move needs over the period,
  J·α + friction (while moving) + the load, divided by the motor's torque constant
  (`CurrentModel`); α is the central difference of the mean speeds,
  (v_{k+1} − v_{k−1}) / (2·period), the mean acceleration over the period to second
  order, at rest before and after the move.

Everything is computed a chunk at a time (numpy, no loop per sample): a stream of
millions of packets never holds its values whole. The choices: docs/manual-notes.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import FormatError, require_int, require_number

if TYPE_CHECKING:
    from ..motor import Motor

PositionFn = Callable[[np.ndarray], np.ndarray]
VELOCITY_UNIT = "pps"  # the sheet's 指令速度 has no unit: pulses (the position page's) per s
CURRENT_UNIT = "A"     # the sheet's 指令電流値 has no unit: amperes, as the replies are read
UNITS = {"position": "pulses", "velocity": VELOCITY_UNIT, "current": CURRENT_UNIT}
TORQUE_CONSTANT_RANGE = (0.0, 1e3)  # N·m/A (0 excluded): a servo's Kt is 0.01–10


@dataclass(frozen=True)
class CurrentModel:
    """The current a move needs: torque / Kt, the torque J·α + friction + load.

    `inertia_kgm2` is everything the motor turns (rotor and load), `pulses_per_rev`
    the profile's pulses per revolution, `friction_nm` opposes motion (counted while
    the mean speed is above 0), `load_nm` > 0 opposes forward motion (counted at rest
    too: holding a load takes its torque)."""

    torque_constant_nm_per_a: float
    inertia_kgm2: float
    pulses_per_rev: int
    friction_nm: float = 0.0
    load_nm: float = 0.0

    def __post_init__(self) -> None:
        lo, hi = TORQUE_CONSTANT_RANGE
        require_number("torque_constant_nm_per_a", self.torque_constant_nm_per_a, lo, hi,
                       lo_open=True)
        require_number("inertia_kgm2", self.inertia_kgm2, 0.0, 1e3, lo_open=True)
        require_int("pulses_per_rev", self.pulses_per_rev, 1, 10_000_000)
        require_number("friction_nm", self.friction_nm, 0.0, 1e4)
        require_number("load_nm", self.load_nm, -1e4, 1e4)

    @classmethod
    def from_motor(cls, motor: Motor, torque_constant_nm_per_a: float) -> CurrentModel:
        """The motor file's inertia, steps per revolution, friction and load."""
        return cls(torque_constant_nm_per_a, motor.inertia_kgm2, motor.steps_per_rev,
                   motor.friction_torque_nm, motor.load_torque_nm)

    @property
    def hold_a(self) -> float:
        """The current at rest: the load's torque (static friction is not counted on)."""
        return self.load_nm / self.torque_constant_nm_per_a

    def current_a(self, speed_pps: np.ndarray, accel_pps2: np.ndarray) -> np.ndarray:
        """The current [A] for mean speeds [pps] and accelerations [pps²]."""
        rad_per_pulse = 2 * math.pi / self.pulses_per_rev
        torque = (self.inertia_kgm2 * accel_pps2 * rad_per_pulse
                  + np.where(speed_pps > 0, self.friction_nm, 0.0) + self.load_nm)
        return torque / self.torque_constant_nm_per_a


def iter_samples(position_at: PositionFn, duration_s: float, pulses: int, period_s: float,
                 *, chunk: int, floor: bool = False) -> Iterator[np.ndarray]:
    """The profile at t = 0, period, 2·period, … (the last at `duration_s`), `chunk`
    samples at a time: clipped to [0, pulses], made monotone (the running maximum
    carried over), the first 0 and the last exactly `pulses`; with `floor`, whole
    pulses (⌊profile⌋: the position commands)."""
    count = max(1, math.ceil(duration_s / period_s - 1e-9))
    carry = 0.0
    for k0 in range(0, count + 1, chunk):
        k = np.arange(k0, min(k0 + chunk, count + 1))
        t = np.minimum(k * period_s, duration_s)
        try:
            p = np.asarray(position_at(t), dtype=float)
        except (TypeError, ValueError) as e:
            raise FormatError(f"position_at: cannot evaluate the profile ({e})") from None
        if p.shape != t.shape or not np.all(np.isfinite(p)):
            raise FormatError(f"position_at: expected {t.size} finite positions, got shape "
                              f"{p.shape}")
        p = np.clip(p, 0, pulses)
        q = np.maximum.accumulate(np.maximum(np.floor(p) if floor else p, carry))
        carry = float(q[-1])
        if k0 == 0:
            q[0] = 0
        if k[-1] == count:
            q[-1] = pulses
        yield q


def iter_velocities(position_at: PositionFn, duration_s: float, pulses: int,
                    period_s: float, *, chunk: int) -> Iterator[np.ndarray]:
    """The velocity commands [pps], one per period: v_k = (x(k+1) − x(k)) / period over
    the samples of `iter_samples` (count values for count + 1 samples)."""
    before: float | None = None
    for x in iter_samples(position_at, duration_s, pulses, period_s, chunk=chunk):
        if before is not None:
            x = np.concatenate(([before], x))
        if len(x) > 1:
            yield np.diff(x) / period_s
        before = float(x[-1])


def iter_currents(velocities: Iterable[np.ndarray], period_s: float,
                  model: CurrentModel) -> Iterator[np.ndarray]:
    """The current commands [A], one per velocity command: the acceleration of each
    period the central difference of its neighbours' mean speeds (at rest before the
    first and after the last), a chunk held back until the next one's first speed is
    known."""
    before = 0.0
    pending: np.ndarray | None = None
    for v in velocities:
        if not len(v):
            continue
        if pending is not None:
            yield _currents(pending, before, float(v[0]), period_s, model)
            before = float(pending[-1])
        pending = v
    if pending is not None:
        yield _currents(pending, before, 0.0, period_s, model)


def _currents(v: np.ndarray, before: float, after: float, period_s: float,
              model: CurrentModel) -> np.ndarray:
    padded = np.concatenate(([before], v, [after]))
    return model.current_a(v, (padded[2:] - padded[:-2]) / (2 * period_s))


def sample_velocities(position_at: PositionFn, duration_s: float, pulses: int,
                      period_s: float) -> np.ndarray:
    """Every velocity command of a move at once (small moves, tests)."""
    parts = list(iter_velocities(position_at, duration_s, pulses, period_s, chunk=1 << 16))
    return np.concatenate(parts)


def sample_currents(position_at: PositionFn, duration_s: float, pulses: int,
                    period_s: float, model: CurrentModel) -> np.ndarray:
    """Every current command of a move at once (small moves, tests)."""
    velocities = iter_velocities(position_at, duration_s, pulses, period_s, chunk=1 << 16)
    return np.concatenate(list(iter_currents(velocities, period_s, model)))
