"""Several PPMC-312 axes, one move: synchronised free-curve tables (issue 11).

Each axis is its own chip with its own table; the move commands carry the
trigger bits so every chip starts on one event input (`move_command`).

time mode — every axis finishes together. Each axis gets its fastest table
(`plan_free_curve`); the slowest keeps it. Every other axis is slowed as little
as needed, in two steps:
1. top-speed cap: the fastest table for the motor capped at speed v
   (`Motor.max_pps`; below the start speed the start speed is lowered with it),
   v found by bisection as the smallest cap whose move is not slower than the
   target (planning stays optimal for the lower top, so the axis runs at lower
   speeds rather than dwelling at low ones);
2. padding: pulses move from the cruise into the stages next to the top (each
   adds `rate_k − rate_top` clock ticks), alternately on the accel and decel
   side, until the duration is within one tick step of the target.
More pulses in a stage only lowers the acceleration it asks of the motor; the
jump, start and top speeds are unchanged. The high-rate override is not used:
it would change the chip's first-pulse latency (900 µs against 100 µs, manual
§8-3) and so the finish on the trigger (docs/manual-notes.md).

line mode — positions stay proportional (a straight joint path). The axis with
the most pulses (L) leads. Its table is planned for an envelope motor: in L's
pulses, the weakest of every axis's capability scaled by its pulse ratio c_i =
N_i / N_L (a_i(c_i·v) / c_i, start, jump, top and jerk likewise), shrunk by a
margin that absorbs rate rounding. The other axes follow on common stage
boundaries (`joint_tables`): every stage lasts the longest any axis needs (its
least counts at its own rates), and at each boundary every follower picks the
floor or ceiling of its ideal rate so that its position there is closest to the
line, carrying the error forward (sigma-delta: rounding never accumulates); the
decel side is matched backwards from the end with the same (shared) rates. A
follower of few pulses may span several of L's short stages with one of its own
(grouped candidates). Cruise speeds are one integer rate per chip, so L's top
rate is searched (up to `top_slack` slower) for the top-rate pair whose ratio
matches the pulse ratio best; every table is then padded to end with the
slowest (split between the sides, so a cruise drift is centred on the line).
LE=1 and LE=0 sets are built; each candidate is scored by the exact deviation of
the executed joint path (`line_deviation`): the least wins, the fastest among
those within 0.25 pulse of it.

Stall safety: every table made here is vetted by `accept(table, motor)`, by
default `criterion.all_length_safe` (the criterion over every move length the
chip can run with the table, the one `verify.criterion.check_stall` reports).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any, Literal

import numpy as np

from ..errors import PlanError, SyncError, echo
from ..motor import Motor
from ..pulses import Piece, PulseTrain
from ..pulses import line_deviation as pulse_line_deviation
from .clock import INTERNAL_HZ, Clock
from .criterion import all_length_safe
from .execution import Execution, simulate_move
from .limits import MIN_STAGE_TICKS, RATE_MAX, RATE_MIN, SIDE_TOTAL_MAX, STAGE_PULSES_MAX
from .planner import make_problem, plan_free_curve
from .table import FreeCurveTable
from .upload import encode_move

Mode = Literal["time", "line"]
Accept = Callable[[FreeCurveTable, Motor], bool]

SPREAD_REL = 1e-3          # finish spread allowed: 0.1 % of the move …
SPREAD_ABS_S = 200e-6      # … or 200 µs, whichever is larger
CAP_BISECTIONS = 30        # top-speed cap search: at most this many plans …
CAP_REL_TOL = 1e-3         # … until the cap is known to 0.1 % (padding does the rest)
START_FRACTION = 0.9       # a cap below the start speed lowers the start speed to 0.9 × cap
TOP_SLACK = 0.03           # line mode: L's top may be up to 3 % slower to match the ratio
LINE_MARGINS = (0.97, 0.9, 0.75, 0.5)  # envelope shrink tried in turn until accepted
LINE_STAGES = (24, 6, 2)   # fallbacks: fewer leader stages when short axes cannot follow
ENVELOPE_GRID = 49         # uniform speeds sampled (plus every curve point) for the envelope
LINE_TOPS = 24             # top rates tried at most (the fastest ones)
NEAR_BEST_PULSES = 0.25    # line candidates this close to the best deviation: take the fastest
TRIGGER_EVENT1 = 0b01      # move command TRG 01: start when event input 1 goes low


def spread_tolerance_s(duration_s: float) -> float:
    """The finish spread allowed for a move of `duration_s`."""
    return max(SPREAD_REL * duration_s, SPREAD_ABS_S)


@dataclass(frozen=True)
class AxisMove:
    """One axis of a synchronised move: its table and what the chip runs."""

    name: str
    pulses: int              # signed (negative: CCW)
    motor: Motor
    table: FreeCurveTable
    execution: Execution
    fastest_s: float         # its own fastest table's duration (unsynchronised)
    how: str                 # what was done to it, one line

    @property
    def duration_s(self) -> float:
        return self.execution.duration_s


class SyncTimes:
    """The times of a plan whose axes each have `duration_s` and `fastest_s` (PPMC-312
    tables here, A-Link settings in profiles.alink.sync)."""

    axes: tuple[Any, ...]

    @property
    def duration_s(self) -> float:
        return max(a.duration_s for a in self.axes)

    @property
    def spread_s(self) -> float:
        d = [a.duration_s for a in self.axes]
        return max(d) - min(d)

    @property
    def unsynchronised_s(self) -> float:
        """The slowest axis's fastest move: no synchronised move can be shorter."""
        return max(a.fastest_s for a in self.axes)


@dataclass(frozen=True)
class SyncPlan(SyncTimes):
    mode: Mode
    axes: tuple[AxisMove, ...]
    info: str


def move_command(axis: AxisMove, trigger: int = TRIGGER_EVENT1) -> bytes:
    """The accel/decel move (82) of one axis, held in the command buffer until the trigger
    (OV = 1, TRG 01: event input 1 low), so every chip wired to that input starts at once."""
    return encode_move(abs(axis.pulses), ccw=axis.pulses < 0, override=True, trigger=trigger)


# --------------------------------------------------------------------------- padding
def pad_to_ticks(table: FreeCurveTable, pulses: int, target_ticks: int, *,
                 accel_first: bool = True, symmetric: bool = False) -> FreeCurveTable:
    """`table` with pulses moved from the cruise into the stages next to the top until the
    move of `pulses` lasts as close to `target_ticks` clock ticks as possible from below.

    Stage k (fastest first) gains `rates[k] − rates[0]` ticks a pulse; the bulk goes to the
    stage nearest the top that can take it, faster stages refine the rest; each amount is
    split between the accel and decel side (accel first: ceil half). `symmetric`: both
    sides always gain alike (an LE=0 table stays LE=0; the step is then two pulses). The
    move stays a trapezoid (accel + decel ≤ pulses) and every count and side total stays
    in the chip's range. Counts only grow: no stage asks more of the motor.
    """
    acc = list(table.accel_pulses)
    dec = list(table.decel)
    rates = table.rates
    cruise = pulses - sum(acc) - sum(dec)
    gap = target_ticks - simulate_move(table, pulses).ticks
    if cruise < 0:
        raise SyncError(f"the table's accel + decel pulses exceed the {pulses}-pulse move")
    sides = [acc, dec] if accel_first else [dec, acc]

    def room(side: list[int], k: int) -> int:
        return max(min(STAGE_PULSES_MAX - side[k], SIDE_TOTAL_MAX - sum(side)), 0) \
            if k < len(side) else 0

    # The bulk goes to the stage nearest the top whose extra ticks a pulse, times the
    # cruise pulses there are, can cover the gap; faster stages then refine the rest
    # (finer steps), slower ones only take what is still left.
    d_all = [r - rates[0] for r in rates]
    bulk = next((k for k in range(1, len(rates)) if d_all[k] * cruise >= gap), len(rates) - 1)
    order = [*range(bulk, 0, -1), *range(bulk + 1, len(rates))]
    for k in order:
        d = d_all[k]
        if symmetric:
            if k >= len(acc) or k >= len(dec):
                continue
            q = max(min(gap // (2 * d), cruise // 2, room(acc, k), room(dec, k)), 0)
            acc[k] += q
            dec[k] += q
            cruise -= 2 * q
            gap -= 2 * q * d
            continue
        if gap < d or cruise <= 0:
            continue
        # half (rounded up) to the first side, the rest to the other, then any rest the
        # other side had no room for back to the first
        for side, cap in ((sides[0], (min(gap // d, cruise) + 1) // 2), (sides[1], None),
                          (sides[0], None)):
            q = max(min(gap // d, cruise, room(side, k),
                        cap if cap is not None else cruise), 0)
            side[k] += q
            cruise -= q
            gap -= q * d
    return _table(table.clock, rates, acc, dec)


def _table(clock: Clock, rates: Sequence[int], acc: Sequence[int],
           dec: Sequence[int]) -> FreeCurveTable:
    """LE=0 when both sides count alike, else LE=1."""
    same = list(acc) == list(dec)
    return FreeCurveTable(clock, tuple(int(r) for r in rates), tuple(int(a) for a in acc),
                          None if same else tuple(int(d) for d in dec))


# --------------------------------------------------------------------------- time mode
def _capped(motor: Motor, v_pps: float) -> Motor:
    """The motor limited to top speed v (start speed lowered to START_FRACTION·v if needed,
    the jump limit kept): any table safe for it is safe for `motor`."""
    start = min(motor.start_pps, START_FRACTION * v_pps)
    return replace(motor, max_pps=v_pps, start_pps=start, max_jump_pps=motor.jump_pps)


def _fastest(motor: Motor, pulses: int) -> tuple[FreeCurveTable, Execution]:
    table = plan_free_curve(motor, pulses=pulses).table
    return table, simulate_move(table, pulses)


def slow_to(motor: Motor, pulses: int, target_s: float, *,
            accept: Accept | None = all_length_safe) -> tuple[FreeCurveTable, str]:
    """The table whose move of `pulses` lasts `target_s` (to a tick step): capped top speed,
    then padding (see the module docstring)."""
    fast, exe = _fastest(motor, pulses)
    if exe.duration_s >= target_s:
        return fast, "fastest table"
    hi = fast.clock.hz / fast.rates[0]           # the uncapped table's top: fast enough
    lo = max(pulses / target_s / 2, 1e-3)        # cruising at it alone takes 2 × target
    best: tuple[FreeCurveTable, float] = (fast, hi)

    def attempt(v: float) -> FreeCurveTable | None:
        try:
            table = plan_free_curve(_capped(motor, v), pulses=pulses).table
        except PlanError:
            return None
        if accept is not None and not accept(table, motor):
            return None
        return table

    for _ in range(CAP_BISECTIONS):
        if hi / lo < 1 + CAP_REL_TOL:
            break
        v = math.sqrt(lo * hi)
        table = attempt(v)
        if table is not None and simulate_move(table, pulses).duration_s <= target_s:
            hi, best = v, (table, v)
        else:
            lo = v
    table, v = best
    target_ticks = math.floor(target_s * table.clock.hz + 1e-6)
    before = padded = table
    # the closest padding the criterion accepts (LE=1 padding can make a short move's
    # triangle switch too steep; symmetric padding keeps the sides alike)
    options = sorted((pad_to_ticks(table, pulses, target_ticks, symmetric=sym)
                      for sym in (False, True)),
                     key=lambda t: target_ticks - simulate_move(t, pulses).ticks)
    padded = next((t for t in options if accept is None or accept(t, motor)), before)
    added = padded.accel_total + padded.decel_total - (before.accel_total + before.decel_total)
    how = (f"top capped at {padded.clock.hz / padded.rates[0]:.6g} pps "
           f"(fastest {fast.clock.hz / fast.rates[0]:.6g} pps), {added} pulses padded")
    return padded, how


def plan_time_sync(axes: Sequence[tuple[str, Motor, int]], *,
                   accept: Accept | None = all_length_safe) -> SyncPlan:
    """Every axis finishes with the slowest one (see the module docstring).

    `axes`: (name, motor, signed pulses). `accept(table, motor)` vets a slowed table;
    None accepts every table the planner makes.
    """
    fastest = []
    for name, motor, pulses in axes:
        n = _distance(name, pulses)
        table, exe = _fastest(motor, n)
        fastest.append((table, exe))
    target = max(exe.duration_s for _, exe in fastest)
    out = []
    for (name, motor, pulses), (table, exe) in zip(axes, fastest, strict=True):
        n = abs(pulses)
        how = "slowest axis: fastest table"
        if exe.duration_s < target:
            table, how = slow_to(motor, n, target, accept=accept)
        out.append(AxisMove(name, pulses, motor, table, simulate_move(table, n),
                            exe.duration_s, how))
    plan = SyncPlan("time", tuple(out), f"time: every axis ends at {target * 1e3:.6g} ms")
    return plan


def _distance(name: str, pulses: int) -> int:
    n = abs(int(pulses))
    if n < 8:
        raise SyncError(f"axis {name}: {pulses} pulses; a free-curve move needs at least 8 "
                        "(2 stages × 2 pulses × 2 sides)")
    return n


# --------------------------------------------------------------------------- line mode
def envelope_motor(motors: Sequence[Motor], scales: Sequence[float], *,
                   margin: float = 1.0) -> Motor:
    """A motor in the leading axis's pulses that every axis i can follow at c_i × its speed:
    capability min_i a_i(c_i·v)/c_i (times `margin`), start, jump, top, jerk likewise.

    Between the sample speeds (every curve point of every axis, plus a uniform grid) the
    true minimum is concave on each piece, so the linear interpolation lies below it: safe.
    """
    c = np.asarray(scales, dtype=float)
    top = min(m.top_pps / ci for m, ci in zip(motors, c, strict=True))
    pts = [np.linspace(0.0, top, ENVELOPE_GRID)]
    pts += [m.curve_speed_pps / ci for m, ci in zip(motors, c, strict=True)]
    v = np.unique(np.concatenate(pts))
    v = v[v <= top]
    a_acc = np.min([m.a_acc_pps2(ci * v) / ci for m, ci in zip(motors, c, strict=True)], axis=0)
    a_dec = np.min([m.a_dec_pps2(ci * v) / ci for m, ci in zip(motors, c, strict=True)], axis=0)
    a_acc, a_dec = margin * a_acc, margin * a_dec
    dead = np.flatnonzero(a_acc <= 0)
    if len(dead):
        if dead[0] == 0:
            raise SyncError("the axes' motors cannot accelerate together from rest")
        v, a_acc, a_dec = v[: dead[0] + 1], a_acc[: dead[0] + 1], a_dec[: dead[0] + 1]
        top = float(v[-1])
    friction = max(0.0, float(np.min(a_dec - a_acc)) / 2)
    torque = np.maximum(a_acc + friction, 0.0)
    lead = motors[int(np.argmax(c))]
    # torque units chosen so the largest is 10 (Motor's fields have sane ranges):
    # acceleration = torque × k, k = steps_per_rev / (2π·inertia)
    k = max(float(np.max(torque)), 1e-9) / 10
    jerks = [m.max_jerk_pps3 / ci for m, ci in zip(motors, c, strict=True)
             if m.max_jerk_pps3 is not None]
    return Motor(steps_per_rev=lead.steps_per_rev, curve_speed_pps=v, curve_torque_nm=torque / k,
                 inertia_kgm2=lead.steps_per_rev / (2 * math.pi * k), safety_factor=1.0,
                 start_pps=min(m.start_pps / ci for m, ci in zip(motors, c, strict=True)),
                 friction_torque_nm=friction / k,
                 max_jump_pps=min(m.jump_pps / ci for m, ci in zip(motors, c, strict=True)),
                 max_pps=top, max_jerk_pps3=min(jerks) if jerks else None,
                 name="envelope of " + ", ".join(m.name or "motor" for m in motors))


def _clock_for(slowest_pps: float) -> Clock:
    """The fastest internal clock whose rate for the slowest speed fits 16 bits."""
    for name, hz in INTERNAL_HZ.items():
        if math.ceil(hz / slowest_pps) <= RATE_MAX:
            return Clock.internal(name)
    raise SyncError(f"a following axis would run at {slowest_pps:.4g} pps, slower than any "
                    "internal clock allows")


def cap_top(table: FreeCurveTable, rate: int) -> FreeCurveTable:
    """`table` with its top at `rate` (≥ the current top rate): faster stages dropped, a
    minimal top stage added if `rate` is not a stage rate. Every step is at most the old one,
    every count unchanged: the capability asked never grows."""
    if rate <= table.rates[0]:
        return table
    keep = [k for k, r in enumerate(table.rates) if r > rate]
    top_n = max(2, math.ceil(MIN_STAGE_TICKS / rate))
    rates = [rate] + [table.rates[k] for k in keep]
    acc = [top_n] + [table.accel_pulses[k] for k in keep if k < len(table.accel_pulses)]
    dec = [top_n] + [table.decel[k] for k in keep if k < len(table.decel)]
    if rate in table.rates:
        k = table.rates.index(rate)
        acc[0] = table.accel_pulses[k] if k < len(table.accel_pulses) else top_n
        dec[0] = table.decel[k] if k < len(table.decel) else top_n
    return _table(table.clock, rates, acc, dec)


def _least_counts(motor: Motor, clock: Clock) -> Callable[[int, int], tuple[int, int]] | None:
    """(accel, decel) least stage counts the motor needs to step from rate r_slow up to
    r_fast (r_fast 0: the top stage), with the chip's 2-pulse and 256-tick minima: the
    planner's own count rule."""
    try:
        counts = make_problem(motor, clock, True).counts
    except PlanError:
        return None

    memo: dict[tuple[int, int], tuple[int, int]] = {}

    def least(r_slow: int, r_fast: int) -> tuple[int, int]:
        key = (r_slow, r_fast)
        if key not in memo:   # every candidate top asks the same pairs again
            base = max(2, math.ceil(MIN_STAGE_TICKS / r_slow))
            if r_fast <= 0:
                memo[key] = (base, base)
            else:
                n, d, _ = counts(np.array([r_slow]), np.array([r_fast]))
                big = STAGE_PULSES_MAX + 1
                memo[key] = (int(min(max(n[0], base), big)), int(min(max(d[0], base), big)))
        return memo[key]
    return least


def _groups(lead: FreeCurveTable, scale: float, hz: float, jump_pps: float,
            grouped: bool) -> list[list[int]]:
    """The leader's stages (fastest-first indices) each stage of a follower spans, slowest
    first. Ungrouped: one each. Grouped: a follower of few pulses stays in a stage through
    the leader's next ones until that stage would last its chip's least (2 pulses, 256
    ticks) — many short stages would each be stretched to it, slowing the whole move —
    or its speeds would span a third of its jump limit. The top stage is always its own."""
    n_l = len(lead.rates)
    if not grouped:
        return [[f] for f in range(n_l - 1, -1, -1)]
    hz_l = lead.clock.hz
    out: list[list[int]] = []
    cur: list[int] = []
    span = 0.0
    for f in range(n_l - 1, 0, -1):
        if cur and scale * (hz_l / lead.rates[f] - hz_l / lead.rates[cur[0]]) > jump_pps / 3:
            out.append(cur)
            cur, span = [], 0.0
        cur.append(f)
        span += lead.accel_pulses[f] * lead.rates[f] / hz_l
        rho = lead.rates[f] * hz / (hz_l * scale)
        if span >= max(2, math.ceil(MIN_STAGE_TICKS / rho)) * rho / hz:
            out.append(cur)
            cur, span = [], 0.0
    if cur:
        out.append(cur)
    out.append([0])
    return out


def joint_tables(lead: FreeCurveTable, dist: Sequence[int], lead_i: int,
                 motors: Sequence[Motor], *, common: bool = False, grouped: bool = False,
                 memo: dict[tuple[int, str], Callable[[int, int], tuple[int, int]] | None]
                 | None = None) -> list[FreeCurveTable] | None:
    """Tables for every axis that follow `lead`'s speed profile scaled by N_i / N_lead, on
    common stage boundaries (see the module docstring). None if some axis has no legal one.

    Each stage lasts the longest any axis needs (its least counts at its own rates); at each
    boundary every axis picks the floor or ceiling of its ideal rate whichever leaves its
    position closest to the line (errors carried, not accumulated); the decel side is
    matched backwards from the end with the same rates. The top rate of each axis is the
    one whose cruise lasts closest to the leader's. `common`: both sides count alike (LE=0
    tables; each stage lasts the longer of its accel and decel durations). `grouped`: a
    follower may span several of the leader's stages with one of its own (`_groups`).
    `memo` keeps each axis's least-count rule between calls (by axis and clock)."""
    n_l = len(lead.rates)
    if len(lead.accel_pulses) != n_l or len(lead.decel) != n_l:
        return None
    hz_l = lead.clock.hz
    m = len(dist)
    scale = [d / dist[lead_i] for d in dist]
    clocks = [lead.clock if i == lead_i else _clock_for(hz_l / lead.rates[-1] * scale[i])
              for i in range(m)]
    memo = {} if memo is None else memo
    for i, (mo, c) in enumerate(zip(motors, clocks, strict=True)):
        if (i, c.name) not in memo:
            memo[(i, c.name)] = _least_counts(mo, c)
    leasts = [memo[(i, c.name)] for i, c in enumerate(clocks)]
    if any(x is None for x in leasts):
        return None
    v_lead = [hz_l / r for r in lead.rates]          # fastest first
    groups = [_groups(lead, scale[i], clocks[i].hz, motors[i].jump_pps,
                      grouped and i != lead_i) for i in range(m)]

    def ideal(i: int, g: list[int], t: Sequence[float]) -> float:
        """The rate that covers the line's distance over the group's time (one stage: the
        leader's rate scaled, exactly — the leader's own rates stay integers)."""
        if len(g) == 1:
            return lead.rates[g[0]] * clocks[i].hz / (hz_l * scale[i])
        time = sum(t[f] for f in g)
        dist_g = sum(t[f] * v_lead[f] for f in g) * scale[i]
        return time * clocks[i].hz / dist_g

    own = [[lead.accel_pulses[f] * lead.rates[f] / hz_l for f in range(n_l)],
           [lead.decel[f] * lead.rates[f] / hz_l for f in range(n_l)]]
    guess = [[max(RATE_MIN, round(ideal(i, g, own[0]))) for g in groups[i]] for i in range(m)]

    def durations(which: int) -> list[float]:
        t = list(own[which])
        for f in range(n_l - 1, -1, -1):          # slowest first
            for i in range(m):
                lst = leasts[i]
                assert lst is not None
                for k, g in enumerate(groups[i]):
                    if g[-1] != f:
                        continue                  # f does not end a stage of this axis
                    r = guess[i][k]
                    nxt = guess[i][k + 1] if k + 1 < len(groups[i]) else 0
                    if nxt >= r:
                        nxt = r - 1
                    need = lst(r, nxt)[which] * r / clocks[i].hz
                    t[f] = max(t[f], need - sum(t[x] for x in g[:-1]))
        return t

    t_acc = durations(0)
    t_dec = durations(1)
    if common:
        t_acc = t_dec = [max(a, d) for a, d in zip(t_acc, t_dec, strict=True)]
    side_least = (lambda pair: max(pair)) if common else (lambda pair: pair[0])
    s_acc = sum(t * v for t, v in zip(t_acc, v_lead, strict=True)) / dist[lead_i]
    s_dec = sum(t * v for t, v in zip(t_dec, v_lead, strict=True)) / dist[lead_i]
    if s_acc + s_dec > 1:
        return None
    t_cruise = (1 - s_acc - s_dec) * dist[lead_i] / v_lead[0]
    tables = []
    for i in range(m):
        lst = leasts[i]
        assert lst is not None
        hz = clocks[i].hz
        rates: list[int] = []   # slowest first
        acc: list[int] = []
        tau = 0.0
        pos = 0
        t_end = 0.0
        p_end = 0.0
        for g in groups[i]:
            t_end += sum(t_acc[f] for f in g)
            p_end += sum(t_acc[f] * v_lead[f] for f in g) * scale[i]
            prev = rates[-1] if rates else RATE_MAX + 1
            rho = ideal(i, g, t_acc)
            if g == [0]:   # the top: the rate whose cruise lasts closest to the leader's
                c_i = dist[i] * (1 - s_acc - s_dec)
                opts = {r for r in (math.floor(rho), math.ceil(rho))
                        if RATE_MIN <= r < prev} or {prev - 1}
                rr = min(opts, key=lambda r: abs(c_i * r / hz - t_cruise))
            else:
                opts = {r for r in (math.floor(rho), math.ceil(rho))
                        if RATE_MIN <= r < prev} or {prev - 1}
                rr = min(opts, key=lambda r: abs(pos + (t_end - tau) * hz / r - p_end))
            if rr < RATE_MIN:
                return None
            if rates:  # the step up to rr within the motor's capability
                low = side_least(lst(rates[-1], rr))
                if acc[-1] < low:
                    tau += (low - acc[-1]) * rates[-1] / hz
                    pos += low - acc[-1]
                    acc[-1] = low
            nn = max(round((t_end - tau) * hz / rr), lst(rr, 0)[0])
            rates.append(rr)
            acc.append(nn)
            tau += nn * rr / hz
            pos += nn
        n_i = len(rates)
        dec: list[int] = list(acc) if common else []
        u = 0.0
        u_end = 0.0
        for j in range(0 if common else n_i):          # slowest first = last in time first
            u_end += sum(t_dec[f] for f in groups[i][j])
            nxt = rates[j + 1] if j + 1 < n_i else 0
            nn = max(round((u_end - u) * hz / rates[j]), lst(rates[j], nxt)[1])
            dec.append(nn)
            u += nn * rates[j] / hz
        if n_i < 2:
            return None
        rates_f, acc_f, dec_f = rates[::-1], acc[::-1], dec[::-1]
        if (sum(acc_f) + sum(dec_f) > dist[i] or max(acc_f + dec_f) > STAGE_PULSES_MAX
                or max(sum(acc_f), sum(dec_f)) > SIDE_TOTAL_MAX):
            return None
        tables.append(_table(clocks[i], rates_f, acc_f, dec_f))
    return tables


def joint_path(pulse_times: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Every instant any axis emits a pulse (and t = 0), and every axis's pulses emitted by
    then (pulses at that instant included), from each axis's sorted pulse instants: the
    joint path as the chips emit it. Between two such instants nothing moves, so these
    states are all the states the path passes through."""
    t = np.unique(np.concatenate([np.zeros(1), *pulse_times]))
    x = np.stack([np.searchsorted(ti, t, side="right") for ti in pulse_times], axis=1)
    return t, x


def line_deviation_times(pulse_times: Sequence[np.ndarray | PulseTrain]
                         ) -> tuple[float, np.ndarray, np.ndarray]:
    """(largest distance, instants, distance at each instant) between the joint path and the
    straight line from the start to the end point, in pulses (each axis's pulse one unit),
    from each axis's pulse instants (its length is its pulse count) or pulse train (any
    length: `profiles.pulses.line_deviation`, memory and time bounded)."""
    return pulse_line_deviation(pulse_times)


def pulse_train(execution: Execution) -> PulseTrain:
    """The chip's pulse instants as pieces, one per segment: pulse j of a segment ends
    rate·(j+1) ticks after its start (the exact ticks of `Execution.pulse_times_s`, any
    number of pulses); its period is exact for the internal clocks."""
    hz = execution.clock.hz
    hz_exact = Fraction(int(hz)) if float(hz).is_integer() else Fraction(hz)
    pieces = []
    before = 0
    for s in execution.segments:
        def times(k: np.ndarray, start: int = s.start_tick, rate: int = s.rate,
                  first: int = before + 1) -> np.ndarray:
            return (start + rate * (k - first + 1)) / hz
        pieces.append(Piece(before + 1, s.pulses, times, Fraction(s.rate) / hz_exact))
        before += s.pulses
    return PulseTrain(pieces)


def line_deviation(executions: Sequence[Execution]) -> tuple[float, np.ndarray, np.ndarray]:
    """`line_deviation_times` of the chips' executions (any number of pulses)."""
    return line_deviation_times([pulse_train(e) for e in executions])


def plan_line_sync(axes: Sequence[tuple[str, Motor, int]], *, top_slack: float = TOP_SLACK,
                   accept: Accept | None = all_length_safe) -> SyncPlan:
    """Positions stay proportional (see the module docstring). `axes`: (name, motor, signed
    pulses); `accept(table, motor)` vets every table."""
    dist = [_distance(name, p) for name, _, p in axes]
    lead_i = int(np.argmax(dist))
    scales = [d / dist[lead_i] for d in dist]
    motors = [m for _, m, _ in axes]
    fastest_s = [_fastest(m, d)[1].duration_s for m, d in zip(motors, dist, strict=True)]
    # Every leader stage must last at least 2 pulses of every follower: many short stages
    # slow a far shorter axis down, so a leader of fewer stages is planned too (about a
    # third of the shortest follower's ramp pulses) and the better plan kept.
    env = envelope_motor(motors, scales)
    try:
        ramp = plan_free_curve(env, pulses=dist[lead_i]).table.accel_total
    except PlanError:
        ramp = 0
    few = max(2, min(127, int(min([s * ramp for s in scales]) / 3)))
    plans: list[tuple[float, SyncPlan]] = []
    for stages in sorted({127, few}, reverse=True):
        for margin in LINE_MARGINS:
            found = _line_attempt(axes, dist, lead_i, scales, motors, fastest_s, margin,
                                  top_slack, accept, stages)
            if found is not None:
                plans.append(found)
                break
    if plans:
        best = min(p[0] for p in plans)
        return min((p for p in plans if p[0] <= best + NEAR_BEST_PULSES),
                   key=lambda p: p[1].duration_s)[1]
    for stages in LINE_STAGES:
        for margin in LINE_MARGINS:
            found = _line_attempt(axes, dist, lead_i, scales, motors, fastest_s, margin,
                                  top_slack, accept, stages)
            if found is not None:
                return found[1]
    raise SyncError("no set of line-synchronised tables passed the stall check; the axes' "
                    "pulse ratio may need speeds below what the clocks can run")


def finish_together(tables: Sequence[FreeCurveTable], dist: Sequence[int], *,
                    symmetric: bool = False) -> list[FreeCurveTable] | None:
    """Every table padded to end with the slowest (None if one cannot be)."""
    exes = [simulate_move(t, n) for t, n in zip(tables, dist, strict=True)]
    end = max(e.duration_s for e in exes)
    out = []
    for t, n, e in zip(tables, dist, exes, strict=True):
        if e.duration_s == end:
            out.append(t)
            continue
        try:
            out.append(pad_to_ticks(t, n, math.floor(end * t.clock.hz + 1e-6),
                                    symmetric=symmetric))
        except SyncError:
            return None
    return out


def _line_attempt(axes: Sequence[tuple[str, Motor, int]], dist: list[int], lead_i: int,
                  scales: list[float], motors: list[Motor], fastest_s: list[float],
                  margin: float, top_slack: float, accept: Accept | None,
                  max_stages: int) -> tuple[float, SyncPlan] | None:
    env = envelope_motor(motors, scales, margin=margin)
    try:
        base = plan_free_curve(env, pulses=dist[lead_i], max_stages=max_stages).table
    except PlanError:
        return None
    r0 = base.rates[0]
    tops = list(range(r0, max(r0, math.floor(r0 * (1 + top_slack))) + 1))[:LINE_TOPS]
    candidates = []
    memo: dict[tuple[int, str], Callable[[int, int], tuple[int, int]] | None] = {}
    for r_top in tops:
        # LE=1 tables and LE=0 ones (symmetric triangles); followers stage by stage or
        # spanning several of the leader's short stages
        for common, grouped in ((False, False), (True, False), (False, True), (True, True)):
            joint = joint_tables(cap_top(base, r_top), dist, lead_i, motors, common=common,
                                 grouped=grouped, memo=memo)
            if joint is None:
                continue
            tables = finish_together(joint, dist, symmetric=common)
            if tables is None:
                continue
            exes = [simulate_move(t, n) for t, n in zip(tables, dist, strict=True)]
            dev = line_deviation(exes)[0]
            candidates.append((dev, max(e.duration_s for e in exes), r_top, tables, exes))

    # The stall criterion over every move length is the costly part: judge candidates in
    # order of deviation, then only faster ones within NEAR_BEST_PULSES of the first passed.
    def passes(c: tuple[float, float, int, list[FreeCurveTable], list[Execution]]) -> bool:
        return accept is None or all(accept(t, mo) for t, mo in zip(c[3], motors, strict=True))

    candidates.sort(key=lambda c: (c[0], c[1]))
    first = next((c for c in candidates if passes(c)), None)
    if first is None:
        return None
    near = sorted((c for c in candidates if c[0] <= first[0] + NEAR_BEST_PULSES
                   and c[1] < first[1]), key=lambda c: c[1])
    chosen = next((c for c in near if passes(c)), first)
    dev, _, r_top, tables, exes = chosen
    out = []
    for i, (name, motor, pulses) in enumerate(axes):
        how = (f"leads (envelope of all axes × {margin:g}, top rate {r_top})" if i == lead_i
               else f"follows at {scales[i]:.6g} × the leader's speed, top rate "
                    f"{tables[i].rates[0]}")
        out.append(AxisMove(name, pulses, motor, tables[i], exes[i], fastest_s[i], how))
    return dev, SyncPlan("line", tuple(out),
                         f"line: leader {axes[lead_i][0]} ({len(tables[lead_i].rates)} stages), "
                         f"{len(candidates)} candidates, deviation {dev:.4g} pulses")


def plan_sync(axes: Sequence[tuple[str, Motor, int]], mode: Mode, *,
              accept: Accept | None = all_length_safe) -> SyncPlan:
    if mode == "time":
        return plan_time_sync(axes, accept=accept)
    if mode == "line":
        return plan_line_sync(axes, accept=accept)
    raise SyncError(f"mode: {echo(mode)} is not 'time' or 'line'")
