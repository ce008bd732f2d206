"""A free curve planned for a move: both LE variants over the DP, the faster kept; the
baseline method; the table written from the staircase."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from dataclasses import replace
from types import MappingProxyType

import numpy as np

from ...errors import FieldRangeError, PlanError
from ...motor import Motor
from ...remembered import Remembered
from ...threads import pool
from ..clock import MAX_OUTPUT_PPS, Clock
from ..table import FreeCurveTable
from .problem import Plan, Shaping, check_plan_args, choose_clock, make_problem, reference_pulses
from .refine import Staircase, jerk_counts, own_decel_counts, refine_rates, switch_safe_decel
from .search import GRID_TARGET, graph, grid_rates, search
from .tightening import tighten

BASELINE_POINTS = 600


def plan_staircase(motor: Motor, clock: Clock, max_stages: int, budget: int, separate: bool,
                   *, grid: str = "adaptive", refine: bool = True, exhaustive_tops: bool = False,
                   shaping: Shaping | None = None) -> Staircase:
    """The fastest staircase of one LE variant (before LE=1's switch-safe decel counts)."""
    pb = make_problem(motor, clock, separate, shaping)
    if grid == "adaptive":
        rates = grid_rates(pb, GRID_TARGET)
    elif grid == "all":
        rates = grid_rates(pb, 1 << 30)
    else:  # the baseline's geometric grid between the start rate and the top rate
        rates = np.unique(np.round(np.geomspace(pb.r_start, pb.r_fast, BASELINE_POINTS))
                          .astype(np.int64))[::-1].copy()
    gr = graph(pb, rates)
    ev = search(pb, gr, max_stages, budget, exhaustive_tops=exhaustive_tops,
                plain=grid == "geometric")
    if refine:
        ev = refine_rates(pb, ev, budget)
    jerked = jerk_counts(pb, ev, budget)
    if jerked is None:
        raise PlanError(f"the jerk limit max_jerk_pps3 = {motor.max_jerk_pps3:g} raises the "
                        f"table's pulses above the {budget}-pulse move; give more pulses")
    return jerked


def table_of(clock: Clock, ev: Staircase, separate: bool) -> FreeCurveTable:
    rates = [int(x) for x in ev.rates[::-1]]
    acc = [int(x) for x in ev.n[::-1]]
    dec = [int(x) for x in ev.d[::-1]]
    return FreeCurveTable(clock, tuple(rates), tuple(acc), tuple(dec) if separate else None)


PLANS_KEPT = 64   # plans remembered (a table and a few lines each)
_plans: Remembered[Plan] = Remembered(PLANS_KEPT)


# The tables `plan` compares (auto mode: all three; LE=1 forced: the first two).
VARIANTS = ("LE=1", "LE=1 on LE=0's rates", "LE=0")


def plan(motor: Motor, clock: Clock | None, max_stages: int, pulses: int | None,
         separate_decel: bool | None, *, grid: str = "adaptive", refine: bool = True,
         label: str = "planner", exhaustive_tops: bool = False,
         shaping: Shaping | None = None, variant: str | None = None,
         without: str | None = None) -> Plan:
    """The fastest table that passes the criterion for every move length (with `shaping`:
    within its bands' share of the motor); `variant` (one of VARIANTS) plans only that
    one, `without` every other one, and `extras["variant"]` says which won. The last
    PLANS_KEPT plans are remembered by their arguments (the motor by its values): a duty
    cycle plans its candidates by the criterion, then tightens the best, whose first
    attempt is that same plan."""
    t0 = time.perf_counter()
    check_plan_args(max_stages, pulses)
    clock = clock or choose_clock(motor)
    kinds = [k for k in VARIANTS if separate_decel is None or (k == "LE=0") != separate_decel]
    for given in (variant, without):
        if given is not None and given not in kinds:
            raise ValueError(f"variant {given!r} is not one of {kinds}")
    if variant is not None:
        kinds = [variant]
    kinds = [k for k in kinds if k != without]
    key = (motor.values_key(), clock, max_stages, pulses, tuple(kinds), grid, refine, label,
           exhaustive_tops, shaping or None)
    result, known = _plans.get(key, lambda: _plan(
        motor, clock, max_stages, pulses, kinds, grid=grid, refine=refine, label=label,
        exhaustive_tops=exhaustive_tops, shaping=shaping, t0=t0))
    return replace(result, solve_s=time.perf_counter() - t0) if known else result


def forget_plans() -> None:
    """Forget the remembered plans (a benchmark times a plan's first run)."""
    _plans.clear()


def _plan(motor: Motor, clock: Clock, max_stages: int, pulses: int | None, kinds: list[str],
          *, grid: str, refine: bool, label: str, exhaustive_tops: bool,
          shaping: Shaping | None, t0: float) -> Plan:
    budget = reference_pulses(motor) if pulses is None else int(pulses)
    # LE=1's decel counts (from a_dec ≥ a_acc) are smaller than LE=0's, but the chip runs
    # short moves as triangles that keep the accel:decel ratio, and with uneven sides the
    # decel can start on a slower stage than the accel reached: a jump the table never
    # shows. `switch_safe_decel` raises the top decel count (free on the planned move:
    # the top stage runs at cruise speed) until no triangle does that. The symmetric LE=0
    # table is always all-length safe. LE=1 is planned twice: on its own DP's rates, and
    # on LE=0's with the decel side's own counts (the DP for uneven sides picks rates
    # whose decel counts the switch rule then raises; LE=0's rates often fare better, and
    # that variant is never slower than LE=0). The fastest is kept, written as LE=0 when
    # the decel counts come out equal anyway.
    variants: list[tuple[Staircase, bool, str]] = []
    kw = dict(grid=grid, refine=refine, exhaustive_tops=exhaustive_tops, shaping=shaping)
    pb = make_problem(motor, clock, True, shaping)

    def switch_safe(ev: Staircase | None, kind: str) -> None:
        safe = None if ev is None else switch_safe_decel(pb, ev, budget)
        if safe is not None:
            variants.append((safe, not np.array_equal(safe.n, safe.d), kind))

    def staircase(separate: bool) -> Staircase | PlanError:
        try:
            return plan_staircase(motor, clock, max_stages, budget, separate, **kw)  # type: ignore[arg-type]
        except PlanError as e:
            return e  # a variant with no table leaves the others

    sides = [sep for sep, wanted in ((True, "LE=1" in kinds), (False, "LE=0" in kinds or
                                     "LE=1 on LE=0's rates" in kinds)) if wanted]
    # the two DPs are independent, and their kernels release the GIL: side by side
    found = dict(zip(sides, pool("planner", 2).map(staircase, sides) if len(sides) > 1
                     else map(staircase, sides), strict=True))
    refused = [e for e in found.values() if isinstance(e, PlanError)]
    ev1, ev0 = (None if isinstance(e, PlanError) else e for e in
                (found.get(True), found.get(False)))
    if "LE=1" in kinds:
        switch_safe(ev1, "LE=1")
    if ev0 is not None and "LE=1 on LE=0's rates" in kinds:
        switch_safe(own_decel_counts(pb, ev0, budget), "LE=1 on LE=0's rates")
    if ev0 is not None and "LE=0" in kinds:
        variants.append((ev0, False, "LE=0"))
    if not variants:
        if refused:
            raise refused[-1]  # a DP had no table: its reason says why
        raise PlanError(f"no LE=1 table fits {budget} pulses and keeps every triangle's "
                        "accel→decel switch safe; give more pulses or allow LE=0 "
                        "(--no-separate-decel)")
    ev, sep, kind = min(variants, key=lambda v: v[0].time_s)
    table = table_of(clock, ev, sep)
    objective = (f"move of {pulses} pulses" if pulses is not None
                 else f"reference move of {budget} pulses (no move length given)")
    info = (f"{label}: {len(ev.rates)} stages, LE={int(sep)}, top {clock.hz / ev.rates[-1]:.6g} pps"
            f", accel {int(ev.n.sum())} + decel {int(ev.d.sum())} pulses, {objective} "
            f"{ev.time_s * 1e3:.6g} ms")
    if len(ev.rates) >= max_stages:
        binds = "stage budget"
    elif ev.total >= budget:
        binds = "move length"  # the ramps use every pulse: a faster top does not fit
    elif clock.hz / ev.rates[-1] >= min(motor.top_pps, MAX_OUTPUT_PPS) * (1 - 1e-9):
        binds = "top speed"
    else:
        binds = "stall criterion (capability and jump limit)"
    return Plan(table, ev.time_s, binds, info, pulses, clock, time.perf_counter() - t0,
                extras=MappingProxyType({"variant": kind}))  # read-only: plans are shared


def plan_free_curve(motor: Motor, *, clock: Clock | None = None, max_stages: int = 127,
                    pulses: int | None = None, separate_decel: bool | None = None,
                    load_angle_deg: float | None = None,
                    start_shaping: Shaping | None = None, decel_stops: bool = True) -> Plan:
    """The stall-safe free curve that minimises the move time of `pulses` (None: the
    reference move of `reference_pulses(motor)`); separate_decel None picks LE=1 only
    when it is faster. The table passes the criterion for every move length the chip
    can run with it. With `load_angle_deg` (e.g. 75) the plan is also judged by the
    load-angle model on every execution and tightened where the rotor rings until its
    worst angle is within that (`tightening.tighten`): every move and (`decel_stops`, the
    default) a decel stop (81) at every pulse of the ramp under every reading the manual
    leaves open (profiles.ppmc312.stops). A motor with `tolerances` gets one
    table safe over its whole box: the criterion on the box's worst-case capability
    (exact over the box, profiles.motor.tolerance), the load angle judged at every
    corner."""
    chosen: list[str] = []  # the variant the plain criterion picked

    def make(m: Motor, shaping: Shaping | None = None) -> Plan:
        if shaping is not None and chosen:
            # a gentler plan of the same motor and move keeps the variant the plain one
            # won with (planning them all again changes nothing but the time); when that
            # one has no table (a gentler LE=1 often has none), the fastest of the others
            try:
                return plan(m, clock, max_stages, pulses, separate_decel, shaping=shaping,
                            variant=chosen[0])
            except PlanError:
                return plan(m, clock, max_stages, pulses, separate_decel, shaping=shaping,
                            without=chosen[0])
        result = plan(m, clock, max_stages, pulses, separate_decel, shaping=shaping)
        if shaping is None:
            chosen[:] = [result.extras["variant"]]
        return result

    if motor.tolerances:
        from ...motor.tolerance import corners, worst_case_motor

        planned, judges = worst_case_motor(motor), [c.motor for c in corners(motor)]
    else:
        planned, judges = motor, [motor]
    if load_angle_deg is None:
        return make(planned)
    if start_shaping is not None:
        # the variant the plain criterion picks, for the gentler plans to keep (a duty
        # cycle, which starts tightening from a shaping, planned it already: remembered)
        with contextlib.suppress(PlanError):
            make(planned)
    refused: PlanError | None = None
    try:
        best: Plan | None = tighten(planned, make, load_angle_deg, judges=judges,
                                    start=start_shaping, stops=decel_stops)
    except PlanError as e:  # nothing below the 90° peak at the motor's top speed
        best, refused = None, e
    if best is not None and best.extras["worst_load_angle_deg"] <= load_angle_deg:
        return best
    return lower_top(planned, make, load_angle_deg, judges, decel_stops, best, refused)


TOP_STEP = 0.8     # the top speed × this a round, when nothing else reaches the aim,
TOP_ROUNDS = 6     # down to 0.8⁶ = 26 % of the motor's
RAMP_FLOOR = 0.4   # meanwhile no band's share below this (as init_planner.RAMP_FLOOR)


def lower_top(motor: Motor, make: Callable[[Motor, Shaping | None], Plan],
              load_angle_deg: float, judges: list[Motor], stops: bool, best: Plan | None,
              refused: PlanError | None) -> Plan:
    """The last lever (docs/manual-notes.md, "The free curve's last lever: the top
    speed"): when a lower start and a gentler ramp leave every table past the aim (a
    large load inertia: its long natural period rings over the whole ramp, and a ramp
    gentler than the friction leaves no table), the table is tightened again with no
    band's share below RAMP_FLOOR (the start speed alone going on down), first at the
    motor's top speed, then at a lower one, TOP_STEP a round; the first within the aim
    is kept (`extras["top_lowered_pps"]`: (from, to) when lowered;
    `extras["untightened_s"]`: the plain table's move time, for the price). None within:
    the closest below the 90° peak with `extras["fix"]`, else a PlanError naming what
    would help."""
    plain_s = make(motor, None).duration_s  # remembered: tighten planned it first
    plans = 0 if best is None else int(best.extras["plans"])
    for k in range(TOP_ROUNDS + 1):
        top = motor.top_pps * TOP_STEP ** k
        try:
            plan = tighten(replace(motor, max_pps=top) if k else motor, make, load_angle_deg,
                           judges=judges, stops=stops, ramp_floor=RAMP_FLOOR)
        except (PlanError, FieldRangeError):  # no table this slow, or none below the peak
            continue
        plans += int(plan.extras["plans"])
        lowered = {"top_lowered_pps": (motor.top_pps, top)} if k else {}
        plan = replace(plan, info=plan.info + (f" (top speed lowered to {top:.6g} pps)"
                                               if k else ""),
                       extras={**plan.extras, **lowered, "untightened_s": plain_s,
                               "plans": plans})
        if plan.extras["worst_load_angle_deg"] <= load_angle_deg:
            return plan
        if best is None or (plan.extras["worst_load_angle_deg"]
                            < best.extras["worst_load_angle_deg"]):
            best = plan
    fix = ("a lower load inertia or more drive current (the rotor rings past the aim even "
           f"with the top speed lowered to {motor.top_pps * TOP_STEP ** TOP_ROUNDS:.0f} pps "
           "and the start and the ramp tightened), or a higher damping_ratio if the drive "
           "damps more")
    if best is None:
        raise PlanError(f"{refused}; what would help: {fix}") if refused is not None \
            else PlanError(f"no table for this move at any top speed tried; what would "
                           f"help: {fix}")
    return replace(best, extras={**best.extras, "fix": fix, "plans": plans})


def plan_baseline(motor: Motor, *, clock: Clock | None = None, max_stages: int = 127,
                  pulses: int | None = None) -> Plan:
    """The plain method: shortest path over a 600-point geometric rate grid between the start
    rate and the top rate with minimal pulse counts (LE=0), no refinement."""
    return plan(motor, clock, max_stages, pulses, False, grid="geometric", refine=False,
                label="baseline")
