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

The criterion is not the whole verdict: the rotor can ring past the load-angle aim on
short moves, decel stops and the other motion commands (constant runs, origin searches
and returns, immediate stops start or reverse at the start speed). `tighten_init`
plans again, gentler where the judge blames, until the table is within the aim under
everything the judge judges, as free curves are tightened (planner/tightening.py): the
judge is a callable (the CLI gives it `verify.safety.judge_safety`'s verdict, so a
table is planned against the one verdict it is checked by), and it says which of two
levers its worst angles come from: the start speed (whatever starts, stops or reverses
near rest) or the ramp (the rest). The start lever lowers the start speed; the ramp
lever the share of the torque the ramp may use (the safety factor), then, once that is
down to RAMP_FLOOR, the top speed. Once within the aim, bisections back towards the
last levers past it buy speed back; the price is the move time against the plain
table's (`extras["untightened"]`). When nothing gets within the aim, the closest table
comes back with `extras["fix"]`: what change to the motor or the machine would help.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from ...errors import InitBuildError, InitPlanError
from ...motor import Motor
from ...motor.angles import AIM_DEG, PEAK_DEG
from ...progress import Progress, track
from ...remembered import Remembered
from ...result import PlanResult
from ..clock import Clock
from ..criterion import all_length_safe
from ..init_model import (
    HIGH_RATE_MIN,
    INIT_PULSES_FIELD_MAX,
    INIT_PULSES_MIN,
    MIN_GAP,
    START_RATE_MAX,
    START_RATE_MIN,
    expand_init,
)
from ..table import FreeCurveTable, InitShape, InitTable

CANDIDATES_KEPT = 32   # candidate lists remembered (a tightening plans some motors twice)


@dataclass(frozen=True)
class InitCandidate:
    table: InitTable
    stages: FreeCurveTable  # the modelled staircase the chip would build


def init_candidates(motor: Motor, shape: InitShape, *, clock: Clock | None = None,
                    separate_decel: bool = True, highs: int = 16,
                    progress: Progress | None = None) -> list[InitCandidate]:
    """For `highs` high speeds spread geometrically from just above the start speed to
    the motor's top, the init table with the fewest stall-safe pulses (LE=1 with the
    decel counts minimised separately when `separate_decel`). `progress` hears
    (candidates searched, candidates)."""
    from .problem import choose_clock

    if shape not in ("linear", "s_curve"):
        raise InitPlanError(f"shape: {shape!r} is not 'linear' or 's_curve'")
    clock = clock or choose_clock(motor)
    start_rate = math.ceil(clock.hz / min(motor.start_pps, motor.jump_pps))
    if not START_RATE_MIN <= start_rate <= START_RATE_MAX:
        raise InitPlanError(f"the start speed needs rate {start_rate} at {clock.name}, outside "
                            f"{START_RATE_MIN}..{START_RATE_MAX}: choose another clock "
                            "(--clock)")
    top_rate = max(HIGH_RATE_MIN, math.ceil(clock.hz / motor.top_pps))
    slowest_high = start_rate - MIN_GAP
    if slowest_high < top_rate:
        raise InitPlanError(f"no high rate fits between the top speed (rate {top_rate}) and "
                            f"start rate {start_rate} − 0x80 at {clock.name}: a top speed "
                            "further above the start speed (max_pps, --cruise-reserve) or "
                            "another clock (--clock) would help")
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
                            f"at {clock.name}, even with the longest ramp the chip takes "
                            f"({INIT_PULSES_FIELD_MAX} pulses): a lower top speed (max_pps, "
                            "--cruise-reserve), a lower load inertia or more drive current "
                            "would help, or a free curve (--kind free)")
    return out


_candidates: Remembered[list[InitCandidate]] = Remembered(CANDIDATES_KEPT)


def forget_candidates() -> None:
    """Forget the remembered candidate lists (a test or a benchmark times a search)."""
    _candidates.clear()


def plan_init(motor: Motor, shape: InitShape, pulses: int, *, clock: Clock | None = None,
              separate_decel: bool = True,
              candidates: list[InitCandidate] | None = None,
              progress: Progress | None = None) -> PlanResult[InitTable]:
    """The stall-safe init table with the shortest modelled move of `pulses`;
    `progress` hears the candidate search (see `init_candidates`), whose last
    CANDIDATES_KEPT lists are remembered by the motor's values, shape, clock and LE.

    `extras`: `stages` (the modelled staircase, a FreeCurveTable) and `shape_run`
    (the move shape the chip runs: trapezoid, triangle …).
    """
    from profiles.ppmc312.execution import simulate_move

    from .problem import choose_clock

    started = time.perf_counter()
    if candidates is None:
        clock = clock or choose_clock(motor)
        key = (motor.values_key(), shape, clock, separate_decel)
        candidates, _ = _candidates.get(key, lambda: init_candidates(
            motor, shape, clock=clock, separate_decel=separate_decel, progress=progress))
    cands = candidates
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


def _smallest_safe(motor: Motor, clock: Clock, shape: InitShape, start: int, high: int,
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


# --- tightening for the load angle -------------------------------------------------------

TIGHTEN_ROUNDS = 8     # judged plans before the closest is returned
RELAX_STEPS = 2        # bisections back towards the last levers past the aim
RAMP_FLOOR = 0.4       # the ramp's share of the torque is not lowered below this; then the top
START_PARTS = ("constant", "origin-search", "origin-return", "stop")  # run from the start speed


class InitJudgement(NamedTuple):
    """What a judge says of an init table: safe (below the 90° peak everywhere) and within
    the aim, and the worst angles by the lever they come from: `start_deg` what starts,
    stops or reverses near rest drives (short moves, stops early on the ramp, the commands
    run from the start speed), `ramp_deg` the rest (0.0: nothing judged there).
    `failing`: what is past the aim ("moves", "decel-stop" or a command family's name);
    `worst_at`: where the worst angle is ("nominal", or a tolerance corner)."""

    safe: bool
    within_aim: bool
    start_deg: float
    ramp_deg: float
    failing: tuple[str, ...] = ()
    worst_at: str = "nominal"

    @property
    def worst_deg(self) -> float:
        return max(self.start_deg, self.ramp_deg)


InitJudge = Callable[[InitTable], InitJudgement]


@dataclass(frozen=True)
class Levers:
    """How much of the motor a tightened init table uses: its start speed, its ramp's
    share of the torque (the safety factor) and its top speed, each × this (1: plain)."""

    start: float = 1.0
    ramp: float = 1.0
    top: float = 1.0

    @property
    def plain(self) -> bool:
        return self == Levers()

    def motor(self, motor: Motor) -> Motor:
        """`motor` as gentle as these levers: what the criterion plans the table for (the
        jump limit kept where it was: only the start from rest is lowered)."""
        if self.plain:
            return motor
        return replace(motor, start_pps=motor.start_pps * self.start,
                       max_jump_pps=motor.jump_pps,
                       safety_factor=motor.safety_factor * self.ramp,
                       max_pps=motor.top_pps * self.top)

    def tightened(self, judged: InitJudgement, aim_deg: float) -> Levers:
        """Gentler where `judged` is past `aim_deg`: each blamed lever by about the share
        the angle is over (ringing and lag grow about in proportion to the torque used)."""
        start, ramp, top = self.start, self.ramp, self.top
        if judged.start_deg > aim_deg:
            start *= _factor(judged.start_deg, aim_deg)
        if judged.ramp_deg > aim_deg:
            f = _factor(judged.ramp_deg, aim_deg)
            if ramp * f >= RAMP_FLOOR:
                ramp *= f
            else:
                top *= f
        return Levers(start, ramp, top)

    def between(self, other: Levers) -> Levers:
        """Halfway (geometrically) between these levers and `other`."""
        return Levers(*(math.sqrt(a * b) for a, b in zip(
            (self.start, self.ramp, self.top), (other.start, other.ramp, other.top),
            strict=True)))


def _factor(worst_deg: float, aim_deg: float) -> float:
    return float(np.clip(aim_deg / worst_deg, 0.6, 0.95))


def tighten_init(motor: Motor, shape: InitShape, pulses: int, judge: InitJudge, *,
                 clock: Clock | None = None, separate_decel: bool = False,
                 aim_deg: float = AIM_DEG, progress: Progress | None = None
                 ) -> PlanResult[InitTable]:
    """The fastest init table for a move of `pulses` that `judge` finds within `aim_deg`
    (module docstring): planned by the criterion (on a tolerance box's worst case), then,
    while `judge` says it is past the aim, planned again for a gentler motor (`Levers`),
    then bisected back; `progress` hears each candidate search (a tightening runs
    several, each from 0). `extras` as `plan_init`'s, and `levers` (the Levers used),
    `judgement` (the judge's word on the table), `untightened` (the plain plan, for the
    price), `plans` (how many were judged) and, when no table is within the aim, `fix`
    (what would help) and the closest table."""
    from ...motor.tolerance import worst_case_motor

    if not 1.0 <= aim_deg <= PEAK_DEG:
        raise InitPlanError(f"load angle aim: {aim_deg:g}° is outside 1..{PEAK_DEG:g}°")
    t0 = time.perf_counter()
    planned = worst_case_motor(motor) if motor.tolerances else motor
    plain = plan_init(planned, shape, pulses, clock=clock, separate_decel=separate_decel,
                      progress=progress)
    clock = plain.table.clock
    tried = [(Levers(), plain, judge(plain.table))]

    def attempt(levers: Levers) -> bool:
        """Plan and judge at `levers`; False when no table is left (too gentle)."""
        try:
            plan = plan_init(levers.motor(planned), shape, pulses, clock=clock,
                             separate_decel=separate_decel, progress=progress)
        except InitPlanError:
            return False
        tried.append((levers, plan, judge(plan.table)))
        return True

    levers, failed = Levers(), None
    for _ in range(TIGHTEN_ROUNDS):
        if tried[-1][2].within_aim:
            break
        failed, levers = levers, levers.tightened(tried[-1][2], aim_deg)
        if levers == failed or not attempt(levers):
            break
    if tried[-1][2].within_aim and failed is not None:
        for _ in range(RELAX_STEPS):
            mid = levers.between(failed)
            if attempt(mid) and tried[-1][2].within_aim:
                levers = mid
            else:
                failed = mid
    return _chosen(tried, plain, motor, aim_deg, time.perf_counter() - t0)


def _chosen(tried: list[tuple[Levers, PlanResult[InitTable], InitJudgement]],
            plain: PlanResult[InitTable], motor: Motor, aim_deg: float,
            solve_s: float) -> PlanResult[InitTable]:
    """The fastest plan within the aim, else the one with the smallest worst angle (with
    `fix`), annotated with its levers, judgement and the plain plan."""
    within = [t for t in tried if t[2].within_aim]
    if within:
        levers, plan, judged = min(within, key=lambda t: float(t[1].duration_s or 0.0))
        extras = {}
    else:
        levers, plan, judged = min(tried, key=lambda t: (not t[2].safe, t[2].worst_deg))
        extras = {"fix": what_would_help(judged, motor, aim_deg)}
    info = plan.info + f"; worst load angle {judged.worst_deg:.1f}° electrical"
    binds = plan.binds
    if not levers.plain:
        info += " (tightened: " + ", ".join(
            f"{name} ×{x:.3g}" for name, x in (("start", levers.start), ("ramp", levers.ramp),
                                               ("top", levers.top)) if x < 1) + ")"
        binds = "load angle (tightened)"
    return replace(plan, info=info, binds=binds, solve_s=solve_s, extras={
        **plan.extras, **extras, "levers": levers, "judgement": judged,
        "worst_load_angle_deg": judged.worst_deg, "untightened": plain,
        "plans": len(tried)})


def what_would_help(judged: InitJudgement, motor: Motor, aim_deg: float) -> str:
    """The changes that would help a motor no init table keeps within `aim_deg`, by what
    is past it: the start (more torque for the inertia), the ramp (a lower top speed), a
    tolerance corner (a narrower friction range), only some command families (leaving
    them out of the verdict, where the machine never runs them)."""
    helps = []
    if judged.start_deg > aim_deg:
        helps.append("a lower load inertia or more drive current (the start rings even at "
                     "the lowest start speed tried)")
    if judged.ramp_deg > aim_deg:
        helps.append("a lower top speed (max_pps in the motor file, or a larger "
                     "--cruise-reserve)")
    low, high = motor.tolerance("friction_torque_nm")
    if "friction" in judged.worst_at and high > low:
        helps.append("a narrower friction range (the friction you measured: friction_coeff "
                     "in --load, or friction_torque_nm)")
    families = [f for f in judged.failing if f not in ("moves", "decel-stop")]
    if families and len(families) == len(judged.failing):
        from ..motion import COMMANDS

        kept = ",".join(f"{c.code:02X}" for n, c in COMMANDS.items() if n not in families)
        helps.append(f"--commands {kept} if the machine never runs "
                     + ", ".join(f"{COMMANDS[f].code:02X} ({f})" for f in families))
    return "; ".join(helps) or f"a motor that keeps the rotor within {aim_deg:g}°"
