"""The load angle of the motion commands other than the accel/decel move (issue 31): through
one motion of a program, and the envelope of each command family a table's user needs.

The model is `profiles.motor.rotor` (electrical degrees: the restoring torque peaks at
90°, a pole slips at 180°), integrated by its compiled kernel; what the chip runs is
`command_runs`'s model.

- `motion_angle`: one motion of a program (`command_runs.Motion`), its direction
  reversals included (a backward piece is a negative command speed: the rotor follows
  the signed command, `rotor.follow`), per motor (a tolerance box's corners), then at
  rest until the ringing has decayed.
- `command_envelopes`: per family, what the table's own use does (the worst angle and
  where) and the envelope within the aim, found by bisection over rates with the
  compiled verdict (`load_angle.judge`: each rate's runs are one batch whose members
  share their dwell, so a rate costs well under a millisecond):
  - constant (83) and origin-search (10): the fastest rate whose runs (a jump from rest,
    any number of pulses, an immediate stop) stay within the aim;
  - stop (80, /FL, /BL): the fastest rate from which an immediate stop, at any pulse of
    a cruise reached up the table's ramp (85), stays within the aim; the 05 rate to set
    is one faster, so that /FHL /BHL decelerate wherever /FL /BL would not stop in step;
  - set-speed (88): the largest jump down from, and up to, the table's top speed (from
    any phase of the cruise before it) within the aim;
  - change-speed (87): a move whose high rate is a slower stage, sped up to the top in
    its cruise: the old decel point (§8-8) leaves it stopping from the speed the walk
    down reaches; the worst such stop;
  - origin-return (11): at the table's high rate, /ORG as the cruise starts and once it
    has settled, the decel stop and the reversal at the start rate.
  The stops at any pulse are sampled as move lengths are (`load_angle.dwell_sampling`:
  every 1/8 natural period over the first, where a cruise rings most, and once ten
  periods have settled the dwell).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..motor import Motor
from ..motor.angles import AIM_DEG, PEAK_DEG, SLIP_DEG
from ..motor.batch import PHASE_CODES, MoveBatch, Phase
from ..motor.batch_angle import PHASE_SAMPLES, dwell_sampling, judge
from ..motor.rotor import Rotors, follow, rotor_of, rotors, settle_s
from ..remembered import Remembered
from .command_runs import Motion, ProgramCommand, Stairs, run_program
from .load_angle import directions
from .table import FreeCurveTable, InitTable

GRID = 12           # rates judged across a range before the bisection
PHASE_PERIODS = 1   # natural periods of a dwell sampled at every phase (then it only decays)
AFTER_JUMP_PERIODS = 3   # natural periods followed at a new rate before its decel
SET_SPEED_CLOSE = 0.01   # the largest immediate change is found to 1 % of its rate
Runs = Sequence[tuple[Phase, int, int]]


# --- one motion of a program -------------------------------------------------------------

@dataclass(frozen=True)
class MotionAngle:
    """The worst |load angle| through one motion over the motors judged."""

    worst_deg: float
    piece: int | None     # the piece it happens in (None: after the last pulse, at rest)
    motor: int            # which of the motors
    slipped: bool


def motion_angle(motion: Motion, motors: Sequence[Motor], *,
                 max_step_s: float | None = None) -> MotionAngle:
    """The load angle through `motion` for each of `motors` (its direction: `motion.ccw`,
    a backward piece the other way), then at rest until it settles; the worst of all."""
    hz = motion.clock.hz
    spans: list[tuple[float, float]] = []
    ends: list[int] = []   # the last piece of each span
    for k, p in enumerate(motion.pieces):
        speed = (-hz if p.backward else hz) / p.rate
        if spans and spans[-1][1] == speed:   # one constant command is one span
            spans[-1] = (spans[-1][0] + p.rate * p.pulses / hz, speed)
            ends[-1] = k
        else:
            spans.append((p.rate * p.pulses / hz, speed))
            ends.append(k)
    best = MotionAngle(-1.0, None, 0, False)
    for m, motor in enumerate(motors):
        rotor = rotor_of(motor, direction=-1 if motion.ccw else 1)
        step = rotor.step_s() if max_step_s is None else min(rotor.step_s(), max_step_s)
        trace = follow(rotor, [*spans, (settle_s(rotor, step), 0.0)], step_s=step,
                       record=False)
        deg = np.degrees(np.asarray(trace.span_max) * rotor.c_e)
        i = int(np.argmax(deg))
        if deg[i] > best.worst_deg:   # past the last span: at rest after the last pulse
            best = MotionAngle(float(deg[i]), ends[i] if i < len(ends) else None, m,
                               trace.slipped)
    return best


# --- envelopes -------------------------------------------------------------------------

@dataclass(frozen=True)
class Family:
    """One command family's verdict: the table's own use (`worst_deg` and `where`) and the
    envelope within the aim."""

    name: str
    worst_deg: float
    where: str
    envelope: dict[str, Any]

    @property
    def stable(self) -> bool:
        return self.worst_deg < PEAK_DEG

    def to_json(self) -> dict[str, Any]:
        return {"worst_load_angle_deg": self.worst_deg, "where": self.where, **self.envelope}


class _Judge:
    """The compiled verdict on batches of runs for a set of rotor rows, remembered by
    the runs (a bisection asks for some twice)."""

    def __init__(self, table: FreeCurveTable, motors: Sequence[Motor]) -> None:
        self.stairs = Stairs(table)
        self.hz = table.clock.hz
        self.rot = Rotors.stack([rotors(m, direction=d) for m in motors
                                 for d in directions(m)])
        self.rotor_list = [rotor_of(m) for m in motors]
        self.kept: dict[tuple[Any, ...], tuple[float, int]] = {}

    def worst(self, key: tuple[Any, ...], make: Callable[[], MoveBatch]) -> tuple[float, int]:
        """The worst angle over the runs `make()` gives and every rotor, and which run
        gives it; remembered by `key` (what names those runs)."""
        if key not in self.kept:
            lag, slipped = judge(make(), self.hz, self.rot)
            deg = np.degrees(lag * self.rot.c_e)
            deg = np.where(slipped, np.maximum(deg, SLIP_DEG), deg).max(axis=0)
            e = int(np.argmax(deg))
            self.kept[key] = (float(deg[e]), e)
        return self.kept[key]

    def period_pulses(self, rate: int, periods: int) -> int:
        """The pulses of `periods` natural periods at `rate` (the stiffest rotor's; at
        least one), at most the ten a dwell settles in."""
        spacing, dense = self._sampling(rate)
        return max(1, min(dense, spacing * PHASE_SAMPLES * periods))

    def _sampling(self, rate: int) -> tuple[int, int]:
        speed = np.asarray([self.hz / rate])
        one = np.asarray([1], np.int64)
        spacing, dense = dwell_sampling(self.rotor_list, speed, one,
                                        np.asarray([2**40], np.int64), 1)
        return int(spacing[0]), int(dense[0])

    def counts(self, rate: int) -> np.ndarray:
        """Pulse counts at `rate` that stand for every count: every 1/8 natural period
        over the first PHASE_PERIODS (every phase of the ringing at its largest: a cruise
        only damps it), and ten periods (a longer dwell repeats that settled state)."""
        step, dense = self._sampling(rate)
        last = min(dense, 1 + step * PHASE_SAMPLES * PHASE_PERIODS)
        return np.unique(np.append(np.arange(1, last + 1, step), dense))

    def ramp(self, rate: int) -> Runs:
        """Up the table's accel stages to `rate` (85, `command_runs.Stairs.up`)."""
        return [(p.phase, p.rate, p.pulses) for p in self.stairs.up(None, rate, 0)]

    def decel(self, rate: int) -> Runs:
        return [(p.phase, p.rate, p.pulses) for p in self.stairs.decel_from(rate, 0)]


def _members(prefix: Runs, rate: int, counts: np.ndarray, suffix: Runs = ()) -> MoveBatch:
    """The runs `prefix`, then `counts[e]` pulses at `rate`, then `suffix`, one for each
    count, built at once (a family whose dwell alone differs)."""
    n = len(counts)
    row = [*prefix, ("cruise", rate, 0), *suffix]
    size = len(row)
    phase = np.tile(np.asarray([PHASE_CODES[p] for p, _, _ in row], np.int8), n)
    rates = np.tile(np.asarray([r for _, r, _ in row], np.int64), n)
    count = np.tile(np.asarray([c for _, _, c in row], np.int64), n)
    count[len(prefix)::size] = counts
    offsets = np.arange(n + 1, dtype=np.int64) * size
    return MoveBatch(count.reshape(n, size).sum(axis=1), np.zeros(n, np.int64), phase, rates,
                     count, offsets)


def _batch(runs: Sequence[Runs]) -> MoveBatch:
    """Runs as one `MoveBatch` (its moves in order)."""
    sizes = np.asarray([len(r) for r in runs], np.int64)
    flat = [s for r in runs for s in r]
    count = np.asarray([c for _, _, c in flat], np.int64)
    offsets = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
    return MoveBatch(np.add.reduceat(count, offsets[:-1]), np.zeros(len(runs), np.int64),
                     np.asarray([PHASE_CODES[p] for p, _, _ in flat], np.int8),
                     np.asarray([r for _, r, _ in flat], np.int64), count, offsets)


def _reach(x0: int, x1: int, safe: Callable[[int], bool], close: float = 0.0) -> int | None:
    """The furthest x from x0 towards x1 such that it and every grid point before it are
    safe (None: x0 is not): a geometric grid of GRID points, then bisection to one, or to
    within `close` of x (a fraction)."""
    if not safe(x0):
        return None
    grid = np.unique(np.rint(np.geomspace(x0, x1, GRID)).astype(np.int64))
    grid = grid if x1 >= x0 else grid[::-1]
    prev = x0
    for x in grid.tolist()[1:]:
        if not safe(x):
            lo, hi = prev, x
            while abs(hi - lo) > max(1, close * lo):
                mid = (lo + hi) // 2
                lo, hi = (mid, hi) if safe(mid) else (lo, mid)
            return lo
        prev = x
    return x1


def _constant(j: _Judge, aim: float) -> Family:
    """83 (and 10): a jump from rest to the rate, any count, an immediate stop."""
    def worst(rate: int) -> tuple[float, int]:
        return j.worst(("constant", rate), lambda: _members((), rate, j.counts(rate)))

    s = j.stairs
    fastest = _reach(s.hi, s.lo, lambda r: worst(r)[0] <= aim)
    deg, e = worst(s.top)
    n = int(j.counts(s.top)[e])
    return Family("constant", deg, f"a constant run of {n} pulses at the table's high rate "
                  f"{s.top} ({j.hz / s.top:.6g} pps)", {
                      "fastest_rate": fastest,
                      "fastest_pps": None if fastest is None else j.hz / fastest,
                      "slowest_rate": s.hi, "slowest_rate_deg": worst(s.hi)[0]})


def _origin_search(j: _Judge, const: Family, aim: float) -> Family:
    """10: 83's runs (a constant run stopped at once on /ORG) over the rates its figure
    allows: the table's high rate up to the faster of its start and stop rates (§8-10)."""
    s = j.stairs
    slowest = min(s.start_rate, s.stop_rate)

    def worst(rate: int) -> float:   # the constant runs' batches, remembered alike
        return j.worst(("constant", rate), lambda: _members((), rate, j.counts(rate)))[0]

    fastest = _reach(slowest, s.lo, lambda r: worst(r) <= aim)
    deg = worst(slowest)
    return Family("origin-search", const.worst_deg,
                  const.where.replace("a constant run", "an origin search"), {
                      "fastest_rate": fastest,
                      "fastest_pps": None if fastest is None else j.hz / fastest,
                      "slowest_rate": slowest, "slowest_rate_deg": deg})


def _stop(j: _Judge, aim: float) -> Family:
    """80, /FL, /BL: up the ramp to the rate, any pulse of its cruise, stopped at once."""
    def worst(rate: int) -> tuple[float, int]:
        return j.worst(("stop", rate), lambda: _members(j.ramp(rate), rate, j.counts(rate)))

    s = j.stairs
    fastest = _reach(s.hi, s.lo, lambda r: worst(r)[0] <= aim)
    deg, e = worst(s.top)
    n = int(j.counts(s.top)[e])
    limit = None if fastest is None else (fastest - 1 if fastest > s.lo else None)
    return Family("stop", deg, f"an immediate stop {n} pulses into the cruise at the "
                  f"table's high rate {s.top} ({j.hz / s.top:.6g} pps)", {
                      "fastest_rate": fastest,
                      "fastest_pps": None if fastest is None else j.hz / fastest,
                      "slowest_rate": s.hi, "slowest_rate_deg": worst(s.hi)[0],
                      # /FHL /BHL decelerate at this rate and faster (§7-6)
                      "high_speed_limit_rate": 0xFFFF if fastest is None else
                      (None if limit is None else max(limit, 2))})


def _set_speed(j: _Judge, aim: float) -> Family:
    """88 at the top speed: from a cruise at one rate (any phase), at once to the other,
    then down the decel stages; both ways."""
    s = j.stairs

    def runs(frm: int, to: int) -> MoveBatch:
        # a few natural periods at the new rate show the jump's ringing at its largest;
        # the decel after it is the table's own (its verdict judges that)
        after = j.period_pulses(to, AFTER_JUMP_PERIODS)
        return _members(j.ramp(frm), frm, j.counts(frm),
                        [("cruise", to, after), *j.decel(to)])

    def worst(rate: int) -> float:
        return max(j.worst(("jump", s.top, rate), lambda: runs(s.top, rate))[0],
                   j.worst(("jump", rate, s.top), lambda: runs(rate, s.top))[0])

    # to 1 % of the rate: a jump is given in pps, and the top speed's rates are close
    to = _reach(s.top, s.hi, lambda r: worst(r) <= aim, SET_SPEED_CLOSE)
    still = worst(s.top)   # no change at all: the ramp, the cruise and the decel
    step = s.table.rates[1] if len(s.table.rates) > 1 else s.top
    deg = worst(step)
    return Family("set-speed", deg, f"an immediate speed change between the table's two "
                  f"fastest stages, {j.hz / s.top:.6g} and {j.hz / step:.6g} pps", {
                      "largest_change_pps": None if to is None else j.hz / s.top - j.hz / to,
                      "down_to_rate": to, "no_change_deg": still})


def _change_speed(j: _Judge, table: FreeCurveTable, motor: Motor) -> Family:
    """87 up to the top in the cruise of a move whose high rate is a slower stage: where
    the old decel point leaves it stopping (§8-8), for the high rate that stops fastest.
    A high rate H leaves the decel stages at or below its speed (D_H pulses); sped up,
    the walk down from the top runs out of them in the stage where the decel counts from
    the top first reach D_H: found for every H at once, the few fastest run through the
    model."""
    s = j.stairs
    pulses = 2 * (table.accel_total + table.decel_total) + 16
    highs = np.asarray(sorted({r for _, r, _ in s.acc if r != s.top}), np.int64)
    if not len(highs):
        return Family("change-speed", 0.0, "the table has one stage: no speed change", {
            "stops_from_pps": None, "faster_than_stop_rate": False, "high_rate": None})
    rates = np.asarray([r for _, r, _ in s.dec], np.int64)
    counts = np.asarray([n for _, _, n in s.dec], np.int64)
    left = (counts[None, :] * (rates[None, :] >= highs[:, None])).sum(axis=1)
    ends = rates[np.minimum(np.searchsorted(np.cumsum(counts), left), len(rates) - 1)]
    worst: tuple[int, Motion] | None = None
    for rate in highs[np.argsort(ends, kind="stable")][:3].tolist():
        at = sum(p.pulses for p in s.up(None, rate, 0)) + 1
        motion = run_program(table, [ProgramCommand("accel", rate, pulses),
                                     ProgramCommand("change-speed", s.top, at=at)]).motions[0]
        if worst is None or motion.final_rate < worst[1].final_rate:
            worst = (rate, motion)
    assert worst is not None
    rate, motion = worst
    speed = j.hz / motion.final_rate
    deg, _ = j.worst(("speed-up", rate), lambda: _batch([motion.runs()]))
    return Family("change-speed", deg, f"a move of {pulses} pulses at high rate {rate}, "
                  f"sped up to the top in its cruise, stops from {speed:.6g} pps at its old "
                  "decel point (§8-8)", {
                      "stops_from_pps": speed, "high_rate": rate,
                      "faster_than_stop_rate": motion.final_rate < s.stop_rate,
                      "above_start_speed": speed > motor.start_pps})


def _origin_return(j: _Judge, table: FreeCurveTable, motors: Sequence[Motor]) -> Family:
    """11 at the table's high rate: /ORG as the cruise starts and once it has settled,
    then the decel and the reversal. What the reversal meets comes after the whole decel,
    whose gentle steps leave little of the cruise's ringing (a stop on the ramp is the
    decel stop's verdict)."""
    s = j.stairs
    ramp = sum(p.pulses for p in s.up(None, s.top, 0))
    best: tuple[float, int] = (-1.0, 0)
    counts = j.counts(s.top)
    for n in sorted({int(counts[0]), int(counts[-1])}):
        run = run_program(table, [ProgramCommand("origin-return", 0, at=ramp + n)])
        deg = motion_angle(run.motions[0], motors).worst_deg
        best = max(best, (deg, ramp + n))
    stop_pps, start_pps = j.hz / s.stop_rate, j.hz / s.start_rate
    return Family("origin-return", best[0], f"/ORG at pulse {best[1]} of a high-speed "
                  f"origin return at the table's high rate, then back at the start rate", {
                      "reversal_pps": stop_pps + start_pps})


_kept: Remembered[dict[str, Family]] = Remembered(16)


def command_families(table: FreeCurveTable | InitTable, motors: Sequence[Motor], *,
                     aim_deg: float = AIM_DEG) -> dict[str, Family]:
    """Every family's verdict (module docstring) over `motors` (one motor, or a tolerance
    box's corners: the worst of them), remembered by table and motor values."""
    from .init_model import as_free_curve

    free = as_free_curve(table)

    def compute() -> dict[str, Family]:
        j = _Judge(free, motors)
        const = _constant(j, aim_deg)
        return {f.name: f for f in (const, _origin_search(j, const, aim_deg), _stop(j, aim_deg),
                                    _set_speed(j, aim_deg),
                                    _change_speed(j, free, motors[0]),
                                    _origin_return(j, free, motors))}

    key = (free, tuple(m.values_key() for m in motors), aim_deg)
    return _kept.get(key, compute)[0]


def command_envelopes(table: FreeCurveTable | InitTable, motor: Motor, *,
                      aim_deg: float = AIM_DEG) -> dict[str, Any]:
    """The envelope each command family allows `motor` within `aim_deg` (and, for a motor
    with tolerances, `"box"`: the same over its box's corners), per family name."""
    from ..motor.tolerance import corners

    out: dict[str, Any] = {name: f.to_json() for name, f in
                           command_families(table, [motor], aim_deg=aim_deg).items()}
    if motor.tolerances:
        box = command_families(table, [c.motor for c in corners(motor)], aim_deg=aim_deg)
        out["box"] = {name: f.to_json() for name, f in box.items()}
    return out
