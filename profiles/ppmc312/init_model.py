"""The staircase the PPMC-312 builds from init parameters — a documented MODEL.

The manual (§7-1, SPEC §1.2) gives only the speed laws of an init table:
linear `V = V0 + K·t` and S-curve `V = V0 + K1·(1 − cos(K2·t))`, the parameter
limits and the error codes 0x01–0x05. It does not say how the chip turns them
into stages. This module is stepramp's model of that, not the chip's algorithm:

1. Grid. Sample the law at `n` equally spaced times from the slower end rate
   (`max(start, stop)`) to the high rate, round each speed to the nearest
   integer rate, merge duplicates. With LE=1 and start ≠ stop, the faster end
   rate is put into the grid exactly (inserted, or replacing the nearest
   interior rate when the grid is full), because the chip shares one rate list
   between the sides (shared-rate reading: each side uses the fastest stages).
2. Time. Each side (accel: start → high, decel: stop → high) takes the grid
   stages at or faster than its end rate. A stage starts at the time at which
   the side's own law reaches the stage's (quantised) speed, and lasts until
   the next stage starts; the high-rate stage lasts one mean stage duration.
   The time axis is scaled so that `Σ pulses = ∫ V dt` equals the pulse count.
3. Pulses. A stage gets `speed × duration` pulses, rounded by largest
   remainder so the side's total is exactly its pulse count.
4. Stage count. `n` is the largest value ≤ `max_stages` for which every stage
   of both sides has ≥ 3 pulses and ≥ 256 clock ticks (so the result is also a
   valid free curve). When even two stages leave a stage of ≤ 2 pulses the
   chip's answer is 0x05.

Error codes (manual §11-6), in the order the model checks them: 0x01 a rate
out of range; 0x03 start or stop ≤ high; 0x02 the slower of start/stop is
within 127 of high; 0x04 the faster of start/stop is within 127 of high (the
limit needs both ≥ high + 0x80, but 0x02 only tests the slower one, so the
other "is close to high and no table can be built"); 0x05 a built stage of
≤ 2 pulses. See docs/manual-notes.md.
"""

from __future__ import annotations

import numpy as np

from ..errors import FieldRangeError, InitBuildError, StepRampError, require_int
from .limits import MIN_STAGE_TICKS
from .limits import STAGES_MAX as MAX_STAGES
from .table import FreeCurveTable, InitTable

# Init parameter ranges and limits (manual §7-1).
START_RATE_MIN, START_RATE_MAX = 0x11, 0xFFFF
HIGH_RATE_MIN, HIGH_RATE_MAX = 0x02, 0xFFEF
INIT_PULSES_FIELD_MIN, INIT_PULSES_FIELD_MAX = 0x10, 0xFFFFF
INIT_PULSES_MIN = 0x100
MIN_GAP = 0x80                # start/stop ≥ high + 0x80
MIN_BUILT_STAGE_PULSES = 3    # a built stage of ≤ 2 pulses is error 0x05



def init_rate_problems(table: InitTable) -> list[tuple[int, str, str]]:
    """Every way the rate parameters break the chip's rules, as (chip code, rule id,
    message saying what to change); the one source of these rules for the model and
    for `profiles.ppmc312.chip_rules`. Order: 0x01 ranges; then 0x03 (start or stop ≤ high); else
    0x02 for the slower end within 127 of high and 0x04 for the faster one."""
    out: list[tuple[int, str, str]] = []
    rates = [("start_rate", table.start_rate, START_RATE_MIN, START_RATE_MAX)]
    if table.stop_rate is not None:
        rates.append(("stop_rate", table.stop_rate, START_RATE_MIN, START_RATE_MAX))
    rates.append(("high_rate", table.high_rate, HIGH_RATE_MIN, HIGH_RATE_MAX))
    for name, value, lo, hi in rates:
        if not lo <= value <= hi:
            fix = f"raise it to ≥ {lo}" if value < lo else f"lower it to ≤ {hi}"
            out.append((0x01, "rate-range",
                        f"{name} = {value} is outside 0x{lo:X}..0x{hi:X} ({lo}..{hi}): {fix}"))
    high = table.high_rate
    ends = [("start_rate", table.start_rate)]
    if table.stop_rate is not None:
        ends.append(("stop_rate", table.stop_rate))
    low_ends = [(n, v) for n, v in ends if v <= high]
    for name, value in low_ends:
        out.append((0x03, "start-above-high",
                    f"{name} = {value} is not slower than high_rate = {high}: raise it "
                    f"to ≥ {high + MIN_GAP} (high + 0x80)"))
    if not low_ends:
        slow_name, slow = max(ends, key=lambda e: e[1])
        for name, value in ends:
            if value - high < MIN_GAP:
                code = 0x02 if value == slow else 0x04
                why = ("" if code == 0x02 else
                       f" (the slower {slow_name} is far enough, but the chip cannot build "
                       f"the table)")
                # Only fixes that stay in their fields' ranges are offered (a slow start
                # rate cannot have a high rate 128 below it).
                fixes = [f"raise {name} to ≥ {high + MIN_GAP}"] \
                    if high + MIN_GAP <= START_RATE_MAX else []
                if value - MIN_GAP >= HIGH_RATE_MIN:
                    fixes.append(f"lower high_rate to ≤ {value - MIN_GAP}")
                out.append((code, "init-gap",
                            f"{name} − high_rate = {value} − {high} = {value - high} ≤ 127"
                            f"{why}: {' or '.join(fixes)}"))
    return out


def init_parameter_problem(table: InitTable) -> tuple[int, str] | None:
    """The chip's answer to the rate parameters before any table is built (0x01–0x04):
    the first of `init_rate_problems`, in the order the chip checks them."""
    problems = init_rate_problems(table)
    if not problems:
        return None
    code, _, message = min(problems, key=lambda p: _CHIP_ORDER.index(p[0]))
    return code, message


_CHIP_ORDER = (0x01, 0x03, 0x02, 0x04)


def init_stage_problem(table: InitTable, *, max_stages: int = MAX_STAGES) -> tuple[int, str] | None:
    """(chip code, reason) when the chip cannot build a table from `table`, else None.

    0x01–0x04 come from the rate parameters (`init_parameter_problem`); 0x05 when
    the model's table, even with two stages, has a stage of ≤ 2 pulses.
    """
    problem = init_parameter_problem(table)
    if problem is not None:
        return problem
    _, _, short = _build(table, max_stages)
    return short


def expand_init(table: InitTable, *, max_stages: int = MAX_STAGES) -> FreeCurveTable:
    """The free curve equivalent to `table` under this module's model (fastest first).

    LE=1 (separate decel) when the init table is. Raises `InitBuildError` with the
    chip's code when no table can be built.
    """
    problem = init_parameter_problem(table)
    if problem is not None:
        raise InitBuildError(*problem)
    rates, sides, short = _build(table, max_stages)
    if short is not None:
        raise InitBuildError(*short)
    accel = sides[0]
    decel = sides[1] if table.separate else None
    return FreeCurveTable(table.clock, tuple(int(r) for r in rates[::-1]),
                          tuple(int(p) for p in accel[::-1]),
                          None if decel is None else tuple(int(p) for p in decel[::-1]))


def as_free_curve(table: FreeCurveTable | InitTable) -> FreeCurveTable:
    """The stages a table gives the chip: a free curve as it is, an init table through
    this module's model (`expand_init`)."""
    if isinstance(table, InitTable):
        return expand_init(table)
    if not isinstance(table, FreeCurveTable):
        raise StepRampError(f"table: expected a FreeCurveTable or InitTable, got "
                            f"{type(table).__name__}")
    return table


# --- the model ---------------------------------------------------------------

def _build(table: InitTable, max_stages: int
           ) -> tuple[np.ndarray, list[np.ndarray], tuple[int, str] | None]:
    """Rates (slowest first), per-side pulses (slowest first), and a 0x05 problem or None."""
    require_int("max_stages", max_stages, 2, MAX_STAGES)
    start, stop, high = table.start_rate, table.effective_stop_rate, table.high_rate
    if start != stop and max_stages < 3:
        raise FieldRangeError("max_stages (start_rate ≠ stop_rate needs 3)", max_stages, 3,
                              MAX_STAGES)
    ends = [(start, table.accel_pulses)]
    if table.separate:
        ends.append((stop, table.effective_decel_pulses))
    slow_end, fast_end = max(start, stop), min(start, stop)
    for n in range(max_stages, 1, -1):
        grid = _grid(n, slow_end, fast_end, high, table.shape, max_stages)
        sides = [_side_pulses(grid, end, total, table.shape) for end, total in ends]
        if min(int(p.min()) for p in sides) < MIN_BUILT_STAGE_PULSES:
            continue
        # Ticks of a stage = pulses × rate; fewer stages only lengthen them, so when
        # even n = 2 is short in ticks the chip still builds it (no code for that).
        if n == 2 or all(int(t.min()) >= MIN_STAGE_TICKS for t in _ticks(grid, sides)):
            return grid, sides, None
    grid = _grid(2, slow_end, fast_end, high, table.shape, max_stages)
    sides = [_side_pulses(grid, end, total, table.shape) for end, total in ends]
    side_names = ["accel_pulses", "decel_pulses"]
    worst = min(range(len(sides)), key=lambda k: int(sides[k].min()))
    need = _pulses_for_min_stage(grid, ends[worst][0], ends[worst][1], table.shape)
    return grid, sides, (0x05, (
        f"even a 2-stage table has a stage of {int(sides[worst].min())} pulses (≤ 2): raise "
        f"{side_names[worst]} = {ends[worst][1]} to ≥ {need}"))


def _ticks(grid: np.ndarray, sides: list[np.ndarray]) -> list[np.ndarray]:
    """Each side's ticks per stage (pulses × rate); a side covers the grid's fastest stages."""
    return [p * grid[len(grid) - len(p):] for p in sides]


def _law(u: np.ndarray, v_end: float, v_high: float, shape: str) -> np.ndarray:
    """Speed at normalised ramp time u ∈ [0, 1] (0 at the end rate, 1 at high)."""
    if shape == "linear":
        return v_end + (v_high - v_end) * u
    return v_end + (v_high - v_end) * (1.0 - np.cos(np.pi * u)) / 2.0


def _law_time(v: np.ndarray, v_end: float, v_high: float, shape: str) -> np.ndarray:
    """Inverse of `_law`: the normalised time at which the law reaches speed v."""
    x = np.clip((v - v_end) / (v_high - v_end), 0.0, 1.0)
    if shape == "linear":
        return x
    return np.arccos(np.clip(1.0 - 2.0 * x, -1.0, 1.0)) / np.pi


def _grid(n: int, slow_end: int, fast_end: int, high: int, shape: str, max_stages: int
          ) -> np.ndarray:
    """Strictly decreasing integer rates from slow_end to high, fast_end included."""
    # Speeds in units of the clock (rate = 1/v): the clock cancels out of the grid.
    u = np.linspace(0.0, 1.0, n)
    v = _law(u, 1.0 / slow_end, 1.0 / high, shape)
    rates = np.clip(np.rint(1.0 / v), high, slow_end).astype(np.int64)
    rates[0], rates[-1] = slow_end, high
    rates = np.unique(rates)[::-1].copy()
    if fast_end != slow_end and fast_end not in rates:
        if len(rates) < max_stages:
            rates = np.sort(np.append(rates, fast_end))[::-1].copy()
        else:
            interior = np.arange(1, len(rates) - 1)
            k = interior[np.argmin(np.abs(rates[interior] - fast_end))]
            rates[k] = fast_end
    return rates


def _side_pulses(grid: np.ndarray, end_rate: int, total: int, shape: str) -> np.ndarray:
    """Pulse counts (slowest first) of the grid stages from end_rate to high."""
    rates = grid[grid <= end_rate]
    speeds = 1.0 / rates.astype(float)
    u = _law_time(speeds, speeds[0], speeds[-1], shape)
    m = len(rates)
    durations = np.empty(m)
    durations[:-1] = np.diff(u)
    durations[-1] = 1.0 / (m - 1)   # the high stage: one mean stage duration
    ideal = speeds * durations
    ideal *= total / ideal.sum()
    return _round_to_total(ideal, total)


def _round_to_total(ideal: np.ndarray, total: int) -> np.ndarray:
    """Largest-remainder rounding: integers within 1 of `ideal`, summing to `total`."""
    base = np.floor(ideal).astype(np.int64)
    missing = total - int(base.sum())
    if missing > 0:
        order = np.argsort(-(ideal - base), kind="stable")
        base[order[:missing]] += 1
    return base


def _pulses_for_min_stage(grid: np.ndarray, end_rate: int, total: int, shape: str) -> int:
    """Smallest pulse count (≥ 0x100) giving every stage of this side's grid ≥ 3 pulses."""
    lo, hi = max(total, INIT_PULSES_MIN - 1), max(total, INIT_PULSES_MIN)
    while int(_side_pulses(grid, end_rate, hi, shape).min()) < MIN_BUILT_STAGE_PULSES:
        lo, hi = hi, hi * 2
    # Bisection: more pulses never shrink the smallest stage by more than rounding.
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if int(_side_pulses(grid, end_rate, mid, shape).min()) >= MIN_BUILT_STAGE_PULSES:
            hi = mid
        else:
            lo = mid
    return hi
