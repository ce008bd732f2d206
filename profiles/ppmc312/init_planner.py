"""The best stall-safe init table (linear or S-curve) for a motor and a move.

What the free curve buys is only visible against the best the chip's own init
tables can do, so this searches them honestly: for each candidate high rate
the smallest accel (and, LE=1, decel) pulse counts whose modelled staircase
(`profiles.ppmc312.init_model.expand_init`, a documented model of the chip's table
builder) passes the stall-safety criterion over every move length the chip can run
(`profiles.ppmc312.criterion`), then
the candidate with the shortest simulated move wins.

The smallest stall-safe counts per high rate do not depend on the move length,
so `init_candidates` computes them once per motor and shape, and `plan_init`
only simulates moves over them.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ..errors import InitBuildError, InitPlanError
from ..motor import Motor
from ..progress import Progress, track
from ..result import PlanResult
from .clock import Clock
from .criterion import all_length_safe
from .init_model import (
    HIGH_RATE_MIN,
    INIT_PULSES_FIELD_MAX,
    INIT_PULSES_MIN,
    MIN_GAP,
    START_RATE_MAX,
    START_RATE_MIN,
    expand_init,
)
from .table import FreeCurveTable, InitTable

Shape = Literal["linear", "s_curve"]


@dataclass(frozen=True)
class InitCandidate:
    table: InitTable
    stages: FreeCurveTable  # the modelled staircase the chip would build


def init_candidates(motor: Motor, shape: Shape, *, clock: Clock | None = None,
                    separate_decel: bool = True, highs: int = 16,
                    progress: Progress | None = None) -> list[InitCandidate]:
    """For `highs` high speeds spread geometrically from just above the start speed to
    the motor's top, the init table with the fewest stall-safe pulses (LE=1 with the
    decel counts minimised separately when `separate_decel`). `progress` hears
    (candidates searched, candidates)."""
    from .planner import choose_clock

    if shape not in ("linear", "s_curve"):
        raise InitPlanError(f"shape: {shape!r} is not 'linear' or 's_curve'")
    clock = clock or choose_clock(motor)
    start_rate = math.ceil(clock.hz / min(motor.start_pps, motor.jump_pps))
    if not START_RATE_MIN <= start_rate <= START_RATE_MAX:
        raise InitPlanError(f"the start speed needs rate {start_rate} at {clock.name}, outside "
                            f"{START_RATE_MIN}..{START_RATE_MAX}: choose another clock")
    top_rate = max(HIGH_RATE_MIN, math.ceil(clock.hz / motor.top_pps))
    slowest_high = start_rate - MIN_GAP
    if slowest_high < top_rate:
        raise InitPlanError(f"no high rate fits between the top speed (rate {top_rate}) and "
                            f"start rate {start_rate} − 0x80 at {clock.name}")
    speeds = np.geomspace(clock.hz / slowest_high, clock.hz / top_rate, highs)
    high_rates = sorted({min(slowest_high, max(top_rate, math.ceil(clock.hz / v)))
                         for v in speeds})
    out = []
    for high in track(high_rates, progress):
        cand = _smallest_safe(motor, clock, shape, start_rate, high, separate_decel)
        if cand is not None:
            out.append(cand)
    if not out:
        raise InitPlanError(f"no {shape} init table is stall-safe for {motor.name or 'motor'} "
                            f"at {clock.name}")
    return out


def plan_init(motor: Motor, shape: Shape, pulses: int, *, clock: Clock | None = None,
              separate_decel: bool = True,
              candidates: list[InitCandidate] | None = None,
              progress: Progress | None = None) -> PlanResult[InitTable]:
    """The stall-safe init table with the shortest modelled move of `pulses`;
    `progress` hears the candidate search (see `init_candidates`).

    `extras`: `stages` (the modelled staircase, a FreeCurveTable) and `shape_run`
    (the move shape the chip runs: trapezoid, triangle …).
    """
    from profiles.ppmc312.execution import simulate_move

    started = time.perf_counter()
    cands = candidates if candidates is not None else init_candidates(
        motor, shape, clock=clock, separate_decel=separate_decel, progress=progress)
    best: tuple[float, InitCandidate, str] | None = None
    for cand in cands:
        run = simulate_move(cand.stages, pulses)
        if best is None or run.duration_s < best[0]:
            best = (run.duration_s, cand, run.shape)
    assert best is not None  # init_candidates never returns an empty list
    duration, cand, run_shape = best
    t = cand.table
    info = (f"{t.shape} init: start rate {t.start_rate}, high rate {t.high_rate} "
            f"({t.clock.hz / t.high_rate:.6g} pps), accel {t.accel_pulses}"
            + (f" + decel {t.decel_pulses}" if t.separate else "")
            + f" pulses, {len(cand.stages.rates)} modelled stages, {run_shape}")
    top_rate = max(HIGH_RATE_MIN, math.ceil(t.clock.hz / motor.top_pps))
    if run_shape != "trapezoid":
        binds = "move length (the ramps meet before the high speed)"
    elif t.high_rate <= top_rate:
        binds = "top speed"
    else:  # a faster high rate needs ramps so long the move is slower overall
        binds = f"stall criterion ({t.shape} ramp)"
    return PlanResult(t, duration, binds, info, pulses, t.clock,
                      time.perf_counter() - started,
                      extras={"stages": cand.stages, "shape_run": run_shape})


def _smallest_safe(motor: Motor, clock: Clock, shape: Shape, start: int, high: int,
                   separate: bool) -> InitCandidate | None:
    def table(accel: int, decel: int | None) -> InitTable:
        return InitTable(clock, shape, start, high, accel,
                         start if decel is not None else None, decel)

    def safe(t: InitTable) -> bool:
        try:
            stages = expand_init(t)
        except InitBuildError:
            return False
        return all_length_safe(stages, motor)

    accel = _bisect(lambda p: safe(table(p, None)))
    if accel is None:
        return None
    decel = None
    if separate:
        # The sides share the model's rate grid (fewer decel pulses can mean fewer,
        # coarser stages on both sides), so the whole table is judged, not just the decel.
        decel = _bisect(lambda d: safe(table(accel, d)), hi=accel)
    final = table(accel, decel)
    return InitCandidate(final, expand_init(final))


def _bisect(ok: object, *, hi: int = INIT_PULSES_FIELD_MAX) -> int | None:
    """Smallest pulse count in [0x100, hi] for which `ok` holds, assuming (near-)monotone
    feasibility; the answer is always verified, so rounding wrinkles cost pulses, not safety."""
    assert callable(ok)
    lo = INIT_PULSES_MIN
    if not ok(hi):
        return None
    if ok(lo):
        return lo
    # Geometric bisection: counts span 256 … 1 048 575.
    while hi - lo > max(1, lo // 200):
        mid = int(math.sqrt(lo * hi)) if hi > 2 * lo else (lo + hi) // 2
        mid = min(max(mid, lo + 1), hi - 1)
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return hi
