"""A-Link ALUM024/025 model: speeds, the multiplier, settings and the move-time model.

Facts: SPEC §2 and the manual (`seeds/alink-alum-manual-ja.txt`, §13 and the
appendices). Choices where the manual is silent: docs/manual-notes.md.

- Speeds are `steps × multiplier` (steps 1–8000); the unit picks the multiplier
  itself (appendix 2). `unit_applies` models what the unit runs for any setting,
  including its silent correction; `quantise_settings` produces settings the unit
  runs unchanged, rounded in the safe direction.
- Acceleration (UP_TIME, nn = 2): `para × 0.01 ms` per 1000 pps, one rate for
  both acceleration and deceleration, so a = 1e8 / para [pps/s].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from ..errors import FieldRangeError, FormatError, is_number, require_int, require_number

# --- speeds and the multiplier (manual 13-2, 13-3) ---------------------------------------------

SPEED_MIN_PPS = 1
SPEED_MAX_PPS = 100_000
STEPS_MAX = 8000
# (upper bound of the band, multiplier), appendix 2 table 1 (MAX_SPEED = 0, by high speed)
# and table 2 (MAX_SPEED ≠ 0, by MAX_SPEED).
BANDS_BY_HIGH: tuple[tuple[int, int], ...] = ((8000, 2), (16000, 5), (40000, 10), (100000, 20))
BANDS_BY_MAX: tuple[tuple[int, int], ...] = ((8000, 1), (16000, 2), (40000, 5), (80000, 10),
                                             (100000, 20))
# Appendix 3: valid acceleration para (nn = 2) per multiplier is m … 8000·m. ×50…×500 are
# listed there but neither multiplier table can select them on this unit (notes).
PARA_RANGE: dict[int, tuple[int, int]] = {m: (m, STEPS_MAX * m)
                                          for m in (1, 2, 5, 10, 20, 50, 100, 200, 500)}
LEGACY_RATE_RANGE = (4, 39320)  # nn = 1: raw axis-chip rate (R3/R4), no documented conversion
PPS2_PER_INV_PARA = 1e8  # a [pps/s] = 1000 pps / (para × 1e-5 s)
MODE_DEFAULT = 0x0005    # D0 = D2 = 1 fixed (manual 11-2 (2))
MODE_S_CURVE = 1 << 4
MODE_TRIANGLE_AVOID = 1 << 5
MOVE_PULSES_MAX = (1 << 27) - 1


def multiplier(high_pps: int, max_pps: int = 0) -> int:
    """The multiplier the unit chooses: by MAX_SPEED when it is set, else by the high speed."""
    _speed("high_pps", high_pps)
    _max_speed(max_pps)
    value, bands = (high_pps, BANDS_BY_HIGH) if max_pps == 0 else (max_pps, BANDS_BY_MAX)
    for upper, m in bands:
        if value <= upper:
            return m
    raise AssertionError("unreachable: value checked against SPEED_MAX_PPS")


def accel_pps2(para: int) -> float:
    """Constant acceleration [pps/s] of an nn = 2 para (para × 0.01 ms per 1000 pps)."""
    return PPS2_PER_INV_PARA / para


@dataclass(frozen=True)
class AlinkRun:
    """What the unit actually runs for a set of raw settings (`unit_applies`)."""

    multiplier: int
    start_pps: int
    high_pps: int
    para: int
    nn: int
    accel_pps2: float | None  # None for nn = 1: the manual gives no conversion
    corrections: tuple[str, ...]
    nak: str | None  # why a drive command would be refused (None: accepted)


def unit_applies(start_pps: int, high_pps: int, para: int, *, max_pps: int = 0,
                 nn: int = 2) -> AlinkRun:
    """Model of the unit's handling of settings, silent corrections included.

    Speeds become `steps × m` with steps = ⌊speed / m⌋ clamped to 1…8000; the
    para is clamped into its range and (nn = 2) cut to a whole multiple of m —
    the register holds para / m (a reading of appendix 3, see notes), and
    truncation is the pessimistic reading (a faster ramp than asked).
    """
    _speed("start_pps", start_pps)
    m = multiplier(high_pps, max_pps)
    if nn not in (1, 2):
        raise FieldRangeError("nn", nn, 1, 2)
    require_int("para", para, 0, MOVE_PULSES_MAX)
    notes: list[str] = []
    speeds = []
    for name, value in (("start", start_pps), ("high", high_pps)):
        steps = min(max(value // m, 1), STEPS_MAX)
        if steps * m != value:
            notes.append(f"{name} speed {value} pps runs as {steps * m} pps (×{m}, {steps} steps)")
        speeds.append(steps * m)
    if nn == 2:
        lo, hi = PARA_RANGE[m]
        eff = min(max(para, lo), hi) // m * m
        accel: float | None = accel_pps2(eff)
    else:
        lo, hi = LEGACY_RATE_RANGE
        eff, accel = min(max(para, lo), hi), None
    if eff != para:
        notes.append(f"acceleration para {para} runs as {eff} (nn={nn}, ×{m}: {lo}..{hi})")
    nak = None
    if max_pps and high_pps > max_pps:
        nak = f"high speed {high_pps} pps > MAX_SPEED {max_pps} pps"
    elif high_pps < start_pps:
        nak = f"high speed {high_pps} pps < self-start speed {start_pps} pps"
    return AlinkRun(m, speeds[0], speeds[1], eff, nn, accel, tuple(notes), nak)


@dataclass(frozen=True)
class AlinkSettings:
    """Settings the unit runs exactly as given (checked on construction).

    `accel_para` is the UP_TIME para with nn = 2 (units of 0.01 ms per 1000 pps);
    `max_pps` is MAX_SPEED (0 = not set).
    """

    start_pps: int
    high_pps: int
    accel_para: int
    max_pps: int = 0
    s_curve: bool = False
    triangle_avoidance: bool = False
    warnings: tuple[str, ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        m = multiplier(self.high_pps, self.max_pps)
        _speed("start_pps", self.start_pps)
        if self.max_pps and self.high_pps > self.max_pps:
            raise FieldRangeError("high_pps", self.high_pps, SPEED_MIN_PPS, self.max_pps)
        if self.start_pps > self.high_pps:
            raise FieldRangeError("start_pps", self.start_pps, m, self.high_pps)
        for name in ("start_pps", "high_pps"):
            if getattr(self, name) % m:
                raise FormatError(f"{name}: {getattr(self, name)} is not a multiple of the "
                                  f"unit's multiplier ×{m}; use quantise_settings")
        lo, hi = PARA_RANGE[m]
        require_int("accel_para", self.accel_para, lo, hi)
        if self.accel_para % m:
            raise FormatError(f"accel_para: {self.accel_para} is not a multiple of ×{m}; "
                              "use quantise_settings")

    @property
    def multiplier(self) -> int:
        return multiplier(self.high_pps, self.max_pps)

    @property
    def accel_pps2(self) -> float:
        return accel_pps2(self.accel_para)

    @property
    def accel_ms_per_kpps(self) -> float:
        return self.accel_para / 100

    @property
    def mode_word(self) -> int:
        return (MODE_DEFAULT | (MODE_S_CURVE if self.s_curve else 0)
                | (MODE_TRIANGLE_AVOID if self.triangle_avoidance else 0))


def quantise_settings(start_pps: float, high_pps: float, accel_ms_per_kpps: float,
                      max_pps: float = 0, *, s_curve: bool = False,
                      triangle_avoidance: bool = False) -> AlinkSettings:
    """Settings the unit runs unchanged, never more aggressive than asked.

    High speed rounds down to a multiple of the multiplier, the start speed rounds
    down, MAX_SPEED rounds down, the para rounds up (slower ramp) to a multiple of
    the multiplier and is raised to the range minimum if asked faster. A ramp
    slower than the range allows would have to be made faster: refused
    (FieldRangeError) — raise MAX_SPEED to get a larger multiplier instead.
    """
    for name, value in (("start_pps", start_pps), ("high_pps", high_pps),
                        ("accel_ms_per_kpps", accel_ms_per_kpps), ("max_pps", max_pps)):
        if not is_number(value, finite=True):
            raise FieldRangeError(name, value, 0, SPEED_MAX_PPS)
    warnings: list[str] = []
    max_int = max_setting(max_pps)
    if max_pps:
        if max_int != max_pps:
            warnings.append(f"MAX_SPEED {max_pps:g} → {max_int} pps (whole pps, rounded down)")
    if not SPEED_MIN_PPS <= high_pps <= (max_int or SPEED_MAX_PPS):
        raise FieldRangeError("high_pps", high_pps, SPEED_MIN_PPS, max_int or SPEED_MAX_PPS)
    high = math.floor(high_pps)
    # Flooring can drop the speed into a lower band; band edges are multiples of every
    # multiplier, so one more pass settles it.
    for _ in range(3):
        m = multiplier(high, max_int)
        high_q = high // m * m
        if high_q == high:
            break
        high = high_q
    if high < 1:
        raise FieldRangeError("high_pps", high_pps, multiplier(1, max_int), max_int or
                              SPEED_MAX_PPS)
    m = multiplier(high, max_int)
    if high != high_pps:
        warnings.append(f"high speed {high_pps:g} → {high} pps (×{m}, "
                        f"{high - high_pps:+.6g} pps)")
    if not m <= start_pps:
        raise FieldRangeError("start_pps", start_pps, m, high)
    start = min(math.floor(start_pps) // m * m, high)
    if start != start_pps:
        warnings.append(f"self-start speed {start_pps:g} → {start} pps (×{m}, "
                        f"{start - start_pps:+.6g} pps)")
    lo, hi = PARA_RANGE[m]
    if accel_ms_per_kpps <= 0 or accel_ms_per_kpps * 100 > hi:
        raise FieldRangeError("accel_ms_per_kpps", accel_ms_per_kpps, lo / 100, hi / 100)
    asked = accel_ms_per_kpps * 100
    para = max(math.ceil(asked * (1 - 1e-12) / m) * m, lo)
    if abs(para - asked) > 1e-9 * asked:
        warnings.append(f"acceleration {accel_ms_per_kpps:g} → {para / 100:g} ms/kpps "
                        f"(para {para}, ×{m} steps of {m}; {para / asked - 1:+.3%} ramp time)")
    return AlinkSettings(start, high, para, max_int if max_pps else 0, s_curve,
                         triangle_avoidance, tuple(warnings))


# --- move-time model ---------------------------------------------------------------------------

UnitMoveShape = Literal["trapezoid", "triangle", "avoided_triangle"]


@dataclass(frozen=True)
class MoveTime:
    duration_s: float
    peak_pps: float
    shape: UnitMoveShape
    ramp_pulses: float  # pulses of one (accel) ramp


def move_times(v0: Any, vh: Any, a: Any, pulses: float,
                avoid: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Vectorised (time, peak, shape code 0/1/2, ramp pulses), symmetric ramps at rate a.

    The S-curve with the same average acceleration has the same time and distance
    as the linear ramp (the 1 − cos law is symmetric), so one formula serves both.
    """
    v0, vh, a = (np.asarray(x, dtype=float) for x in (v0, vh, a))
    d_ramp = (vh**2 - v0**2) / (2 * a)
    trapezoid = 2 * d_ramp <= pulses
    t_trap = 2 * (vh - v0) / a + (pulses - 2 * d_ramp) / vh
    if avoid:
        # Triangle avoidance: acceleration stops after a third of the pulses, a third
        # runs at that speed (the PCL-family rule; the manual is silent, see notes).
        capped = d_ramp > pulses / 3
        vp = np.where(capped, np.sqrt(v0**2 + 2 * a * pulses / 3), vh)
        t_cap = 2 * (vp - v0) / a + (pulses / 3) / vp
        t = np.where(capped, t_cap, t_trap)
        shape = np.where(capped, 2, 0)
        ramp = np.where(capped, pulses / 3, d_ramp)
        return t, vp, shape, ramp
    vp = np.where(trapezoid, vh, np.sqrt(v0**2 + a * pulses))
    t = np.where(trapezoid, t_trap, 2 * (vp - v0) / a)
    ramp = np.where(trapezoid, d_ramp, pulses / 2)
    return t, vp, np.where(trapezoid, 0, 1), ramp


def move_time_s(settings: AlinkSettings, pulses: int) -> MoveTime:
    """Predicted duration of a `pulses` move with these settings (continuous model)."""
    require_int("pulses", pulses, 1, MOVE_PULSES_MAX)
    t, vp, shape, ramp = move_times(settings.start_pps, settings.high_pps, settings.accel_pps2,
                                     pulses, settings.triangle_avoidance)
    shapes: tuple[UnitMoveShape, ...] = ("trapezoid", "triangle", "avoided_triangle")
    return MoveTime(float(t), float(vp), shapes[int(shape)], float(ramp))


# --- value checks ------------------------------------------------------------------------------

def _speed(name: str, value: Any) -> int:
    return require_int(name, value, SPEED_MIN_PPS, SPEED_MAX_PPS)


def _max_speed(value: Any) -> int:
    return require_int("max_pps", value, 0, SPEED_MAX_PPS)


def max_setting(max_pps: Any) -> int:
    """MAX_SPEED from a user value: 0 (not set) or 1…100000 pps, rounded down."""
    require_number("max_pps", max_pps, 0, SPEED_MAX_PPS)
    if 0 < max_pps < SPEED_MIN_PPS:
        raise FieldRangeError("max_pps", max_pps, 0, SPEED_MAX_PPS)
    return math.floor(max_pps)
