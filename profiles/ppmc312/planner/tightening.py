"""Tightening a plan for the load angle where the rotor rings, not everywhere.

A table that passes the criterion can still ring: each speed step excites the rotor's
oscillation about its lag (about c_e·Δv/ω_n of angle), on top of the lag the
acceleration itself needs (sin δ = the share of the pull-out torque in use). Short
moves run only the slow end of the table, where the steps are largest, and a
triangle's accel→decel switch; long moves spend their time elsewhere. So the table
is judged over every execution (profiles.ppmc312.load_angle), each execution past
the aim is traced to the command's speed steps within the last natural period before
its worst angle, and only those speed bands (`Shaping`: the capability share and the
jump limit there, and the start speed when the jump from rest or the stop to rest is
among them) are
planned again more gently, until every execution is within the aim. A long move then
pays only for the bands its own ramp shares with the short moves that rang. The
executions are the moves' and, by default, a decel stop's (81) at every pulse of the
ramp under every reading (profiles.ppmc312.stops): a stop that rings is traced alike
and blames the stages just before its worst angle (where it comes and the decel below).
A round traces the worst executions and, beside them, the worst of every other speed
band where one past the aim tops out (`_diverse`): the bands that ring are blamed at
once instead of surfacing one round at a time (NEMA23's designer changes: 1–4 plans
where they took 5–8). One just past the aim may be the others' echo, blamed for
nothing: NEMA17's 3 200–10 000-pulse tables are 0.3–0.5 % slower for it, NEMA23's
10 000-pulse one 0.8 % faster; blaming only bands 4 % past the aim cost NEMA17 0.1 %
but left NEMA23's designer changes at 4 plans where they now take 3.

Once within the aim by more than RELAX_ROOM_DEG, two bisections back towards the last
shaping past it buy speed (2–3 % of NEMA23's short moves' time with 10° of room; with
2–4° they bought under 0.2 % for two more plans). Such a step only asks within-or-not:
its plan is judged first at the move lengths where that shaping was worst, and one past
the aim there is refused without the all-length verdict; then its moves, and its stops
only when the moves are within (`judged`'s `settle`).

A round's moves are judged by their samples alone when these already say within or
past (`load_angle.angles`' aim_deg: one past the aim, or every one 3° or more below it,
refining raising a family's worst by less); the plan kept is then judged whole. The
decisions are those of judging every plan whole (tested), a refinement fewer a round.

When the bands do not converge, the whole table is tightened alike (`tighten_uniform`:
the safety factor, the largest jump and the start speed scaled together), the method
this one replaced and the baseline it is measured against (bench/bench_tighten.py).
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Future
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ...errors import FieldRangeError, PlanError
from ...motor import Motor
from ...motor.angles import PEAK_DEG
from ...motor.rotor import Rotor, follow, rotor_of
from ...threads import pool
from ..execution import Execution, simulate_moves
from ..load_angle import Angles, angles, spans_of
from ..stops import (
    StopAngles,
    dwell_of,
    locate,
    ramp_pulse,
    readings_of,
    stop_angles,
    stop_execution,
)
from ..table import FreeCurveTable
from .problem import Plan, Shaping

Make = Callable[[Motor, Shaping | None], Plan]

LOCAL_ROUNDS = 8          # band repairs before falling back to uniform tightening
RELAX_STEPS = 2           # bisections back towards the last shaping past the aim,
RELAX_ROOM_DEG = 4.0      # when the plan came out this far within the aim
CULPRITS = 6              # executions past the aim traced per round (the worst first)
BAND_CULPRITS = 8         # and the worst of each other speed band's past the aim
SCREEN = 12               # a relax step is judged first at the move lengths where the
SCREEN_MARGIN_DEG = 0.1   # shaping past the aim was worst: this far past it there, it fails
WINDOW_PERIODS = 0.75     # how far before its worst angle an execution's steps are blamed
TIGHTEN_STEP = 0.85
TIGHTEN_ROUNDS = 8
TIGHTEN_BISECT = 2


class Judged(NamedTuple):
    """A table's load angle over every move (`moves`) and, unless not asked, every decel
    stop (`stops`)."""

    moves: Angles
    stops: StopAngles | None

    def worst(self) -> float:
        return max(float(self.moves.deg.max()),
                   0.0 if self.stops is None else self.stops.worst_deg())

    @property
    def exact(self) -> bool:
        """False: the moves' samples alone (`worst` a lower bound, on the same side of
        the aim as the exact one)."""
        return self.moves.refined


class Screen(NamedTuple):
    """Where a shaping past the aim was worst: the move lengths and the decel stops, each
    as (pulse of the ramp, reading): where it comes, which a gentler table runs too."""

    lengths: np.ndarray
    stops: list[tuple[int, str]]


def judged(table: FreeCurveTable, judges: Sequence[Motor], stops: bool = True,
           aim_deg: float | None = None, *, settle: bool = False) -> Judged:
    """Every move and (`stops`) every decel stop of `table` on `judges`, both remembered:
    the safety verdict asks again. `aim_deg`: the moves' samples alone when they say
    whether the table is within it (`load_angle.angles`; `Judged.exact` False).
    `settle`: only within-or-not is asked, so the moves are judged first, and with them
    past the aim the stops are not judged (`Judged.stops` None)."""
    if stops and not settle:
        # the stops' verdict beside the moves': each one's serial parts (batches built,
        # references integrated) overlap the other's kernels, which run on every core
        side = pool("judge-stops", 1).submit(stop_angles, table, judges)
        return Judged(angles(table, judges, aim_deg=aim_deg), side.result())
    moves = angles(table, judges, aim_deg=aim_deg)
    past = aim_deg is not None and float(moves.deg.max()) > aim_deg
    return Judged(moves, stop_angles(table, judges) if stops and not past else None)


def tighten(motor: Motor, make: Make, load_angle_deg: float, *,
            judges: Sequence[Motor] | None = None, start: Shaping | None = None,
            stops: bool = True, ramp_floor: float = 0.0) -> Plan:
    """Plan with `make`, judge the table's load angle over every execution on `judges`
    (default: `motor`; a tolerance box's corners): every move and (`stops`) a decel stop
    at every pulse of the ramp under every reading, and while some execution exceeds
    `load_angle_deg`, plan again more gently in the speed bands that drove it (module
    docstring). Refuses when nothing gets below the 90° peak. The plan's
    `extras["worst_load_angle_deg"]` and `extras["shaping"]` say what was reached,
    `extras["plans"]` how many plans it tried.

    `start`: a shaping to try first instead of the plain criterion, e.g. where another
    move of the same motor ended (a duty cycle's candidates: the bands that ring are the
    motor's). Within the aim, it is kept as it is (nothing past the aim is known to
    relax towards); past it, tightening goes on from there; when it leaves no table for
    this move, from the plain criterion. `ramp_floor`: no band's share below it, the start
    going on down (free_curve.lower_top: a ramp below the friction leaves no table)."""
    _check_aim(load_angle_deg)
    t0 = time.perf_counter()
    judges = list(judges or [motor])
    plain = Shaping.bands(motor)
    warm = start is not None and not start.plain and start.edges_pps == plain.edges_pps
    shaping = start if warm and start is not None else plain
    tried: list[Plan] = []
    failed: Shaping | None = None   # the last shaping past the aim
    failed_at = Screen(np.zeros(0, dtype=np.int64), [])  # where it was worst
    made = [0]                                # plans tried
    # tried plans judged by their samples alone (by index): made exact if kept
    bounded: dict[int, tuple[Plan, Shaping]] = {}

    def attempt(shaping: Shaping, screen: Screen | None = None) -> tuple[Plan, Judged] | None:
        """The plan and its verdict; None when there is no table, or when it is past the
        aim at one of the `screen` executions (a relax step: only within-or-not matters,
        and failing there spares the every-execution verdict)."""
        made[0] += 1
        try:
            plan = make(motor, None if shaping.plain else shaping)
        except PlanError:
            if not tried and shaping.plain:
                raise  # the plain criterion has no table: nothing gentler has one either
            return None  # too gentle for the move: the bands went too far
        if screen is not None and _screened_out(plan.table, judges, screen,
                                                load_angle_deg + SCREEN_MARGIN_DEG):
            return None
        # remembered: the verdict asks again; samples that say within or past are enough
        # until the plan is kept
        found = judged(plan.table, judges, stops, load_angle_deg, settle=screen is not None)
        if not found.exact:
            bounded[len(tried)] = (plan, shaping)
        plan = _annotated(plan, found.worst(), shaping, len(judges), t0, stops)
        tried.append(plan)
        return plan, found

    within = False
    for _ in range(LOCAL_ROUNDS):
        done = attempt(shaping)
        if done is None and not tried and not shaping.plain:
            done = attempt(shaping := plain)  # the start left no table: begin plain
        if done is None:
            break
        plan, found = done
        if plan.extras["worst_load_angle_deg"] <= load_angle_deg:
            # the factors are first-order: halfway back towards the last shaping past the
            # aim is often within it too, and faster
            room = plan.extras["worst_load_angle_deg"] < load_angle_deg - RELAX_ROOM_DEG
            if failed is not None and room:
                _relax(attempt, shaping, failed, failed_at, load_angle_deg)
            within = True
            break
        failed, failed_at = shaping, _worst_lengths(found, load_angle_deg)
        blame = culprits(plan.table, judges, found.moves, load_angle_deg, shaping, found.stops)
        shaping = _gentler(shaping, blame, load_angle_deg, ramp_floor)
    if not within:  # the bands did not converge: the whole table tightened alike too
        with contextlib.suppress(PlanError):
            tried.append(tighten_uniform(motor, make, load_angle_deg, judges=judges,
                                         stops=stops))
            made[0] += tried[-1].extras["plans"]
    return _counted(_kept(tried, bounded, lambda plan, shaping: _annotated(
        plan, judged(plan.table, judges, stops).worst(), shaping, len(judges), t0, stops),
        load_angle_deg), made[0])


def _kept(tried: list[Plan], bounded: dict[int, tuple[Plan, Shaping]],
          exact: Callable[[Plan, Shaping], Plan], aim_deg: float) -> Plan:
    """The plan `_best` keeps of `tried`, judged exactly: a plan judged by its samples
    alone (`bounded`: by its index, unannotated, and its shaping) is judged whole
    (`exact`) once it is the one kept; when none is within the aim, every one is."""
    while True:
        if not any(p.extras["worst_load_angle_deg"] <= aim_deg for p in tried):
            for k in list(bounded):  # the least past the aim, by every plan's whole verdict
                tried[k] = exact(*bounded.pop(k))
            return _best(tried, aim_deg)
        best = _best(tried, aim_deg)
        k = next(k for k, p in enumerate(tried) if p is best)
        if k not in bounded:
            return best
        tried[k] = exact(*bounded.pop(k))


def _relax(attempt: Callable[[Shaping, Screen], tuple[Plan, Judged] | None],
           shaping: Shaping, failed: Shaping, failed_at: Screen, aim_deg: float) -> None:
    """RELAX_STEPS bisections from `shaping` (within the aim) back towards `failed` (past
    it, worst at `failed_at`), each plan tried through `attempt` (which keeps it)."""
    for _ in range(RELAX_STEPS):
        mid = shaping.between(failed)
        again = attempt(mid, failed_at)
        if again is not None and again[0].extras["worst_load_angle_deg"] <= aim_deg:
            shaping = mid
        else:
            failed = mid
            if again is not None:
                failed_at = _worst_lengths(again[1], aim_deg)


def _counted(plan: Plan, plans: int) -> Plan:
    return replace(plan, extras={**plan.extras, "plans": plans})


def _best(plans: list[Plan], aim_deg: float) -> Plan:
    """The fastest plan within the aim; else the one with the smallest worst angle, when
    that is below the 90° peak."""
    within = [p for p in plans if p.extras["worst_load_angle_deg"] <= aim_deg]
    if within:
        return min(within, key=lambda p: float(p.duration_s or 0.0))
    best = min(plans, key=lambda p: p.extras["worst_load_angle_deg"])
    worst = best.extras["worst_load_angle_deg"]
    if worst >= PEAK_DEG:
        raise PlanError(f"no table keeps the load angle below {PEAK_DEG:g}° for every move "
                        f"length (best {worst:.1f}°): raise the motor's damping_ratio if the "
                        "drive damps more, or lower safety_factor and start_pps")
    return replace(best, info=best.info + f" (aim ≤ {aim_deg:g}° not reached)")


def _worst_lengths(found: Judged, aim_deg: float) -> Screen:
    """The SCREEN move lengths and the SCREEN decel stops furthest past the aim (the worst
    first)."""
    per_move = found.moves.deg.max(axis=0)
    over = np.flatnonzero(per_move > aim_deg)
    lengths = found.moves.lengths[over[np.argsort(per_move[over])[::-1]][:SCREEN]]
    st = found.stops
    if st is None or not st.deg.size:
        return Screen(lengths, [])
    per_stop = st.deg.max(axis=0)
    over = np.flatnonzero(per_stop > aim_deg)
    stops = []
    for e in over[np.argsort(per_stop[over])[::-1]][:SCREEN].tolist():
        stage, dwell = int(st.stage[e]), int(st.dwell[e])
        reading, p = readings_of(st.table, stage, dwell)[0]
        p = st.table.accel_pulses[stage] if p is None else p
        stops.append((ramp_pulse(st.table, stage, p), "c" if reading == "LOW" else reading))
    return Screen(lengths, stops)


def _screened_out(table: FreeCurveTable, judges: Sequence[Motor], screen: Screen,
                  limit_deg: float) -> bool:
    """Whether `table` is past `limit_deg` on a move or a stop of `screen` (a stop at a
    pulse past this table's ramp is left out)."""
    if len(screen.lengths) and float(angles(table, judges, pulses=screen.lengths.tolist())
                                     .deg.max()) > limit_deg:
        return True
    pairs = []
    for pulse, reading in screen.stops:
        where = locate(table, pulse)
        if where is not None:
            pairs.append((where[0], dwell_of(table, where[0], where[1], reading)))
    return bool(pairs) and stop_angles(table, judges, stops=pairs).worst_deg() > limit_deg


class Blame:
    """The speed bands (and the start) the traced executions' worst angles came from,
    each with the worst angle it drove."""

    def __init__(self) -> None:
        self.bands: dict[int, float] = {}
        self.start = 0.0

    def add(self, band: int, deg: float) -> None:
        self.bands[band] = max(self.bands.get(band, 0.0), deg)


def culprits(table: FreeCurveTable, judges: Sequence[Motor], found: Angles, aim_deg: float,
             shaping: Shaping, stops: StopAngles | None = None) -> Blame:
    """Trace the worst executions past the aim (at most CULPRITS of the moves and the
    decel stops `stops`, each on the motor and direction where it is worst) and blame the
    speed bands of the command's segments within WINDOW_PERIODS natural periods before
    the worst angle."""
    blame = Blame()
    pools = [(found.deg, found.owner, found.direction, "move")]
    if stops is not None and stops.deg.size:
        pools.append((stops.deg, stops.owner, stops.direction, "stop"))
    past = [(float(deg[:, e].max()), k, e) for k, (deg, _, _, _) in enumerate(pools)
            for e in np.flatnonzero(deg.max(axis=0) > aim_deg).tolist()]
    worst = _diverse(sorted(past, reverse=True), table, shaping, found, stops)
    lengths = [int(found.lengths[e]) for _, k, e in worst if pools[k][3] == "move"]
    moves = iter(simulate_moves(table, lengths) if lengths else [])
    rotor_list: dict[tuple[int, int], Rotor] = {}  # by (pool, row): a motor and a direction
    for deg, k, e in worst:
        rows, owner, direction, kind = pools[k]
        run = (next(moves) if kind == "move" else
               stop_execution(table, int(stops.stage[e]), int(stops.dwell[e])))  # type: ignore[union-attr]
        row = int(np.argmax(rows[:, e]))
        if (k, row) not in rotor_list:
            rotor_list[k, row] = rotor_of(judges[int(owner[row])],
                                          direction=int(direction[row]))
        _blame_run(blame, table, run, rotor_list[k, row], deg, shaping)
    return blame


def _diverse(past: list[tuple[float, int, int]], table: FreeCurveTable, shaping: Shaping,
             found: Angles, stops: StopAngles | None) -> list[tuple[float, int, int]]:
    """The CULPRITS worst of `past` (deg, pool, index: 0 a move, 1 a stop; every one past
    the aim), and beside them the worst of every other speed band where one of them
    reaches its top speed (a move's: the stage its ramp turns at; a stop's: where it
    comes), at most BAND_CULPRITS: blamed in one round, the bands that ring do not
    surface one by one."""
    hz = table.clock.hz
    slowest = len(table.rates) - 1       # stages are listed fastest first
    reach = np.cumsum(table.accel_pulses[::-1])  # pulses from rest to each stage's end

    def band(k: int, e: int) -> int:
        if k == 0:  # a move turns about halfway (a triangle) or cruises at the top
            stage = slowest - min(int(np.searchsorted(reach, found.lengths[e] / 2)), slowest)
        else:
            stage = int(stops.stage[e])  # type: ignore[union-attr]
        return shaping.band(hz / table.rates[stage])

    chosen = past[:CULPRITS]
    seen = {band(k, e) for _, k, e in chosen}
    for deg, k, e in past[CULPRITS:]:
        if len(chosen) >= CULPRITS + BAND_CULPRITS:
            break
        b = band(k, e)
        if b not in seen:
            seen.add(b)
            chosen.append((deg, k, e))
    return chosen


def _blame_run(blame: Blame, table: FreeCurveTable, run: Execution, rotor: Rotor, deg: float,
               shaping: Shaping) -> None:
    """Blame the bands of `run`'s segments within WINDOW_PERIODS natural periods before
    its worst angle (`deg`), and the start when the jump from rest, or the stop to rest
    from the slowest stage (a jump the start speed sets as well), is in that window: a
    motor that starts fast rings worst just after a short move's last pulse."""
    step = rotor.step_s()
    trace = follow(rotor, spans_of(run, rotor, step), step_s=step)
    t_worst = float(trace.t_s[int(np.argmax(np.abs(trace.lag)))])
    speed = float(run.speed_at(min(t_worst, run.duration_s * (1 - 1e-12))))
    period = rotor.natural_period_s(speed)
    since = t_worst - WINDOW_PERIODS * (period if math.isfinite(period) else 0.0)
    hz = table.clock.hz
    for seg in run.segments:
        if seg.start_tick / hz <= t_worst and seg.end_tick / hz >= since:
            blame.add(shaping.band(hz / seg.rate), deg)
    if since <= 0.0 or since <= run.duration_s <= t_worst:
        blame.start = max(blame.start, deg)  # the jump from or to rest is in the window


def _gentler(shaping: Shaping, blame: Blame, aim_deg: float, floor: float) -> Shaping:
    """`shaping` made gentler where `blame` points: each band and the start by `_factor`,
    no band below `floor` (a share of the motor; 0: none)."""
    return shaping.scaled({b: min(1.0, max(_factor(w, aim_deg), floor / shaping.scale[b]))
                           for b, w in blame.bands.items()},
                          _factor(blame.start, aim_deg) if blame.start else 1.0)


def _factor(worst_deg: float, aim_deg: float) -> float:
    """How much gentler a band that drove `worst_deg` is made: the ringing and the lag
    both grow about in proportion to the share of the motor used."""
    return float(np.clip(aim_deg / worst_deg, 0.6, 0.95))


def _annotated(plan: Plan, worst: float, shaping: Shaping, judges: int, t0: float,
               stops: bool) -> Plan:
    note = (f"; worst load angle {worst:.1f}° electrical over every move length"
            + (" and every decel stop" if stops else "")
            + (f" at {judges} tolerance corners" if judges > 1 else ""))
    if not shaping.plain:
        gentler = [f"{lo:.0f}–{hi:.0f} pps ×{s:.3g}" for lo, hi, s in
                   zip((0.0, *shaping.edges_pps), (*shaping.edges_pps, math.inf),
                       shaping.scale, strict=True) if s < 1.0]
        note += " (tightened where it rings: " + ", ".join(
            ([f"start ×{shaping.start_scale:.3g}"] if shaping.start_scale < 1 else [])
            + gentler).replace("–inf", "+") + ")"
    return replace(plan, info=plan.info + note, solve_s=time.perf_counter() - t0,
                   binds="load angle (tightened)" if not shaping.plain else plan.binds,
                   extras={**plan.extras, "worst_load_angle_deg": worst, "shaping": shaping})


def tighten_uniform(motor: Motor, make: Make, load_angle_deg: float, *,
                    judges: Sequence[Motor] | None = None, stops: bool = True) -> Plan:
    """The whole table tightened alike: the safety factor, the largest jump and the start
    speed scaled by 0.85 a round until the worst angle (every move and, with `stops`,
    every decel stop) is within `load_angle_deg`, then bisected back towards the last
    scale that failed (`extras["plans"]`: how many plans it made). While the descent
    judges a plan, the next scale's is made on a side thread (the same plan, remembered
    or not: a second core's worth of the round); one it did not need is dropped."""
    _check_aim(load_angle_deg)
    t0 = time.perf_counter()
    judges = list(judges or [motor])
    tried: list[Plan] = []
    ahead: dict[float, Future[Plan]] = {}  # the descent's next plan, made on the side

    def attempt(scale: float, descent: bool = True) -> tuple[float, Plan]:
        shaping = Shaping.uniform(scale)
        future = ahead.pop(scale, None)
        if descent:  # make the scale tried next if this one fails while this one is judged
            nxt = scale * TIGHTEN_STEP
            ahead[nxt] = pool("tighten-ahead", 1).submit(make, motor, Shaping.uniform(nxt))
        if future is not None and not future.cancel():
            plan = future.result()  # made ahead (raises the PlanError make raised)
        else:
            plan = make(motor, None if shaping.plain else shaping)
        worst = judged(plan.table, judges, stops).worst()
        plan = _annotated(plan, worst, shaping, len(judges), t0, stops)
        tried.append(plan)
        return worst, plan

    try:
        return _descend(attempt, load_angle_deg, tried)
    finally:
        for future in ahead.values():
            future.cancel()  # made ahead for a step the descent did not take


def _descend(attempt: Callable[..., tuple[float, Plan]], load_angle_deg: float,
             tried: list[Plan]) -> Plan:
    """`tighten_uniform`'s rounds: 0.85 a round until within the aim, then bisected back
    (`attempt(scale, descent)`: the worst angle and the plan at `scale`)."""
    scale, failed = 1.0, None
    for _ in range(TIGHTEN_ROUNDS):
        try:
            worst, plan = attempt(scale)
        except PlanError:
            if not tried:
                raise
            break  # too gentle for the move: nothing tighter fits either
        if worst <= load_angle_deg:
            for _ in range(TIGHTEN_BISECT if failed is not None else 0):
                mid = (scale + failed) / 2  # type: ignore[operator]
                w_mid, p_mid = attempt(mid, False)
                if w_mid <= load_angle_deg:
                    scale, plan = mid, p_mid
                else:
                    failed = mid
            return _counted(plan, len(tried))
        failed, scale = scale, scale * TIGHTEN_STEP
    return _counted(_best(tried, load_angle_deg), len(tried))


def _check_aim(load_angle_deg: float) -> None:
    if not 1.0 <= load_angle_deg <= PEAK_DEG:
        raise FieldRangeError("load angle target [°]", load_angle_deg, 1, PEAK_DEG)
