"""PPMC-312 chip-rule checks for tables: findings with the chip's own error codes.

`check_table(table)` returns every rule a table breaks (errors: the chip refuses
it or cannot output it) and every legal-but-suspect property (warnings), errors
first, then by stage. Stage numbers index the table's fastest-first lists.
Stall safety needs a motor and lives in `profiles.ppmc312.criterion`, not here.

Rules (SPEC §1.3–1.4, manual §7-1, §7-2, §11-6; choices in docs/manual-notes.md):

free curve
  stage-count       error 0x11  accel (decel) stage count outside 2..127
  rate-min          error 0x18  a stage rate ≤ 1
  speed-max         error       clock / rate above 2 Mpps
  pulses-min        error 0x19  a stage pulse count ≤ 1
  pulses-field      error       a stage pulse count above 0xFFFFF
  stage-ticks-min   error       pulses × rate < 256 clock ticks
  accel-total-max   error 0x1A  accel pulse total above 0xFFFFF
  decel-total-max   error 0x1A  decel pulse total above 0xFFFFF
  rates-monotonic   warning     rates not strictly increasing fastest → slowest
  stage-short       warning     a stage < 1/10 of its neighbours' mean duration
  stop-speed-high   warning     slowest decel stage ≥ 62.5 kpps (extra pulses)
  decel-stage-count warning     LE=1 with different accel and decel stage counts
init
  rate-range        error 0x01  start/stop outside 0x11..0xFFFF, high outside 2..0xFFEF
  start-above-high  error 0x03  start or stop ≤ high
  init-gap          error 0x02  slower of start/stop − high ≤ 127
                    error 0x04  faster of start/stop − high ≤ 127 (table cannot be built)
  init-pulses-field error       accel/decel pulses outside 0x10..0xFFFFF
  init-pulses-min   error       accel/decel pulses < 0x100
  init-stage-pulses error 0x05  the built table (profiles.ppmc312.init_model) has a stage ≤ 2 pulses
  speed-max         error       high speed above 2 Mpps
  stop-speed-high   warning     stop speed ≥ 62.5 kpps
"""

from __future__ import annotations

import math
from functools import partial
from itertools import pairwise

from profiles.errors import FormatError
from profiles.findings import Finding
from profiles.ppmc312.clock import MAX_OUTPUT_PPS
from profiles.ppmc312.limits import (
    MIN_STAGE_TICKS,
    SIDE_TOTAL_MAX,
    STAGE_PULSES_MAX,
    STAGE_PULSES_MIN,
    STAGES_MAX,
    STAGES_MIN,
)
from profiles.ppmc312.table import FreeCurveTable, InitTable, Table

STOP_SPEED_WARN_PPS = 62_500.0   # 8 MHz / 0x80: the chip over-runs at the stop rate
SHORT_STAGE_FRACTION = 0.1       # a stage under 1/10 of its neighbours' mean duration


def check_table(table: Table) -> list[Finding]:
    """All chip-rule findings for `table`: errors first, then by stage (table-wide first)."""
    if isinstance(table, FreeCurveTable):
        out = _check_free_curve(table)
    elif isinstance(table, InitTable):
        out = _check_init(table)
    else:
        raise FormatError(f"check_table: expected a FreeCurveTable or InitTable, "
                          f"got {type(table).__name__}")
    if len(out) > 1:
        out.sort(key=_order)
    return out


def _order(f: Finding) -> tuple[bool, bool, int]:
    return (f.severity != "error", f.stage is not None, -1 if f.stage is None else f.stage)


def min_rate_for(hz: float) -> int:
    """Smallest rate whose speed stays ≤ 2 Mpps at clock `hz`."""
    return max(2, math.ceil(hz / MAX_OUTPUT_PPS - 1e-9))


def _stop_rate_min(hz: float) -> int:
    # Smallest rate whose speed is below 62.5 kpps.
    return math.floor(hz / STOP_SPEED_WARN_PPS) + 1


# --- free curve ----------------------------------------------------------------

def _check_free_curve(t: FreeCurveTable) -> list[Finding]:
    sides: list[tuple[str, str, tuple[int, ...]]] = [("accel", "accel_pulses", t.accel_pulses)]
    if t.decel_pulses is not None:
        sides.append(("decel", "decel_pulses", t.decel_pulses))
    out = _stage_counts(t, sides)
    if not t.rates:
        return out
    # One min/max/comparison pass per rule answers "all fine" for the common case; plain
    # Python (at most 127 stages): `stepramp check` never imports numpy for a table.
    out += _rate_rules(t)
    for side, field, pulses in sides:
        if pulses:
            out += _side_rules(t, side, field, pulses)
    return out + _stop_speed(t)


def _stage_counts(t: FreeCurveTable, sides: list[tuple[str, str, tuple[int, ...]]]
                  ) -> list[Finding]:
    """Each side's stage count (2..127), and sides of different counts (legal, warned)."""
    out: list[Finding] = []
    for side, _, pulses in sides:
        if not STAGES_MIN <= len(pulses) <= STAGES_MAX:
            out.append(Finding("error", "stage-count",
                               f"{side} stage count {len(pulses)} is outside {STAGES_MIN}.."
                               f"{STAGES_MAX}: give {STAGES_MIN} to {STAGES_MAX} stages",
                               0x11))
    if t.decel_pulses is not None and len(t.decel_pulses) != len(t.accel_pulses):
        n_acc, n_dec = len(t.accel_pulses), len(t.decel_pulses)
        short, n_short = ("decel", n_dec) if n_dec < n_acc else ("accel", n_acc)
        end_rate = t.rates[n_short - 1] if 0 < n_short <= len(t.rates) else 0
        at = f" and starts/stops at rate {end_rate}" if end_rate else ""
        out.append(Finding("warning", "decel-stage-count",
                           f"{n_acc} accel stages but {n_dec} decel stages: legal, but the sides "
                           f"share rates, so {short} uses only the {n_short} fastest rates "
                           f"(rates[0..{n_short - 1}]){at}; give both sides the same count "
                           f"unless that is intended"))
    return out


def _rate_rules(t: FreeCurveTable) -> list[Finding]:
    """Rates ≤ 1 (0x18), speeds above 2 Mpps, rates that do not grow fastest to slowest."""
    out: list[Finding] = []
    rates, hz = t.rates, t.clock.hz
    increasing = all(b > a for a, b in pairwise(rates))
    rmin = rates[0] if increasing else min(rates)
    if rmin <= 1 or hz / rmin > MAX_OUTPUT_PPS:
        fastest_ok, clk = min_rate_for(hz), t.clock.name
        for i, r in enumerate(rates):
            if r <= 1:
                out.append(Finding("error", "rate-min",
                                   f"rates[{i}] = {r} is ≤ 1: raise it to ≥ {fastest_ok} "
                                   f"(≤ 2 Mpps at {clk})", 0x18, i))
            elif r < fastest_ok:
                out.append(Finding("error", "speed-max",
                                   f"rates[{i}] = {r} at {clk} gives {hz / r:.0f} pps > 2 Mpps: "
                                   f"raise it to ≥ {fastest_ok}", None, i))
    if not increasing:
        for i in range(1, len(rates)):
            if rates[i] <= rates[i - 1]:
                what = "repeats" if rates[i] == rates[i - 1] else "is faster than"
                out.append(Finding("warning", "rates-monotonic",
                                   f"rates[{i}] = {rates[i]} {what} rates[{i - 1}] = "
                                   f"{rates[i - 1]}: rates must grow from fastest to slowest; "
                                   f"make it > {rates[i - 1]} (sort or drop the stage)",
                                   None, i))
    return out


def _side_rules(t: FreeCurveTable, side: str, field: str, pulses: tuple[int, ...]
                ) -> list[Finding]:
    """One side's pulse counts: ≤ 1 (0x19), above the field, its total (0x1A), too few
    clock ticks a stage, and stages far shorter than their neighbours."""
    out: list[Finding] = []
    rates = t.rates
    if min(pulses) < STAGE_PULSES_MIN:
        for i, p in enumerate(pulses):
            if p < STAGE_PULSES_MIN:
                need = _pulses_needed(rates, i)
                out.append(Finding("error", "pulses-min",
                                   f"{field}[{i}] = {p} is ≤ 1: raise it to ≥ {need}",
                                   0x19, i))
    if max(pulses) > STAGE_PULSES_MAX:
        for i, p in enumerate(pulses):
            if p > STAGE_PULSES_MAX:
                out.append(Finding("error", "pulses-field",
                                   f"{field}[{i}] = {p} exceeds 0xFFFFF ({STAGE_PULSES_MAX})"
                                   f": lower it to ≤ {STAGE_PULSES_MAX}", None, i))
    total = sum(pulses)
    if total > SIDE_TOTAL_MAX:
        out.append(Finding("error", f"{side}-total-max",
                           f"{side} total {total} pulses exceeds 0xFFFFF "
                           f"({SIDE_TOTAL_MAX}): remove {total - SIDE_TOTAL_MAX} pulses "
                           f"from {field}", 0x1A))
    # pulses × rate per stage (a side uses the fastest len(pulses) rates)
    ticks = [p * r for p, r in zip(pulses, rates, strict=False)]
    if min(ticks) < MIN_STAGE_TICKS:
        clk = t.clock.name
        for i, (p, r) in enumerate(zip(pulses, rates, strict=False)):
            if p * r < MIN_STAGE_TICKS and p > 1 and r > 1:
                out.append(Finding("error", "stage-ticks-min",
                                   f"{field}[{i}]: rate {r} at {clk} × {p} pulses = {p * r} "
                                   f"ticks < {MIN_STAGE_TICKS}: raise the count to "
                                   f"≥ {_pulses_needed(rates, i)}", None, i))
    return out + _short_stages(side, field, ticks, rates)


def _stop_speed(t: FreeCurveTable) -> list[Finding]:
    """A stop at ≥ 62.5 kpps: the chip emits extra pulses at the stop rate (warned)."""
    n_dec, rates, hz = len(t.decel), t.rates, t.clock.hz
    if not n_dec or n_dec > len(rates):
        return []
    r_stop = rates[n_dec - 1]
    if r_stop <= 0 or hz / r_stop < STOP_SPEED_WARN_PPS:
        return []
    return [Finding("warning", "stop-speed-high",
                    f"slowest decel stage rates[{n_dec - 1}] = {r_stop} at {t.clock.name} "
                    f"stops at {hz / r_stop:.0f} pps ≥ 62500 pps: the chip emits tens "
                    f"of extra pulses at the stop rate; raise that rate to "
                    f"≥ {_stop_rate_min(hz)} or add a slower stage", None, n_dec - 1)]


def _pulses_needed(rates: tuple[int, ...], i: int) -> int:
    r = rates[i] if i < len(rates) else 0
    return max(STAGE_PULSES_MIN, math.ceil(MIN_STAGE_TICKS / r)) if r > 0 else STAGE_PULSES_MIN


def _short_stages(side: str, field: str, ticks: list[int], rates: tuple[int, ...]
                  ) -> list[Finding]:
    n = len(ticks)
    if n < 2:
        return []
    # Stage 0 (the fastest) runs straight on into the cruise at the same rate, so its
    # own length does not matter: planners give it the minimum on purpose, or (LE=1
    # decel) extra pulses that keep every triangle's switch safe. It is never reported,
    # and (being cruise-like) is no neighbour: stage 1's only neighbour is stage 2, the
    # last stage's only neighbour the one before it.
    # Candidates in integers: 20·t_i ≤ t_(i−1) + t_(i+1) (10·t_i ≤ the one neighbour of
    # stage 1 and of the last stage) holds whenever the exact test below does (ticks <
    # 2**41: the float rounding is far below one tick); few stages pass.
    last = n - 1
    tick = ticks
    candidates = [1] if n > 2 and 10 * tick[1] <= tick[2] else []
    candidates += [i for i in range(2, last) if 20 * tick[i] <= tick[i - 1] + tick[i + 1]]
    if 10 * tick[last] <= tick[last - 1]:
        candidates.append(last)
    if not candidates:
        return []
    out = []
    for i in candidates:
        # The neighbours' mean as floats, as the rule was first written; the sums are
        # below 2**53, so exact.
        mean = float(tick[i - 1]) if i == last else (
            float(tick[2]) if i == 1 else (tick[i - 1] + tick[i + 1]) / 2.0)
        if tick[i] < SHORT_STAGE_FRACTION * mean:
            # partial: the message is written only when read (a random table has ~9)
            out.append(Finding("warning", "stage-short",
                               partial(_short_message, side, field, i, tick[i], mean, rates[i]),
                               None, i))
    return out


def _short_message(side: str, field: str, i: int, ticks: int, mean: float, rate: int) -> str:
    target = SHORT_STAGE_FRACTION * mean
    need = math.ceil(target / rate) if rate > 0 else 2
    return (f"{side} stage {i} lasts {ticks} ticks, under 1/10 of its neighbours' mean "
            f"{mean:.0f} ticks: raise {field}[{i}] to ≥ {need} or merge the stage into a "
            "neighbour")


# --- init ------------------------------------------------------------------------

def _check_init(t: InitTable) -> list[Finding]:
    # here: the init model's stage grid needs numpy, which checking a free curve never does
    from profiles.ppmc312.init_model import (
        INIT_PULSES_FIELD_MAX,
        INIT_PULSES_FIELD_MIN,
        INIT_PULSES_MIN,
        init_rate_problems,
        init_stage_problem,
    )

    out: list[Finding] = []
    hz, clk = t.clock.hz, t.clock.name
    out += [Finding("error", rule, message, code) for code, rule, message in
            init_rate_problems(t)]
    rates_ok = not any(f.rule == "rate-range" for f in out)
    high = t.high_rate
    pulse_fields = [("accel_pulses", t.accel_pulses)]
    if t.decel_pulses is not None:
        pulse_fields.append(("decel_pulses", t.decel_pulses))
    for name, value in pulse_fields:
        if not INIT_PULSES_FIELD_MIN <= value <= INIT_PULSES_FIELD_MAX:
            fix = (f"raise it to ≥ {INIT_PULSES_MIN}" if value < INIT_PULSES_FIELD_MIN
                   else f"lower it to ≤ {INIT_PULSES_FIELD_MAX}")
            out.append(Finding("error", "init-pulses-field",
                               f"{name} = {value} is outside 0x10..0xFFFFF "
                               f"({INIT_PULSES_FIELD_MIN}..{INIT_PULSES_FIELD_MAX}): {fix}"))
        elif value < INIT_PULSES_MIN:
            out.append(Finding("error", "init-pulses-min",
                               f"{name} = {value} is below 0x100 (256): raise it to ≥ 256"))
    if high > 0 and hz / high > MAX_OUTPUT_PPS:
        out.append(Finding("error", "speed-max",
                           f"high_rate = {high} at {clk} gives {hz / high:.0f} pps > 2 Mpps: "
                           f"raise it to ≥ {min_rate_for(hz)}"))
    stop = t.effective_stop_rate
    if stop > 0 and hz / stop >= STOP_SPEED_WARN_PPS:
        name = "stop_rate" if t.stop_rate is not None else "start_rate (the stop rate, LE=0)"
        out.append(Finding("warning", "stop-speed-high",
                           f"{name} = {stop} at {clk} stops at {hz / stop:.0f} pps ≥ 62500 pps: "
                           f"the chip emits tens of extra pulses at the stop rate; raise it to "
                           f"≥ {_stop_rate_min(hz)}"))
    if rates_ok and not any(f.rule in ("start-above-high", "init-gap") for f in out):
        problem = init_stage_problem(t)
        if problem is not None:
            code, reason = problem
            out.append(Finding("error", "init-stage-pulses", reason, code))
    return out
