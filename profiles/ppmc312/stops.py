"""A decel stop (81, and the high-speed limit's /FHL /BHL stop, §7-6) from any pulse of
the ramp: what the chip runs, and the load angle over every such stop of a table.

The manual (§8-2) does not say how the chip walks down the staircase from the middle of
an accel stage, so every reading it leaves open is judged (docs/manual-notes.md,
"Decel stops from any pulse of the ramp"). In table indices (0 = the fastest stage;
the accel runs stages n_a − 1 … 0, each A[i] pulses; the decel side has n_d stages of
D[i] pulses, D = A when LE = 0), a decel stop after p pulses (1 ≤ p ≤ A[i]) of accel
stage i runs, after the slower accel stages:

- (a) at once, same stage: D[i] more pulses at R[i], then decel stages i+1 … n_d − 1;
- (b) finish the stage: the rest of A[i] at R[i], then decel stages i+1 … n_d − 1;
- (c) at once, one stage down: decel stages i+1 … n_d − 1 right away;
- LOW (§11-1, E0 cause bit 「減速開始にて現在のパルスレートが停止パルスレートより低いた
  め即停止」): a stage slower than the decel side's slowest (LE = 1, i ≥ n_d) stops at
  once after its p pulses, under every reading.

Every stop is then the accel up to stage i, a *dwell* of L pulses at R[i], and the decel
stages slower than i: L = p under (c) (and (b), which is (c) with p = A[i]), L = D[i] + p
under (a). A stage's stops are the dwells L ∈ [1, A[i]] ∪ [D[i] + 1, D[i] + A[i]], and
the worst angle varies with L as a move's does with its length (the ringing's phase at
the step down): they are sampled and refined as move lengths are
(`load_angle.dwell_sampling`, `load_angle.refine`), so that every pulse of the ramp is
covered under every reading. A stop during the cruise runs the trapezoid's decel
(`stop_runs_at`), which the move verdict judges already.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import FieldRangeError, FormatError
from ..motor import Motor
from ..motor.batch import MoveBatch, Phase
from ..motor.batch_angle import dwell_sampling, judge, refine_toward, sample_grid
from ..motor.rotor import PEAK_DEG, Rotors, rotor_of, rotors
from ..remembered import Remembered
from .criterion import StepProblem, runs_problems
from .execution import Execution, Segment
from .init_model import as_free_curve
from .load_angle import directions
from .table import FreeCurveTable, InitTable

READINGS = ("a", "b", "c")
READING_TEXT = {
    "a": "at once, same stage: the stage's decel count more at its rate, then the slower "
         "decel stages",
    "b": "finish the stage, then the slower decel stages",
    "c": "at once, one stage down: the slower decel stages right away",
}
LOW_TEXT = ("slower than the stop rate: the chip stops at once (E0 cause bit LOW), "
            "under every reading")
DECEL_STOP_CODE = 0x81
# Ranges whose worst sample is this close to the worst of all are judged at every dwell
# around it. Sampled every eighth of a natural period, a stop's peak between samples was
# at most 1.0° above the samples' on the bundled motors' plans (bench/bench_stops.py
# checks the sampled verdict against every dwell); the moves' 3° (load_angle.REFINE_DEG)
# would refine most stages of a tightened table, whose stops all come near the aim.
Runs = list[tuple[Phase, int, int]]


def _sides(table: FreeCurveTable | InitTable) -> tuple[FreeCurveTable, tuple[int, ...],
                                                        tuple[int, ...]]:
    free = as_free_curve(table)
    return free, free.accel_pulses, free.decel


def is_low(table: FreeCurveTable | InitTable, stage: int) -> bool:
    """Whether accel stage `stage` runs slower than the decel side's slowest stage (LE = 1
    with fewer decel stages): a decel stop there stops at once (§11-1 LOW)."""
    return stage >= len(_sides(table)[2])


def stop_runs(table: FreeCurveTable | InitTable, stage: int, pulses_into_stage: int,
              reading: str) -> Runs:
    """The segments of a decel stop after `pulses_into_stage` pulses of accel stage
    `stage` (fastest-first index) under `reading` ("a", "b" or "c"; module docstring), as
    (phase, rate, pulses) from rest: the accel stages slower than `stage` and the
    stage's first pulses are "accel", everything the stop runs after them "decel"."""
    free, acc, dec = _sides(table)
    if reading not in READINGS:
        raise FormatError(f"decel-stop reading: {reading!r} is not one of "
                          f"{', '.join(READINGS)}")
    if isinstance(stage, bool) or not isinstance(stage, int | np.integer) or \
            not 0 <= stage < len(acc) or acc[stage] < 1:
        lo = next((i for i, a in enumerate(acc) if a), 0)
        raise FieldRangeError("decel-stop accel stage (0 = the fastest)", stage, lo,
                              len(acc) - 1)
    p = pulses_into_stage
    if isinstance(p, bool) or not isinstance(p, int | np.integer) or not 1 <= p <= acc[stage]:
        raise FieldRangeError(f"decel-stop pulses into accel stage {stage}", p, 1, acc[stage])
    rate = free.rates[stage]
    out: Runs = [("accel", free.rates[j], acc[j]) for j in range(len(acc) - 1, stage, -1)
                 if acc[j]]
    out.append(("accel", rate, int(p)))
    if stage >= len(dec):
        return out  # LOW: slower than the stop rate, it stops at once
    more = {"a": dec[stage], "b": acc[stage] - p, "c": 0}[reading]
    if more:
        out.append(("decel", rate, more))
    return out + [("decel", free.rates[j], dec[j]) for j in range(stage + 1, len(dec))
                  if dec[j]]


def locate(table: FreeCurveTable | InitTable, pulse: int) -> tuple[int, int] | None:
    """The accel stage (fastest-first index) and the pulses into it of the ramp's
    `pulse`-th pulse from rest (1 = the first), or None past the ramp (the cruise)."""
    _, acc, _ = _sides(table)
    if isinstance(pulse, bool) or not isinstance(pulse, int | np.integer) or pulse < 1:
        raise FieldRangeError("pulse of the ramp", pulse, 1, 0xFFFFFFFF)
    before = 0
    for i in range(len(acc) - 1, -1, -1):
        if pulse <= before + acc[i]:
            return i, int(pulse - before)
        before += acc[i]
    return None


def stop_runs_at(table: FreeCurveTable | InitTable, pulse: int, reading: str) -> Runs:
    """`stop_runs` for a decel stop after `pulse` pulses from rest: on the ramp, at its
    stage; past it, in the cruise at the top rate, the trapezoid's decel (every stage of
    the decel side, the top one first, under every reading)."""
    free, acc, dec = _sides(table)
    where = locate(free, pulse)
    if where is not None:
        return stop_runs(free, where[0], where[1], reading)
    if reading not in READINGS:
        raise FormatError(f"decel-stop reading: {reading!r} is not one of "
                          f"{', '.join(READINGS)}")
    out: Runs = [("accel", free.rates[j], acc[j]) for j in range(len(acc) - 1, -1, -1) if acc[j]]
    out.append(("cruise", free.rates[0], int(pulse) - sum(acc)))
    return out + [("decel", free.rates[j], dec[j]) for j in range(len(dec)) if dec[j]]


def ramp_pulse(table: FreeCurveTable | InitTable, stage: int, pulses_into_stage: int) -> int:
    """The pulse of the ramp from rest where a stop `pulses_into_stage` into accel stage
    `stage` takes effect (the pulses of the slower stages, plus those)."""
    _, acc, _ = _sides(table)
    return int(sum(acc[stage + 1:]) + pulses_into_stage)


def dwell_of(table: FreeCurveTable | InitTable, stage: int, pulses_into_stage: int,
             reading: str) -> int:
    """The pulses a stop `pulses_into_stage` into accel stage `stage` under `reading`
    dwells at the stage's rate (`stop_runs`'s segments at that rate, together)."""
    stop_runs(table, stage, pulses_into_stage, reading)  # refuses what is no stop
    _, acc, dec = _sides(table)
    if stage >= len(dec):
        return int(pulses_into_stage)  # LOW
    return int({"a": dec[stage] + pulses_into_stage, "b": acc[stage],
                "c": pulses_into_stage}[reading])


def readings_of(table: FreeCurveTable | InitTable, stage: int, dwell: int
                ) -> list[tuple[str, int | None]]:
    """The readings whose stop dwells `dwell` pulses at accel stage `stage`'s rate, each
    with its pulses into the stage (None: (b), which dwells A[i] wherever it comes), in
    the order a, b, c; a LOW stage is ("LOW", p)."""
    _, acc, dec = _sides(table)
    if stage >= len(dec):
        return [("LOW", dwell)]
    out: list[tuple[str, int | None]] = []
    if 1 <= dwell - dec[stage] <= acc[stage]:
        out.append(("a", dwell - dec[stage]))
    if dwell == acc[stage]:
        out.append(("b", None))
    if 1 <= dwell <= acc[stage]:
        out.append(("c", dwell))
    return out


def describe_readings(found: Sequence[tuple[str, int | None]]) -> str:
    """Readings as a message names them: "reading (a): at once, same stage: …"."""
    parts = []
    for reading, _ in found:
        parts.append(LOW_TEXT if reading == "LOW" else f"reading ({reading}): "
                     f"{READING_TEXT[reading]}")
    return "; ".join(parts)


def stop_execution(table: FreeCurveTable | InitTable, stage: int, dwell: int) -> Execution:
    """The stop that dwells `dwell` pulses at accel stage `stage`'s rate as an
    `Execution` (shape "decel_stop", status 0: no move reports it), for traces."""
    batch = stop_batch(table, np.asarray([stage]), np.asarray([dwell]))
    free = as_free_curve(table)
    segments, tick = [], 0
    for phase, rate, count in batch.runs(0):
        segments.append(Segment(phase, rate, count, tick))
        tick += rate * count
    return Execution(shape="decel_stop", status=0, segments=segments,
                     pulses=int(batch.pulses[0]), clock=free.clock, high_rate=free.rates[0],
                     high_rate_given=False)


def stop_batch(table: FreeCurveTable | InitTable, stage: np.ndarray, dwell: np.ndarray
               ) -> MoveBatch:
    """The stops that dwell `dwell[e]` pulses at accel stage `stage[e]`'s rate, as flat
    segment arrays (`MoveBatch`; shape 0 for all: a stop is no move shape): the accel
    stages slower than the stage (phase accel), the dwell (accel), the decel stages
    slower than it (decel). Built in numpy, never per stop."""
    free, acc, dec = _sides(table)
    rates = np.asarray(free.rates, dtype=np.int64)
    a = np.asarray(acc, dtype=np.int64)
    d = np.asarray(dec, dtype=np.int64)
    stage = np.asarray(stage, dtype=np.int64)
    dwell = np.asarray(dwell, dtype=np.int64)
    a_slow = np.flatnonzero(a[::-1] > 0)
    a_idx = len(a) - 1 - a_slow                    # accel stages with pulses, slowest first
    d_idx = np.flatnonzero(d > 0)                  # decel stages with pulses, fastest first
    n_pre = np.searchsorted(-a_idx, -stage, side="left")   # accel stages slower than stage
    d_from = np.searchsorted(d_idx, stage, side="right")   # first decel stage past it
    n_tail = len(d_idx) - d_from
    size = n_pre + 1 + n_tail
    offsets = np.concatenate(([0], np.cumsum(size)))
    total = int(offsets[-1])
    phase = np.zeros(total, np.int8)
    rate = np.empty(total, np.int64)
    count = np.empty(total, np.int64)
    pre = _spans(offsets[:-1], n_pre)
    k = pre - np.repeat(offsets[:-1], n_pre)
    rate[pre], count[pre] = rates[a_idx[k]], a[a_idx[k]]
    at = offsets[:-1] + n_pre
    rate[at], count[at] = rates[stage], dwell
    tail = _spans(at + 1, n_tail)
    j = d_idx[tail - np.repeat(at + 1, n_tail) + np.repeat(d_from, n_tail)]
    rate[tail], count[tail], phase[tail] = rates[j], d[j], 2
    pulses = np.add.reduceat(count, offsets[:-1]) if total else np.zeros(0, np.int64)
    return MoveBatch(pulses, np.zeros(len(stage), np.int64), phase, rate, count, offsets)


def _spans(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The indices starts[i] .. starts[i] + lengths[i] − 1, concatenated."""
    return np.repeat(starts - np.cumsum(lengths) + lengths, lengths) + np.arange(
        int(lengths.sum()))


@dataclass(frozen=True)
class Dwells:
    """The dwell ranges a table's stops run: range f dwells lo[f]..hi[f] pulses at accel
    stage stage[f]'s rate (one range per reading's span; (a)'s and (c)'s join when they
    touch). `key` numbers every (range, dwell) in one ascending integer line: range f's
    dwell L is base[f] + L."""

    stage: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    base: np.ndarray

    def of_key(self, key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(stage, dwell) of each key."""
        f = np.searchsorted(self.base, key, side="right") - 1
        return self.stage[f], key - self.base[f]


def dwell_ranges(table: FreeCurveTable | InitTable, ramp_limit: int | None = None) -> Dwells:
    """Every dwell a decel stop of `table` runs, stage by stage (module docstring); with
    `ramp_limit`, of the stops that come at most that many pulses up the ramp (the ramp
    the moves of some lengths run: `ramp_reach`)."""
    _, acc, dec = _sides(table)
    a = np.asarray(acc, dtype=np.int64)
    d = np.zeros(len(a), np.int64)
    shared = min(len(a), len(dec))
    d[:shared] = np.asarray(dec[:shared], dtype=np.int64)
    low = np.arange(len(a)) >= len(dec)
    before = np.concatenate((np.cumsum(a[::-1])[::-1][1:], [0]))  # ramp pulses before i
    reach = a if ramp_limit is None else np.clip(ramp_limit - before, 0, a)  # p ≤ reach
    has = reach > 0
    # (c): 1..p; (b): A[i] wherever it comes; (a): D[i] + 1..D[i] + p, unless LOW
    s_c, s_b, s_a = np.flatnonzero(has), np.flatnonzero(has & (reach < a) & ~low), \
        np.flatnonzero(has & ~low)
    stage = np.concatenate((s_c, s_b, s_a))
    lo = np.concatenate((np.ones(len(s_c), np.int64), a[s_b], d[s_a] + 1))
    hi = np.concatenate((reach[s_c], a[s_b], d[s_a] + reach[s_a]))
    # ranges of one stage that overlap or touch are one: sorted by stage then start, a
    # range starts a new one past the furthest end before it (stages kept apart by `gap`)
    order = np.lexsort((lo, stage))
    stage, lo, hi = stage[order], lo[order], hi[order]
    gap = int(hi.max(initial=0)) + 2
    reach_end = np.maximum.accumulate(hi + stage * gap)
    new = np.ones(len(stage), bool)
    new[1:] = lo[1:] + stage[1:] * gap > reach_end[:-1] + 1
    heads = np.flatnonzero(new)
    stage, lo = stage[heads], lo[heads]
    hi = np.maximum.reduceat(hi, heads) if len(heads) else hi
    base = np.concatenate(([0], np.cumsum(hi + 1)[:-1])).astype(np.int64)
    return Dwells(stage, lo, hi, base)


def ramp_reach(table: FreeCurveTable | InitTable, lengths: Sequence[int]) -> int:
    """The furthest pulse of the ramp the moves of `lengths` run (their accel pulses):
    a decel stop during one of them comes at most there."""
    from .move_batch import moves

    runs = moves(table, np.asarray(lengths, dtype=np.int64))
    accel = np.where(runs.phase == 0, runs.count, 0)
    per_move = np.add.reduceat(accel, runs.offsets[:-1]) if len(accel) else accel
    return int(np.where(np.diff(runs.offsets) > 0, per_move, 0).max(initial=0))


# --- the load angle over every stop of a table ------------------------------------------

@dataclass(frozen=True)
class WorstStop:
    """The worst |load angle| over the stops judged for one motor."""

    worst_angle_deg: float
    stage: int                     # the accel stage (fastest-first index) it came in
    dwell: int                     # pulses at that stage's rate
    readings: tuple[tuple[str, int | None], ...]   # `readings_of` that stop
    direction: int                 # 1 forward, −1 backward
    first_unstable: tuple[int, int] | None  # (stage, dwell) of the stop past 90° earliest
    #                                         on the ramp (None: none)
    slipped: bool
    executions: int                # stops judged × rotors

    @property
    def pulses_into_stage(self) -> int | None:
        """The pulses into the stage of the first reading that names them ((b) alone: None,
        it dwells the whole stage wherever it comes)."""
        return next((p for _, p in self.readings if p is not None), None)


@dataclass(frozen=True)
class StopAngles:
    """The worst |load angle| [electrical °] of every stop judged (stage[e], dwell[e]) for
    every rotor row: `deg[row, stop]`; row r is motor `owner[r]` moving `direction[r]`."""

    table: FreeCurveTable
    stage: np.ndarray
    dwell: np.ndarray
    deg: np.ndarray
    slipped: np.ndarray
    owner: np.ndarray
    direction: np.ndarray

    def worst(self, motor: int) -> WorstStop | None:
        """Motor `motor`'s worst stop (None: the table has no stop to judge)."""
        mine = np.flatnonzero(self.owner == motor)
        if not len(self.stage) or not len(mine):
            return None
        d = self.deg[mine]
        r, e = np.unravel_index(int(np.argmax(d)), d.shape)
        unstable = np.flatnonzero(np.any(d >= PEAK_DEG, axis=0))
        first = None
        if len(unstable):
            # the earliest on the ramp: the slowest stage, the shortest dwell there
            k = unstable[np.lexsort((self.dwell[unstable], -self.stage[unstable]))[0]]
            first = (int(self.stage[k]), int(self.dwell[k]))
        stage, dwell = int(self.stage[e]), int(self.dwell[e])
        return WorstStop(float(d[r, e]), stage, dwell,
                         tuple(readings_of(self.table, stage, dwell)),
                         int(self.direction[mine[r]]), first, bool(self.slipped[mine].any()),
                         len(self.stage) * len(mine))

    def worst_deg(self) -> float:
        """The worst angle over every motor (0 with no stop)."""
        return float(self.deg.max()) if self.deg.size else 0.0


STOP_VERDICTS_KEPT = 32
_verdicts: Remembered[StopAngles] = Remembered(STOP_VERDICTS_KEPT)


def stop_angles(table: FreeCurveTable | InitTable, motors: Sequence[Motor], *,
                stops: Sequence[tuple[int, int]] | None = None, ramp_limit: int | None = None,
                max_step_s: float | None = None) -> StopAngles:
    """The load angle of every decel stop of `table` (every pulse of the ramp, or of its
    first `ramp_limit` pulses; every reading: sampled, then refined around the worst, as
    move lengths are) for every motor and direction, or of the given (stage, dwell)
    stops. Judged through `load_angle.judge` (shared prefixes and tails). The last
    STOP_VERDICTS_KEPT verdicts over every stop are remembered by table, limit and motor
    values, read-only (tightening judges a table, then the safety verdict asks again)."""
    free = as_free_curve(table)
    if stops is not None or max_step_s is not None:
        return _stop_angles(free, motors, stops, ramp_limit, max_step_s)

    def judged() -> StopAngles:
        found = _stop_angles(free, motors, None, ramp_limit, None)
        for a in vars(found).values():
            if isinstance(a, np.ndarray):
                a.flags.writeable = False
        return found

    key = (free, ramp_limit, tuple(m.values_key() for m in motors))
    return _verdicts.get(key, judged)[0]


def forget_stop_verdicts() -> None:
    """Forget the remembered stop verdicts (a benchmark times a first verdict)."""
    _verdicts.clear()


def _stop_angles(free: FreeCurveTable, motors: Sequence[Motor],
                 stops: Sequence[tuple[int, int]] | None, ramp_limit: int | None,
                 max_step_s: float | None) -> StopAngles:
    owner = np.asarray([m for m, motor in enumerate(motors) for _ in directions(motor)])
    rot = Rotors.stack([rotors(motor, direction=d) for motor in motors
                        for d in directions(motor)])
    hz = free.clock.hz

    def run(stage: np.ndarray, dwell: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if not len(stage):
            return np.zeros((len(rot), 0)), np.zeros((len(rot), 0), bool)
        return judge(stop_batch(free, stage, dwell), hz, rot, max_step_s=max_step_s)

    if stops is not None:
        pairs = np.asarray(sorted({(int(s), int(d)) for s, d in stops}),
                           dtype=np.int64).reshape(-1, 2)
        stage, dwell = pairs[:, 0], pairs[:, 1]
        lag, slipped = run(stage, dwell)
    else:
        ranges = dwell_ranges(free, ramp_limit)
        keys, family, _ = stop_samples(free, motors, ranges)
        stage, dwell = ranges.of_key(keys)
        lag, slipped = run(stage, dwell)
        extra = (refine_toward(keys, family, np.degrees(lag.max(axis=0) * rot.c_e))
                 if len(keys) else keys)
        if len(extra):
            more = ranges.of_key(extra)
            more_lag, more_slipped = run(*more)
            stage = np.concatenate((stage, more[0]))
            dwell = np.concatenate((dwell, more[1]))
            lag = np.concatenate((lag, more_lag), axis=1)
            slipped = np.concatenate((slipped, more_slipped), axis=1)
    return StopAngles(free, stage, dwell, np.degrees(lag * rot.c_e), slipped, owner,
                      rot.direction)


def stop_samples(table: FreeCurveTable, motors: Sequence[Motor], ranges: Dwells
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The stops that stand for every dwell of every range (`Dwells` keys ascending, the
    range of each, each range's spacing): each range sampled from its shortest dwell
    every spacing pulses (1/8 of the natural period at the stage's speed, the stiffest
    motor's) until the dwell has lasted ten natural periods (a longer one repeats that
    settled state), and its longest (`load_angle.dwell_sampling`)."""
    if not len(ranges.stage):
        empty = np.zeros(0, np.int64)
        return empty, empty, empty
    rotor_list = [rotor_of(m) for m in motors]
    speed = table.clock.hz / np.asarray(table.rates, dtype=float)[ranges.stage]
    lo, hi = ranges.lo, ranges.hi
    spacing, dense = dwell_sampling(rotor_list, speed, lo, hi, 1)
    dwell, family = sample_grid(lo, spacing, dense, hi)
    keys, first = np.unique(ranges.base[family] + dwell, return_index=True)
    return keys, family[first], spacing


def stop_problems(table: FreeCurveTable | InitTable, motor: Motor,
                  ramp_limit: int | None = None) -> list[tuple[int, StepProblem]]:
    """The criterion on every decel stop's speed changes (of the stops on the first
    `ramp_limit` pulses of the ramp), as (stage, problem): per stage one stop stands for
    all (a dwell is the fastest segment of its stop, so both of its speed changes are
    judged on their neighbours' dwells, which no reading changes). A LOW stop ends slower
    than the stop rate: allowed as the stop rate is (the move verdict judges that one)."""
    free, _, dec = _sides(table)
    out: list[tuple[int, StepProblem]] = []
    for stage in np.unique(dwell_ranges(free, ramp_limit).stage).tolist():
        runs = stop_runs(free, stage, 1, "c")
        # the dwell as a cruise: the steps into and out of it are the trapezoid's accel
        # and decel steps, not a triangle's switch
        at = len(runs) - sum(1 for phase, _, _ in runs if phase == "decel") - 1
        runs[at] = ("cruise", runs[at][1], runs[at][2])
        found = runs_problems(runs, free.clock.hz, sum(c for _, _, c in runs), motor,
                              free.rates)
        low = stage >= len(dec)
        out += [(stage, p) for p in found if not (low and p.kind == "stop")]
    return out


def describe_stop(table: FreeCurveTable | InitTable, worst: WorstStop) -> dict[str, Any]:
    """Where a stop comes, as the verdict's JSON names it: the stage, the pulses into it
    and of the ramp, the readings."""
    p = worst.pulses_into_stage
    return {"stage": worst.stage, "dwell_pulses": worst.dwell,
            "pulses_into_stage": p,
            "ramp_pulse": None if p is None else ramp_pulse(table, worst.stage, p),
            "readings": [r for r, _ in worst.readings]}
