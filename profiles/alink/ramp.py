"""The A-Link ALUM's ramp as stages — a documented MODEL (docs/manual-notes.md, "A-Link
ALUM: the ramp the load angle judges").

The manual gives the unit's speeds as whole steps of its multiplier (「駆動速度=(1 ~ 8000)
×倍率」, appendix 2), one acceleration para for both ways (UP_TIME 「1000パルス増加するのに
掛かる時間」, §11-2 (6)) and the choice 「加減速タイプ 0:直線 1:S字」 (MODE D4); it does not
say how the unit steps its speed, nor how a move too short for the high speed ramps. The
model, which the load-angle judge (verdict.judge_ramp, on safety.py) runs:

1. Speed steps. The ramp climbs from the start speed L to the high speed H through every
   speed the unit can hold on the way, v_k = L + k·m (k = 0 … K−1, K = (H − L)/m, m the
   multiplier), and runs at H after it.
2. When. Linear: the law v(t) = L + a·t (a = 1e8 / para pps/s); S-curve: v(t) = L + (H − L)
   (1 − cos(π t / T)) / 2 with T = (H − L) / a, the same average acceleration (the
   planner's reading). The unit is at step k from the instant the law reaches v_k until it
   reaches v_{k+1}.
3. Pulses. Each pulse lasts one period of the step in force when it begins: the first
   begins at t = 0 at L (the self-start speed), the next one period later, and so on (a
   step no pulse begins in is passed between two pulses and dropped). The ramp's pulses R
   are those that begin before the law reaches H.
4. Stages. A ramp of more than MAX_STAGES steps is judged as its first step (L exact) and
   MAX_STAGES − 1 stages of equal time, each pulse of a stage at the mean of its pulses'
   speeds: the steps
   of a fine ramp (m pps apart, sub-millisecond) are far shorter than the rotor's natural
   period, which the oracle test bounds (tests/profiles/alink/test_ramp.py).
5. Moves. A move of N pulses with R ramp pulses: N ≥ 2R, the ramp, N − 2R pulses at H, the
   ramp reversed (one para both ways); N < 2R, a triangle: the ramp's first ⌈N/2⌉ pulses
   up, its first ⌊N/2⌋ reversed down (decel mirrors accel). With triangle avoidance (MODE
   D5) and 3R > N: ⌊N/3⌋ up, the rest at the speed reached, ⌊N/3⌋ down (the PCL rule
   `model.move_times` uses). After the last pulse the command rests: the unit stops from
   the speed it decelerated to (L) within a step.
6. A decel stop (STOP nn 31) at pulse A of the ramp decelerates from the stage it is in
   along the ramp reversed: up A pulses, down the whole ramp below and including that stage.
7. Homing legs (profiles.alink.planner.homing): a search ramps from OL to OH at O_UPTIME's rate in
   MODE's shape, cruises at OH and stops at once where it meets the origin (no ramp down);
   the alignment runs at OL and stops at once at the edge.

Speeds are floats (stage means); `rates` are pulse periods in whole nanoseconds of the
model's clock `RAMP_HZ`, the form the compiled load-angle kernel takes.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..errors import FieldRangeError, require_int
from .model import MOVE_PULSES_MAX, PPS2_PER_INV_PARA, AlinkSettings

RAMP_HZ = 1e9        # the model's clock: pulse periods in whole nanoseconds
MAX_STAGES = 250     # a ramp of more speed steps is judged as this many stages of equal time
RampShape = Literal["linear", "s_curve"]
Kind = Literal["move", "stop", "search", "creep"]


@dataclass(frozen=True, eq=False)
class AlinkRamp:
    """The unit's ramp from `start_pps` to `high_pps` as stages, slowest first
    (`speeds_pps`, `pulses`): what every move runs up (and, reversed, down)."""

    shape: RampShape
    start_pps: float
    high_pps: float
    accel_pps2: float
    multiplier: int
    speeds_pps: np.ndarray = field(repr=False)
    pulses: np.ndarray = field(repr=False)
    triangle_avoidance: bool = False
    steps: int = 0                    # the unit's speed steps (K) the stages stand for
    max_pps: int = 0                  # MAX_SPEED (0: not set): a speed change's cap

    kind = "alink_ramp"

    @property
    def ramp_pulses(self) -> int:
        """R: the pulses of one ramp (up or down)."""
        return int(self.pulses.sum())

    @property
    def ramp_time_s(self) -> float:
        return float(np.sum(self.pulses / self.speeds_pps))

    @property
    def rates(self) -> np.ndarray:
        """Each stage's pulse period in ticks of `RAMP_HZ` (int64)."""
        return np.rint(RAMP_HZ / self.speeds_pps).astype(np.int64)

    @property
    def high_rate(self) -> int:
        return round(RAMP_HZ / self.high_pps)

    def key(self) -> tuple[object, ...]:
        """The values a verdict depends on (for remembering one)."""
        return (self.shape, self.start_pps, self.high_pps, self.accel_pps2, self.multiplier,
                self.triangle_avoidance, self.max_pps, self.pulses.tobytes(),
                self.speeds_pps.tobytes())

    def describe(self) -> str:
        shape = "S-curve" if self.shape == "s_curve" else "linear"
        return (f"{shape} ramp {self.start_pps:g} → {self.high_pps:g} pps at "
                f"{self.accel_pps2:.6g} pps/s (×{self.multiplier}: {self.steps} speed steps "
                f"as {len(self.pulses)} stages, {self.ramp_pulses} pulses, "
                f"{self.ramp_time_s * 1e3:.4g} ms)")


def ramp_of(settings: AlinkSettings) -> AlinkRamp:
    """The ramp the unit runs with `settings` (module doc: the model)."""
    return build_ramp(settings.start_pps, settings.high_pps, settings.accel_pps2,
                      settings.multiplier, "s_curve" if settings.s_curve else "linear",
                      triangle_avoidance=settings.triangle_avoidance,
                      max_pps=settings.max_pps)


def build_ramp(start_pps: float, high_pps: float, accel_pps2: float, multiplier: int,
               shape: RampShape = "linear", *, triangle_avoidance: bool = False,
               max_pps: int = 0) -> AlinkRamp:
    """The ramp from `start_pps` to `high_pps` in speed steps of `multiplier` at
    `accel_pps2` (the average for the S-curve)."""
    return build_ramps(start_pps, [high_pps], accel_pps2, multiplier, shape,
                       triangle_avoidance=triangle_avoidance, max_pps=max_pps)[0]


def build_ramps(start_pps: float, highs_pps: Sequence[float], accel_pps2: float,
                multiplier: int, shape: RampShape = "linear", *,
                triangle_avoidance: bool = False, max_pps: int = 0) -> list[AlinkRamp]:
    """`build_ramp` to each of `highs_pps`. The linear law reaches a step at one instant
    whatever the top, so each linear ramp's steps are the first ones of the ramp to the
    highest: their pulses are counted once (the loop over the steps was most of the
    speed-change and limit verdicts' ramps); the S-curve's law stretches with the top."""
    for high in highs_pps:
        if not 0 < start_pps <= high:
            raise FieldRangeError("start_pps", start_pps, 1, high)
    if not accel_pps2 > 0:
        raise FieldRangeError("accel_pps2", accel_pps2, PPS2_PER_INV_PARA / 4e6, math.inf)
    steps = [int((high - start_pps) // multiplier) for high in highs_pps]
    shared: list[int] = []
    if shape == "linear" and steps:
        k = np.arange(max(steps) + 1, dtype=float)
        shared = _step_pulses((k * multiplier / accel_pps2).tolist(),
                              (start_pps + k[:-1] * multiplier).tolist())
    out = []
    for high, k_steps in zip(highs_pps, steps, strict=True):
        if k_steps == 0:
            empty = np.zeros(0)
            out.append(AlinkRamp(shape, start_pps, high, accel_pps2, multiplier, empty,
                                 empty.astype(np.int64), triangle_avoidance, 0, max_pps))
            continue
        k = np.arange(k_steps + 1, dtype=float)
        v = start_pps + k[:-1] * multiplier
        top = start_pps + k_steps * multiplier
        ramp_s = (top - start_pps) / accel_pps2
        if shape == "linear":
            t = k * multiplier / accel_pps2
            counts = np.asarray(shared[:k_steps], dtype=np.int64)
        else:
            t = ramp_s / math.pi * np.arccos(np.clip(1 - 2 * k / k_steps, -1.0, 1.0))
            counts = np.asarray(_step_pulses(t.tolist(), v.tolist()), dtype=np.int64)
        out.append(_staged(shape, start_pps, high, accel_pps2, multiplier, t, v, counts,
                           ramp_s, triangle_avoidance, max_pps))
    return out


def _staged(shape: RampShape, start_pps: float, high_pps: float, accel_pps2: float,
            multiplier: int, t: np.ndarray, v: np.ndarray, counts: np.ndarray, ramp_s: float,
            triangle_avoidance: bool, max_pps: int) -> AlinkRamp:
    """The ramp of the steps' instants `t`, speeds `v` and pulses `counts`, as stages."""
    k_steps = len(v)
    if k_steps > MAX_STAGES:
        # the first step alone (the start speed exact), the rest in stages of equal time
        rest = (t[1:-1] - t[1]) / (ramp_s - t[1]) * (MAX_STAGES - 1)
        group = np.concatenate(([0], 1 + np.minimum(rest.astype(np.int64), MAX_STAGES - 2)))
        moved = np.bincount(group, counts * v, MAX_STAGES)
        counts = np.bincount(group, counts, MAX_STAGES).astype(np.int64)
        v = moved / np.maximum(counts, 1)   # each pulse at its own step's speed, averaged
    kept = counts > 0
    return AlinkRamp(shape, start_pps, high_pps, accel_pps2, multiplier, v[kept],
                     counts[kept], triangle_avoidance, k_steps, max_pps)


def _step_pulses(t: list[float], v: list[float]) -> list[int]:
    """How many pulses begin in each step k (from t[k] to t[k+1], at v[k]), each lasting one
    period of the step it begins in; a loop over the unit's steps (≤ 8000), not pulses:
    step k's count depends on the steps before it alone, so a prefix of `v` (and `t`)
    gives a prefix of the counts."""
    out = []
    tau = 0.0
    ceil = math.ceil
    for end, speed in zip(t[1:], v, strict=False):
        count = 0
        if tau < end:
            count = ceil((end - tau) * speed - 1e-9)
            if count < 0:
                count = 0
        out.append(count)
        tau += count / speed
    return out


# --- the motions a ramp runs -------------------------------------------------------------------

@dataclass(frozen=True)
class Parts:
    """Motions as (up, middle, down) pulses each: the ramp's first `up` pulses, `middle`
    pulses at the speed reached (H after a whole ramp), then the ramp's first `down` pulses
    reversed; `x` is what the caller counts them by (move length, stop pulse, leg length)."""

    x: np.ndarray
    up: np.ndarray
    middle: np.ndarray
    down: np.ndarray


def parts(ramp: AlinkRamp, kind: Kind, x: np.ndarray) -> Parts:
    """The motions of `kind` at `x`: a move of x pulses, a decel stop at pulse x of the
    ramp, a homing search of x pulses (ramp, cruise, stop at once), a creep of x pulses at
    the start speed (module doc: 5–7)."""
    x = np.asarray(x, dtype=np.int64).reshape(-1)
    r = ramp.ramp_pulses
    zero = np.zeros_like(x)
    if kind == "move":
        if ramp.triangle_avoidance:
            avoided = 3 * r > x
            third = x // 3
            up = np.where(avoided, third, r)
            return Parts(x, up, x - 2 * up, up.copy())
        tri = x < 2 * r
        up = np.where(tri, (x + 1) // 2, r)
        down = np.where(tri, x // 2, r)
        return Parts(x, up, x - up - down, down)
    if kind == "stop":
        ends = np.cumsum(ramp.pulses)
        stage = np.searchsorted(ends, x, side="left")
        return Parts(x, x.copy(), zero, ends[np.minimum(stage, len(ends) - 1)])
    if kind == "search":
        up = np.minimum(x, r)
        return Parts(x, up, x - up, zero)
    return Parts(x, zero, x.copy(), zero)


def families(ramp: AlinkRamp, kind: Kind
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The families of `kind`'s motions: (lo, hi, speed_pps) per family, each a range of x
    over which only one dwell grows, a pulse per x, at that speed (the last, open one
    — a cruise — up to MOVE_PULSES_MAX)."""
    p = ramp.pulses
    ends = np.cumsum(p)
    starts = ends - p
    r = ramp.ramp_pulses
    top = MOVE_PULSES_MAX
    if kind == "move":
        mult = 3 if ramp.triangle_avoidance else 2
        lo = np.append(mult * starts + 1, mult * r)
        hi = np.append(np.minimum(mult * ends, mult * r - 1), top)
        speed = np.append(ramp.speeds_pps, ramp.high_pps)
    elif kind == "stop":
        lo, hi, speed = starts + 1, np.minimum(ends, max(r - 1, 0)), ramp.speeds_pps
    elif kind == "search":
        lo = np.append(starts + 1, max(r, 1))
        hi = np.append(ends, top)
        speed = np.append(ramp.speeds_pps, ramp.high_pps)
    else:
        lo, hi, speed = np.array([1]), np.array([top]), np.array([ramp.start_pps])
    keep = lo <= hi
    return lo[keep].astype(np.int64), hi[keep].astype(np.int64), speed[keep].astype(float)


def segments(ramp: AlinkRamp, motions: Parts
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The motions as flat segments: (rate [ticks of RAMP_HZ], pulses, offsets): motion e
    is segments offsets[e]..offsets[e+1], neighbouring ones at one rate joined. Each
    motion's slots (its up stages, the middle, its down stages) are placed where they go,
    no sort."""
    p = ramp.pulses
    ends = np.cumsum(p)
    n = len(p)
    rates = np.append(ramp.rates, ramp.high_rate)
    counts = np.append(p, 0)      # a stage's pulses; the high speed's come from `middle`
    before = np.concatenate(([0], ends))   # pulses before each stage
    up, mid, down = motions.up, motions.middle, motions.down
    m = len(up)
    k_up = np.searchsorted(ends, up, side="left") if n else np.zeros(m, np.int64)
    k_dn = np.searchsorted(ends, down, side="left") if n else np.zeros(m, np.int64)
    n_up = np.where(up > 0, k_up + 1, 0)
    n_dn = np.where(down > 0, k_dn + 1, 0)
    size = n_up + 1 + n_dn
    first = np.cumsum(size) - size
    total = int(size.sum())
    rate = np.empty(total, np.int64)
    count = np.empty(total, np.int64)
    for n_side, k_side, part, rising in ((n_up, k_up, up, True), (n_dn, k_dn, down, False)):
        owner = np.repeat(np.arange(m), n_side)
        within = np.arange(int(n_side.sum())) - np.repeat(np.cumsum(n_side) - n_side, n_side)
        stage = within if rising else k_side[owner] - within
        slot = first[owner] + (within if rising else n_up[owner] + 1 + within)
        # the partial stage at the turn: the last going up, the first coming down
        turn = within == (n_side[owner] - 1 if rising else 0)
        rate[slot] = rates[stage]
        count[slot] = np.where(turn, part[owner] - before[stage], counts[stage])
    # the middle runs at the stage the up part ended in (H after a whole ramp)
    mid_stage = np.where(up >= ramp.ramp_pulses, n, k_up)
    rate[first + n_up] = rates[mid_stage]
    count[first + n_up] = mid
    owner = np.repeat(np.arange(m), size)
    keep = count > 0
    owner, rate, count = owner[keep], rate[keep], count[keep]
    # join neighbouring segments of one rate within a motion (the peak's dwell)
    new = np.ones(len(owner), bool)
    new[1:] = (owner[1:] != owner[:-1]) | (rate[1:] != rate[:-1])
    starts = np.flatnonzero(new)
    count = np.add.reduceat(count, starts) if len(starts) else count
    owner, rate = owner[starts], rate[starts]
    offsets = np.zeros(m + 1, np.int64)
    offsets[1:] = np.cumsum(np.bincount(owner, minlength=m))
    return rate, count, offsets


def pulse_times_s(ramp: AlinkRamp, kind: Kind, x: int) -> tuple[np.ndarray, np.ndarray]:
    """One motion's pulses under the model: (the instant of each pulse k = 1..N [s], the
    speed it runs at [pps]), the first pulse at one period after the start."""
    require_int("pulses", x, 1, MOVE_PULSES_MAX)
    rate, count, _ = segments(ramp, parts(ramp, kind, np.array([x])))
    period = np.repeat(rate / RAMP_HZ, count)
    return np.cumsum(period), 1.0 / period


def homing_ramp(ol_pps: int, oh_pps: int, accel_pps2: float, shape: RampShape,
                multiplier: int) -> AlinkRamp:
    """The homing search's ramp from OL to OH at O_UPTIME's rate (module doc: 7)."""
    return build_ramp(ol_pps, oh_pps, accel_pps2, multiplier, shape)


# --- one move as the unit runs it (stepramp simulate SETTINGS) -----------------------------------

PULSE_TIMES_CSV_MAX = 10_000_000   # rows of a pulse-times CSV (one a pulse)


@dataclass(frozen=True)
class Motion:
    """One move of `pulses` under the model: its parts, its segments (speed [pps] and
    pulses each, in order), its shape and duration."""

    pulses: int
    shape: str            # trapezoid, triangle, avoided_triangle, constant
    up: int
    middle: int
    down: int
    rates: np.ndarray = field(repr=False)    # ticks of RAMP_HZ per pulse, per segment
    counts: np.ndarray = field(repr=False)

    @property
    def speeds_pps(self) -> np.ndarray:
        return RAMP_HZ / self.rates.astype(float)

    @property
    def duration_s(self) -> float:
        return float(np.sum(self.counts * self.rates) / RAMP_HZ)

    @property
    def peak_pps(self) -> float:
        return float(self.speeds_pps.max())

    def to_json(self) -> dict[str, object]:
        return {"pulses": self.pulses, "shape": self.shape, "up_pulses": self.up,
                "middle_pulses": self.middle, "down_pulses": self.down,
                "duration_s": self.duration_s, "peak_pps": self.peak_pps,
                "segments": [{"speed_pps": v, "pulses": c} for v, c in
                             zip(self.speeds_pps.tolist(), self.counts.tolist(),
                                 strict=True)]}

    def segments_csv(self) -> str:
        """Each segment as CSV `segment,speed_pps,pulses,duration_s,end_s`."""
        dur = self.counts * self.rates / RAMP_HZ
        ends = np.cumsum(dur)
        return "segment,speed_pps,pulses,duration_s,end_s\n" + "".join(
            f"{k},{v:.6f},{c},{d:.9f},{e:.9f}\n" for k, (v, c, d, e) in enumerate(zip(
                self.speeds_pps.tolist(), self.counts.tolist(), dur.tolist(), ends.tolist(),
                strict=True)))

    def pulse_times_chunks(self, chunk: int = 1 << 16) -> Iterator[str]:
        """CSV `pulse,time_s`: each pulse's end, segment by segment, in pieces of at most
        `chunk` rows (memory does not grow with the move); at most PULSE_TIMES_CSV_MAX."""
        if self.pulses > PULSE_TIMES_CSV_MAX:
            raise FieldRangeError("pulses (one CSV row per pulse)", self.pulses, 1,
                                  PULSE_TIMES_CSV_MAX)
        yield "pulse,time_s\n"
        start, number = 0, 1
        for rate, count in zip(self.rates.tolist(), self.counts.tolist(), strict=True):
            for k0 in range(0, count, chunk):
                k = np.arange(k0 + 1, min(count, k0 + chunk) + 1, dtype=np.int64)
                times = (start + k * rate) / RAMP_HZ
                yield "".join(f"{n},{t:.9f}\n" for n, t in enumerate(times.tolist(), number))
                number += len(k)
            start += count * rate


def run_move(ramp: AlinkRamp, pulses: int) -> Motion:
    """The move of `pulses` the unit runs with `ramp` (module doc: 5)."""
    require_int("pulses", pulses, 1, MOVE_PULSES_MAX)
    p = parts(ramp, "move", np.array([pulses]))
    rates, counts, _ = segments(ramp, p)
    up, middle, down = int(p.up[0]), int(p.middle[0]), int(p.down[0])
    r = ramp.ramp_pulses
    shape = ("constant" if r == 0 else "trapezoid" if up == r else
             "avoided_triangle" if middle else "triangle")
    return Motion(pulses, shape, up, middle, down, rates, counts)
