"""The planning problem: the clock, the move, the motor's limits as the DP sees them,
and how much of the motor a table may use in each speed band (`Shaping`)."""

from __future__ import annotations

import bisect
import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import PlanError, require_int
from ...motor import Motor
from ...motor.resonance import narrow_bands, top_allowed
from ...result import PlanResult
from ..clock import INTERNAL_HZ, MAX_OUTPUT_PPS, Clock
from ..limits import (
    MIN_STAGE_TICKS,
    RATE_MAX,
    RATE_MIN,
    STAGE_PULSES_MAX,
    STAGES_MAX,
    STAGES_MIN,
)
from ..table import FreeCurveTable

Plan = PlanResult[FreeCurveTable]  # what every free-curve planner returns

REFERENCE_MOVE_FACTOR = 10  # pulses=None: 10 × the continuous ramps' pulses (see notes)

# --------------------------------------------------------------------------- clock
def choose_clock(motor: Motor) -> Clock:
    """The fastest internal clock (finest speed resolution) whose rates reach the start speed.

    The slowest stage must run at ≤ start_pps, i.e. rate ≥ f_clk / start_pps, and that
    rate must fit the 16-bit field. Top speed only needs rate ≥ 2, which a faster
    clock meets at least as well, so the start speed decides. EXTCK is never chosen.
    """
    for name, hz in INTERNAL_HZ.items():
        if math.ceil(hz / motor.start_pps) <= RATE_MAX:
            return Clock.internal(name)
    slowest = min(INTERNAL_HZ.values())
    raise PlanError(f"start_pps {motor.start_pps:g} is below the slowest speed any internal clock "
                    f"can run ({slowest / RATE_MAX:.4g} pps at 15.625kHz); raise start_pps")


# --------------------------------------------------------------------------- problem
def base_pulses(rates: Any) -> Any:
    """Chip minimum of a stage: 2 pulses and 256 clock ticks."""
    r = np.asarray(rates, dtype=float)
    return np.maximum(2.0, np.ceil(MIN_STAGE_TICKS / r))


@dataclass(frozen=True)
class Shaping:
    """How much of the motor a table may use, speed band by speed band: in band b
    (speeds edges_pps[b−1] ≤ f < edges_pps[b]) the stage counts come from the
    safety factor × scale[b] and the jumps are at most the jump limit × scale[b]; the
    slowest stage runs at most start_pps × start_scale. All 1 is the plain criterion;
    all equal to s is the whole table tightened alike (the safety factor, the largest
    jump and the start speed × s). The load-angle tightening
    (profiles.ppmc312.planner.tighten) lowers the bands where the rotor rings."""

    edges_pps: tuple[float, ...] = ()
    scale: tuple[float, ...] = (1.0,)
    start_scale: float = 1.0

    @classmethod
    def uniform(cls, s: float) -> Shaping:
        return cls((), (s,), s)

    @classmethod
    def bands(cls, motor: Motor, ratio: float = 1.5) -> Shaping:
        """Geometric bands from the start speed up to the top speed, all at 1."""
        edges = []
        f = motor.start_pps * ratio
        while f < motor.top_pps:
            edges.append(f)
            f *= ratio
        return cls(tuple(edges), (1.0,) * (len(edges) + 1), 1.0)

    def band(self, speed_pps: float) -> int:
        """The band of a speed: edges_pps[b−1] ≤ speed < edges_pps[b]."""
        return bisect.bisect_right(self.edges_pps, speed_pps)

    def scaled(self, bands: dict[int, float], start: float = 1.0) -> Shaping:
        """This shaping with band b's scale × bands[b] and the start scale × `start`."""
        scale = list(self.scale)
        for b, f in bands.items():
            scale[b] *= f
        return Shaping(self.edges_pps, tuple(scale), self.start_scale * start)

    def between(self, other: Shaping) -> Shaping:
        """Halfway (geometrically) between this shaping and `other`, band by band."""
        return Shaping(self.edges_pps, tuple(math.sqrt(a * b) for a, b in
                                             zip(self.scale, other.scale, strict=True)),
                       math.sqrt(self.start_scale * other.start_scale))

    @property
    def plain(self) -> bool:
        return self.start_scale == 1.0 and all(s == 1.0 for s in self.scale)


@dataclass
class Problem:
    motor: Motor
    hz: float
    separate: bool
    jump: float
    start: float
    r_fast: int    # smallest rate allowed (top speed, 2 Mpps, rate ≥ 2)
    r_start: int   # smallest rate at or below the start speed
    shaping: Shaping = field(default_factory=Shaping)

    def jump_at(self, speed_pps: float) -> float:
        """The largest jump up from a speed."""
        return self.jump * self.shaping.scale[self.shaping.band(speed_pps)]

    def counts(self, r_slow: Any, r_fast: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Minimal (accel, decel) counts of the slower stage of each step, and validity.

        Per step f_slow → f_fast (Δ = f_fast − f_slow): the least capability over
        [f_slow, f_fast] (a_acc for accel, a_dec for decel; in a shaped band, with the
        safety factor × σ: (σ·sf·T − T_f − |T_L|)·k and (σ·sf·T + T_f − |T_L|)·k), then
        n = max(base, ceil(Δ·f_slow / a)), both sides max'd for LE=0; valid when
        0 < Δ ≤ the (band's) jump limit, the counts fit their field and neither stage
        lies in a band a jump can step over. Run compiled (dp_kernel.stage_counts)."""
        from .dp_kernel import stage_counts

        rs, rf = np.broadcast_arrays(np.asarray(r_slow, dtype=float),
                                     np.asarray(r_fast, dtype=float))
        shape = rs.shape
        n, d = np.empty(rs.size), np.empty(rs.size)
        valid = np.empty(rs.size, dtype=bool)
        stage_counts(np.ascontiguousarray(rs).ravel(),  # type: ignore[call-arg]
                     np.ascontiguousarray(rf).ravel(), *self.count_constants, n, d, valid)
        return n.reshape(shape), d.reshape(shape), valid.reshape(shape)

    def graph_counts(self, rates: np.ndarray, width: int) -> tuple[np.ndarray, ...]:
        """The counts of every step of the planner's graph (node j of `rates`, slowest
        first, from each of j − 1 … j − width), as the DP weighs them: (G, width) arrays
        of accel + decel, accel, both packed (total << 32 | accel; a path's sums stay far
        below 2^31: 127 × 0xFFFFF × 2) and validity, each 0 where the step is invalid or
        j − 1 − w < 0; and each node's reach (1 + its last valid w, 0 when none). `counts`
        on those steps is the reference (tests/profiles/ppmc312/planner/test_dp_kernel.py);
        one compiled pass that interpolates the curve once per node
        (dp_kernel.graph_counts)."""
        from .dp_kernel import graph_counts

        g = len(rates)
        weight, accel = np.empty((g, width)), np.empty((g, width))
        packed_w = np.empty((g, width), dtype=np.int64)
        valid = np.empty((g, width), dtype=bool)
        reach = np.empty(g, dtype=np.int64)
        graph_counts(np.ascontiguousarray(rates, dtype=np.int64), int(width),  # type: ignore[call-arg]
                     *self.count_constants, weight, accel, packed_w, valid, reach)
        return weight, accel, packed_w, valid, reach

    @functools.cached_property
    def count_constants(self) -> tuple[Any, ...]:
        """What `counts` hands the kernel besides the steps: the motor, the shaping and the
        chip's limits, prepared once per problem (the planner counts hundreds of times)."""
        m = self.motor
        return (float(self.hz), m.curve_speed_pps, m.curve_torque_nm, float(m.safety_factor),
                float(m.friction_torque_nm), float(abs(m.load_torque_nm)),
                float(m.pps2_per_nm), np.asarray(self.shaping.edges_pps, dtype=float),
                np.asarray(self.shaping.scale, dtype=float), self.shaping.plain,
                float(self.jump), self.separate,
                np.asarray(narrow_bands(m), dtype=float).reshape(-1, 2),
                float(MIN_STAGE_TICKS), float(STAGE_PULSES_MAX))

    def top_ok(self, rates: Any) -> np.ndarray:
        """The top stage (the cruise) lies outside every resonance band."""
        return top_allowed(self.hz / np.asarray(rates, dtype=float), self.motor)


def make_problem(motor: Motor, clock: Clock, separate: bool,
                 shaping: Shaping | None = None) -> Problem:
    shaping = shaping or Shaping()
    hz = clock.hz
    top = min(motor.top_pps, MAX_OUTPUT_PPS)
    r_fast = max(RATE_MIN, math.ceil(hz / top))
    start = motor.start_pps * shaping.start_scale
    r_start = math.ceil(hz / start)
    if r_start > RATE_MAX:
        raise PlanError(f"clock {clock.name}: the start speed {start:g} pps needs rate "
                        f"{r_start} > {RATE_MAX}; use a slower clock (choose_clock picks one)")
    if r_start <= r_fast:
        raise PlanError(f"clock {clock.name}: no rate lies between the start speed "
                        f"{start:g} pps and the top speed {top:g} pps; a table needs "
                        "two stages")
    return Problem(motor, hz, separate, motor.jump_pps, start, r_fast, r_start, shaping)


def check_plan_args(max_stages: int, pulses: int | None) -> None:
    require_int("max_stages", max_stages, STAGES_MIN, STAGES_MAX)
    if pulses is not None:
        # 2 stages × 2 pulses × 2 sides is the smallest trapezoid a free curve can run
        require_int("pulses", pulses, 8, 0xFFFFFFFF)


def reference_pulses(motor: Motor) -> int:
    """The move `pulses=None` plans for: 10 × the pulses the continuous (exact, no-jerk)
    optimum spends accelerating from start_pps to 90 % of the top usable speed and back.

    The top usable speed is the curve's top, capped at 2 Mpps and at the first speed
    where a_acc reaches 0 (the ramp's pulses diverge there).
    """
    top = min(motor.top_pps, MAX_OUTPUT_PPS)
    v = np.linspace(0.0, top, 4001)
    dead = np.flatnonzero(motor.a_acc_pps2(v) <= 0)
    if len(dead):
        top = float(v[dead[0]])
    v_hi = max(0.9 * top, motor.start_pps)
    v = np.linspace(motor.start_pps, v_hi, 2001)
    dens = v / motor.a_acc_pps2(v) + v / motor.a_dec_pps2(v)
    ramp = float(np.sum((dens[1:] + dens[:-1]) * np.diff(v)) / 2)
    return int(max(1000, math.ceil(REFERENCE_MOVE_FACTOR * ramp)))


