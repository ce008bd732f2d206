"""ALGO A-Link ALUM024/025 positioning unit: speed multiplier, settings, command words.

Facts: SPEC §2 and the manual (`seeds/alink-alum-manual-ja.txt`, §11–13). Choices
where the manual is silent or contradicts itself: docs/manual-notes.md.

- Speeds are `steps × multiplier` (steps 1–8000); the unit picks the multiplier
  itself (appendix 2). `unit_applies` models what the unit runs for any setting,
  including its silent correction; `quantise_settings` produces settings the unit
  runs unchanged, rounded in the safe direction.
- Acceleration (UP_TIME, nn = 2): `para × 0.01 ms` per 1000 pps, one rate for
  both acceleration and deceleration, so a = 1e8 / para [pps/s].
- `plan_settings` picks the fastest stall-safe settings for a motor.
- Command words (`form`, `CommandWriter`, `settings_commands`) and responses
  (`decode_response`) are described once each as `fields.Frame`s.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, Literal

import numpy as np

from .errors import FieldRangeError, FormatError, StepRampError, require_int
from .fields import Bit, Bits, Frame
from .motor import Motor

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
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(
                value):
            raise FieldRangeError(name, value, 0, SPEED_MAX_PPS)
    warnings: list[str] = []
    max_int = _max_setting(max_pps)
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

Shape = Literal["trapezoid", "triangle", "avoided_triangle"]


@dataclass(frozen=True)
class MoveTime:
    duration_s: float
    peak_pps: float
    shape: Shape
    ramp_pulses: float  # pulses of one (accel) ramp


def _move_times(v0: Any, vh: Any, a: Any, pulses: float,
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
    t, vp, shape, ramp = _move_times(settings.start_pps, settings.high_pps, settings.accel_pps2,
                                     pulses, settings.triangle_avoidance)
    shapes: tuple[Shape, Shape, Shape] = ("trapezoid", "triangle", "avoided_triangle")
    return MoveTime(float(t), float(vp), shapes[int(shape)], float(ramp))


# --- settings planner --------------------------------------------------------------------------

S_CURVE_PEAK_FACTOR = math.pi / 2  # peak / average acceleration of the 1 − cos law


@dataclass(frozen=True)
class AlinkPlan:
    settings: AlinkSettings
    pulses: int | None
    predicted_time_s: float | None  # None for pulses=None (the long-move setting)
    shape: Shape | None
    ramp_time_s: float
    ramp_pulses: float
    accel_limit_pps2: float  # the motor's bound the ramp respects (min over [start, high])
    warnings: tuple[str, ...]
    ratio_to_optimum: float | None = None  # predicted / verify.references.exact_optimum


def plan_settings(motor: Motor, *, pulses: int | None = None, max_pps: float = 0,
                  s_curve: bool = False, ramp_limit_s: float = 1.0,
                  compare: bool = True) -> AlinkPlan:
    """Fastest stall-safe settings for `motor`.

    Every candidate high speed (each whole multiple of its multiplier up to the motor's
    top speed) gets the fastest start speed ≤ start_pps and jump_pps and the fastest
    para whose constant acceleration stays ≤ min a_acc and ≤ min a_dec over [start, high]
    (for the S-curve the 1 − cos peak, π/2 × average, is held to that bound). With
    `pulses`, the candidate with the shortest predicted move wins; without, the highest
    speed whose ramp lasts at most `ramp_limit_s`.
    """
    if pulses is not None:
        require_int("pulses", pulses, 1, MOVE_PULSES_MAX)
    if isinstance(ramp_limit_s, bool) or not isinstance(ramp_limit_s, int | float) or not (
            0 < ramp_limit_s <= 3600):
        raise FieldRangeError("ramp_limit_s", ramp_limit_s, 0, 3600)
    max_int = _max_setting(max_pps)
    top = min(motor.top_pps, max_int or SPEED_MAX_PPS, SPEED_MAX_PPS)
    start_cap = min(motor.start_pps, motor.jump_pps)
    bands = BANDS_BY_HIGH if max_int == 0 else BANDS_BY_MAX
    vh_all, m_all = [], []
    lower = 0
    for upper, m in bands:
        if max_int and not lower < max_int <= upper:
            lower = upper
            continue
        hi = min(upper, top) if max_int == 0 else min(max_int, top)
        first = (lower // m + 1) * m if max_int == 0 else m
        if hi >= first:
            speeds = np.arange(first, math.floor(hi) // m * m + 1, m, dtype=np.int64)
            vh_all.append(speeds)
            m_all.append(np.full(len(speeds), m, dtype=np.int64))
        lower = upper
    if not vh_all:
        raise FieldRangeError("motor.top_pps", motor.top_pps, 2, SPEED_MAX_PPS)
    vh = np.concatenate(vh_all)
    mult = np.concatenate(m_all)
    v0 = np.floor(start_cap / mult) * mult
    v0 = np.minimum(v0, vh)
    a_lim = np.minimum(motor.min_a_acc_pps2(v0, vh), motor.min_a_dec_pps2(v0, vh))
    peak_factor = S_CURVE_PEAK_FACTOR if s_curve else 1.0
    a_avg_lim = a_lim / peak_factor
    with np.errstate(divide="ignore", invalid="ignore"):
        para_exact = PPS2_PER_INV_PARA / a_avg_lim
        para = np.ceil(para_exact * (1 + 1e-12) / mult) * mult
    para = np.maximum(para, mult)
    ok = (v0 >= mult) & (a_lim > 0) & np.isfinite(para) & (para <= STEPS_MAX * mult)
    if not ok.any():
        raise StepRampError(f"{motor.name or 'motor'}: no A-Link setting is stall-safe (start "
                            f"speed {start_cap:g} pps, acceleration bounds outside "
                            "the para ranges); lower the load or set MAX_SPEED")
    vh, mult, v0, para, a_lim = vh[ok], mult[ok], v0[ok], para[ok], a_lim[ok]
    a = PPS2_PER_INV_PARA / para
    ramp_t = (vh - v0) / a
    if pulses is not None:
        t, _, _, _ = _move_times(v0, vh, a, pulses, avoid=False)
        best = int(np.argmin(t))
    else:
        fits = np.flatnonzero(ramp_t <= ramp_limit_s)
        best = int(fits[-1]) if len(fits) else int(np.argmin(ramp_t))
    warnings: list[str] = []
    if pulses is None and ramp_t[best] > ramp_limit_s:
        warnings.append(f"no setting ramps within {ramp_limit_s:g} s; the quickest ramp takes "
                        f"{ramp_t[best]:.3g} s")
    if v0[best] < start_cap:
        warnings.append(f"self-start speed {v0[best]:g} pps (motor allows {start_cap:g}: "
                        f"multiplier ×{mult[best]})")
    settings = AlinkSettings(int(v0[best]), int(vh[best]), int(para[best]), max_int, s_curve,
                             False, tuple(warnings))
    predicted = None
    shape: Shape | None = None
    ratio = None
    if pulses is not None:
        mt = move_time_s(settings, pulses)
        predicted, shape = mt.duration_s, mt.shape
        if compare:
            ratio = _ratio_to_optimum(motor, pulses, predicted, warnings)
    return AlinkPlan(settings, pulses, predicted, shape, float(ramp_t[best]),
                     float((vh[best] ** 2 - v0[best] ** 2) / (2 * a[best])), float(a_lim[best]),
                     tuple(warnings), ratio)


def _ratio_to_optimum(motor: Motor, pulses: int, predicted_s: float,
                      warnings: list[str]) -> float | None:
    try:
        from verify.references import exact_optimum  # lazily: verify depends on profiles
    except ImportError as e:
        warnings.append(f"ratio to optimum not computed: {e}")
        return None
    return predicted_s / float(exact_optimum(motor, pulses).duration_s)


# --- command codes (manual 12-4 table 12-4-1, 11-2 … 11-9) ------------------------------------

class Cmd(IntEnum):
    LOGIC = 0x1C
    MODE = 0x1D
    L_SPEED = 0x12
    H_SPEED = 0x13
    UP_TIME = 0x14
    MAX_SPEED = 0x15
    SETTING = 0x17
    OL_SPEED = 0x18
    OH_SPEED = 0x19
    O_UPTIME = 0x1A
    MODE_SIG = 0x1E
    MOVE_R = 0x21
    MOVE_A = 0x22
    STOP = 0x2F
    HOME = 0x31
    P_SEARCH = 0x3C
    M_SEARCH = 0x3D
    P_ORG = 0x3E
    M_ORG = 0x3F
    READ_STAT = 0x45
    READ = 0x46
    OUT_M = 0x4C
    OUT_B = 0x4D
    OUT_S = 0x4E
    OUT_G = 0x4F
    CHANGE_SPD = 0x51
    LIMIT = 0x52
    DELAY = 0x58
    OFFSET = 0x5A
    RESET_POS = 0x5B
    CLEAR_EL = 0x5C
    # read-backs (11-9): 0x86 and 0x8B do not exist
    L_SPEED_R = 0x82
    H_SPEED_R = 0x83
    UP_TIME_R = 0x84
    MAX_SPEED_R = 0x85
    SETTING_R = 0x87
    OL_SPEED_R = 0x88
    OH_SPEED_R = 0x89
    O_UPTIME_R = 0x8A
    LOGIC_R = 0x8C
    MODE_R = 0x8D
    MODE_SIG_R = 0x8E


READ_BACKS = frozenset(c for c in Cmd if c >= 0x80)
# func (nn) values the manual documents for the commands this module sends
FUNC_SPEED_PPS = 1       # L_SPEED/H_SPEED/OL_SPEED/OH_SPEED/MAX_SPEED: ×1 pps
FUNC_ACCEL_LEGACY = 1    # UP_TIME/O_UPTIME nn = 1: raw rate
FUNC_ACCEL_PARA = 2      # UP_TIME/O_UPTIME nn = 2: para × 0.01 ms/kpps
FUNC_MOVE = 28
FUNC_STOP_IMMEDIATE = 28
FUNC_STOP_DECEL = 31
FUNC_SETTING_COORD = 29
FUNC_SETTING_SOFT_LIMIT = 30
FUNC_EDGE_RISING = 28
FUNC_EDGE_FALLING = 30

PARA_MIN = -(1 << 27)
PARA_MAX = (1 << 27) - 1
FUNC_MAX = 31

COMMAND_FRAME = Frame("alink.command", (
    Bits("cmd_word", 2, (Bit("pair0", 14, 2), Bit("func", 8, 5), Bit("cmd", 0, 8)),
         order="little"),
    Bits("param1", 2, (Bit("pair1", 14, 2), Bit("para_hi", 0, 14)), order="little"),
    Bits("param2", 2, (Bit("pair2", 14, 2), Bit("para_lo", 0, 14)), order="little"),
))


class UnknownCommandError(StepRampError, ValueError):
    """A command code the A-Link ALUM manual does not define."""


def command_name(cmd: int) -> str:
    try:
        return Cmd(cmd).name
    except ValueError:
        raise UnknownCommandError(f"cmd: 0x{cmd:02X} is not an A-Link ALUM command "
                                  "(see profiles.alink.Cmd)") from None


def form(cmd: int, func: int, para: int) -> tuple[int, int, int]:
    """(CMD, PARAM1, PARAM2) without pair code: CMD = ((func << 8) & 0x1FFF) + cmd,
    para as 28-bit two's complement split 14 + 14."""
    return _form_words(cmd, func, para, 0)


def _form_words(cmd: int, func: int, para: int, pair: int) -> tuple[int, int, int]:
    if isinstance(cmd, bool) or not isinstance(cmd, int):
        raise UnknownCommandError(f"cmd: {cmd!r} is not an A-Link ALUM command code")
    command_name(cmd)
    require_int("func", func, 0, FUNC_MAX)
    require_int("para", para, PARA_MIN, PARA_MAX)
    raw = para & 0x0FFF_FFFF
    data = COMMAND_FRAME.encode(pair0=pair, pair1=pair, pair2=pair, func=func, cmd=int(cmd),
                                para_hi=raw >> 14, para_lo=raw & 0x3FFF)
    return _words(data)


def parse_command(w0: int, w1: int, w2: int) -> tuple[int, int, int, int]:
    """Inverse of the command words: (cmd, func, para, pair); refuses unknown codes,
    a set reserved bit 13 and unequal pair codes."""
    d = COMMAND_FRAME.decode(_pack_words((w0, w1, w2)))
    command_name(d["cmd"])
    pairs = (d["pair0"], d["pair1"], d["pair2"])
    if len(set(pairs)) != 1:
        raise FormatError(f"pair codes differ across the three words: {pairs}")
    return d["cmd"], d["func"], _signed28((d["para_hi"] << 14) | d["para_lo"]), pairs[0]


class PairCode(IntEnum):
    """Bits 15–14 of every command word (bits 3–2 of the status word)."""

    NOOP = 0
    ONE = 1
    TWO = 2
    THREE = 3

    def next(self) -> PairCode:
        return PairCode(next_pair(self))


def next_pair(pair: int) -> int:
    """Pair code after `pair`: 1 → 2 → 3 → 1 (0, the no-op, is never produced)."""
    require_int("pair", pair, 0, 3)
    return pair % 3 + 1


@dataclass(frozen=True)
class Command:
    name: str
    cmd: int
    func: int
    para: int
    words: tuple[int, int, int]  # pair code applied
    pair: int
    address: int | None = None   # D0 byte offset of the CMD word, when known


class CommandWriter:
    """putcmd: gives each command the next pair code (first one 1) on all three words."""

    def __init__(self, *, address: int | None = None) -> None:
        self.pair = 0  # last pair code sent (PairOld); 0 before the first command
        self.address = address

    def put(self, cmd: int, func: int, para: int) -> Command:
        pair = next_pair(self.pair)
        words = _form_words(cmd, func, para, pair)
        self.pair = pair
        return Command(command_name(cmd), int(cmd), func, para, words, pair, self.address)

    def stream(self, commands: Iterable[tuple[int, int, int]]) -> Iterator[tuple[int, int, int]]:
        """Yield the words of each (cmd, func, para) with pair codes applied."""
        for cmd, func, para in commands:
            yield self.put(cmd, func, para).words


def settings_commands(settings: AlinkSettings, *, slave_address: int | None = None,
                      axis: int = 0, duplex: Duplex = "full",
                      writer: CommandWriter | None = None) -> list[Command]:
    """The commands that program `settings`: MAX_SPEED, MODE, H_SPEED, L_SPEED, UP_TIME.

    MAX_SPEED and H_SPEED come first since the multiplier depends on them; the
    unit checks start ≤ high ≤ MAX_SPEED only at drive time (Nak), not per setting.
    """
    if writer is None:
        address = (None if slave_address is None
                   else command_address(slave_address, axis, duplex))
        writer = CommandWriter(address=address)
    seq = ((Cmd.MAX_SPEED, FUNC_SPEED_PPS, settings.max_pps),
           (Cmd.MODE, 0, settings.mode_word),
           (Cmd.H_SPEED, FUNC_SPEED_PPS, settings.high_pps),
           (Cmd.L_SPEED, FUNC_SPEED_PPS, settings.start_pps),
           (Cmd.UP_TIME, FUNC_ACCEL_PARA, settings.accel_para))
    return [writer.put(c, f, p) for c, f, p in seq]


def settings_document(settings: AlinkSettings, commands: Iterable[Command], *,
                      summary: dict[str, Any] | None = None,
                      warnings: Iterable[str] = ()) -> dict[str, Any]:
    """`settings` and the `commands` that program them as a JSON-ready dict (what
    `stepramp alink settings --format json` prints); `summary` adds planner numbers."""
    return {"multiplier": settings.multiplier, "start_pps": settings.start_pps,
            "high_pps": settings.high_pps, "up_time_para": settings.accel_para,
            "accel_ms_per_kpps": settings.accel_ms_per_kpps,
            "accel_pps2": settings.accel_pps2, "max_pps": settings.max_pps,
            "s_curve": settings.s_curve, **(summary or {}), "warnings": list(warnings),
            "commands": [{"name": c.name, "cmd": c.cmd, "func": c.func, "para": c.para,
                          "words": [f"0x{w:04X}" for w in c.words],
                          **({"address": f"0x{c.address:03X}"} if c.address is not None
                             else {})}
                         for c in commands]}


SETTINGS_FORMATS = ("text", "json", "hex", "c")


def render_settings(doc: dict[str, Any], fmt: str) -> str:
    """A `settings_document` as text, JSON, hex words (one command a line) or a C header."""
    import json

    if fmt == "json":
        return json.dumps(doc, indent=1) + "\n"
    if fmt == "hex":
        return "".join(" ".join(w[2:] for w in c["words"]) + "\n" for c in doc["commands"])
    if fmt == "c":
        # The separating comma goes before each row's comment: "}, /* … */," is not C.
        last = len(doc["commands"]) - 1
        rows = "\n".join("    {" + ", ".join(c["words"]) + "}" + ("," if i < last else " ")
                          + f"  /* {c['name']} func {c['func']} para {c['para']} */"
                          for i, c in enumerate(doc["commands"]))
        return ("/* A-Link ALUM settings generated by stepramp: "
                f"start {doc['start_pps']} pps, high {doc['high_pps']} pps, "
                f"×{doc['multiplier']}, UP_TIME para {doc['up_time_para']} */\n"
                "#ifndef STEPRAMP_ALINK_H\n#define STEPRAMP_ALINK_H\n#include <stdint.h>\n\n"
                f"static const uint16_t stepramp_alink_words[{len(doc['commands'])}][3] = {{\n"
                f"{rows}\n}};\n\n#endif\n")
    if fmt != "text":
        raise FormatError(f"format: {fmt!r} is not one of {', '.join(SETTINGS_FORMATS)}")
    lines = [f"multiplier ×{doc['multiplier']}: start {doc['start_pps']} pps, high "
             f"{doc['high_pps']} pps, UP_TIME para {doc['up_time_para']} "
             f"({doc['accel_ms_per_kpps']:g} ms/kpps = {doc['accel_pps2']:.6g} pps²)"]
    for key in ("predicted_time_s", "linear_time_s", "s_curve_time_s", "ratio_to_optimum"):
        if doc.get(key) is not None:
            lines.append(f"{key}: {doc[key]:.6g}")
    lines += [f"warning: {w}" for w in doc["warnings"]]
    lines += [f"{c['name']:10s} func {c['func']:2d} para {c['para']:8d}  "
              + " ".join(c["words"]) for c in doc["commands"]]
    return "\n".join(lines) + "\n"


# --- memory map (manual 9-2, 9-3) --------------------------------------------------------------

Duplex = Literal["full", "half"]
D0_BASE = 0x080  # commands
DI_BASE = 0x100  # status
AXES = 2
_SLAVE_MAX = {"full": 53, "half": 58}  # last address of the 2-axis unit must stay ≤ 63


def _address(base: int, slave_address: int, axis: int, duplex: str, word: int) -> int:
    if duplex not in _SLAVE_MAX:
        raise FormatError(f"duplex: {duplex!r} is not 'full' or 'half'")
    require_int("slave_address", slave_address, 1, _SLAVE_MAX[duplex])
    require_int("axis", axis, 0, AXES - 1)
    require_int("word", word, 0, 2)
    step = 2 if duplex == "full" else 1
    return base + 2 * (slave_address + step * (3 * axis + word))


def command_address(slave_address: int, axis: int = 0, duplex: Duplex = "full",
                    word: int = 0) -> int:
    """Byte offset in the master's memory of command word `word` (0 CMD, 1 PARAM1,
    2 PARAM2) of `axis` (0 or 1) of the unit at `slave_address`."""
    return _address(D0_BASE, slave_address, axis, duplex, word)


def status_address(slave_address: int, axis: int = 0, duplex: Duplex = "full",
                   word: int = 0) -> int:
    """Byte offset of response word `word` (0 status, 1 DATA1, 2 DATA2)."""
    return _address(DI_BASE, slave_address, axis, duplex, word)


# --- responses (manual 11-1, 11-8, 11-9 (12)) ---------------------------------------------------

_DATA_WORDS = (
    Bits("data1", 2, (Bit("pair1", 14, 2), Bit("value_hi", 0, 14)), order="little"),
    Bits("data2", 2, (Bit("pair2", 14, 2), Bit("value_lo", 0, 14)), order="little"),
)
STATUS_BITS = (Bit("ack", 0), Bit("eeprom_error", 1), Bit("pair0", 2, 2), Bit("extended", 4),
               Bit("driving", 5), Bit("inhibit", 6), Bit("origin_set", 8),
               Bit("origin_detecting", 9), Bit("plus_limit", 10), Bit("minus_limit", 11),
               Bit("limit_latched", 12), Bit("abnormal_stop", 15))
RESPONSE_FRAME = Frame("alink.response", (
    Bits("status", 2, STATUS_BITS, order="little", strict=False), *_DATA_WORDS))
# Read-back status: bits 3–2 carry the pair code (answith checks them for every answer;
# the table's "パラメータ0" label there is read as an erratum), bits 9–6 echo the
# sub-command, bits 15–11 hold parameter 0 (unit / method flag of PARAM1/2).
READBACK_STATUS_BITS = (Bit("ack", 0), Bit("pair0", 2, 2), Bit("extended", 4),
                        Bit("subcommand", 6, 4), Bit("param0", 11, 5))
READBACK_FRAME = Frame("alink.readback", (
    Bits("status", 2, READBACK_STATUS_BITS, order="little", strict=False), *_DATA_WORDS))
_FLAGS = ("eeprom_error", "extended", "driving", "inhibit", "origin_set", "origin_detecting",
          "plus_limit", "minus_limit", "limit_latched", "abnormal_stop")


@dataclass(frozen=True)
class AlinkResponse:
    ack: bool
    pair_codes: tuple[int, int, int]  # status, DATA1, DATA2
    value: int                        # DATA1:DATA2 as 28-bit signed
    valid: bool                       # all pair codes equal (and equal the one sent)
    mismatch: str | None = None       # which pair code disagrees, when not valid
    read_back: bool = False
    eeprom_error: bool = False
    extended: bool = False
    driving: bool = False
    inhibit: bool = False
    origin_set: bool = False
    origin_detecting: bool = False
    plus_limit: bool = False
    minus_limit: bool = False
    limit_latched: bool = False
    abnormal_stop: bool = False
    subcommand: int | None = None     # read-backs only: low nibble of the command echoed
    param0: int | None = None         # read-backs only

    def words(self) -> tuple[int, int, int]:
        """Re-encode (the inverse of decode_response for the bits the layout names)."""
        raw = self.value & 0x0FFF_FFFF
        vals: dict[str, Any] = {"ack": self.ack, "pair0": self.pair_codes[0],
                                "pair1": self.pair_codes[1], "pair2": self.pair_codes[2],
                                "value_hi": raw >> 14, "value_lo": raw & 0x3FFF}
        if self.read_back:
            vals.update(extended=self.extended, subcommand=self.subcommand or 0,
                        param0=self.param0 or 0)
            return _words(READBACK_FRAME.encode(vals))
        vals.update({k: getattr(self, k) for k in _FLAGS})
        return _words(RESPONSE_FRAME.encode(vals))


_WORD_NAMES = ("status", "DATA1", "DATA2")


def decode_response(w0: int, w1: int, w2: int, *, expected_pair: int | None = None,
                    read_back: bool = False, expected_cmd: int | None = None) -> AlinkResponse:
    """Decode status, DATA1, DATA2. Not `valid` (with `mismatch` saying which word
    disagrees) while the pair codes differ or differ from `expected_pair`: the host
    polls again. For read-backs, `expected_cmd` checks the echoed sub-command."""
    if expected_pair is not None:
        require_int("expected_pair", expected_pair, 0, 3)
    frame = READBACK_FRAME if read_back else RESPONSE_FRAME
    d = frame.decode(_pack_words((w0, w1, w2)))
    pairs = (d["pair0"], d["pair1"], d["pair2"])
    mismatch = None
    ref = pairs[0] if expected_pair is None else expected_pair
    for name, p in zip(_WORD_NAMES, pairs, strict=True):
        if p != ref:
            mismatch = (f"{name} pair code {p} ≠ {ref}" +
                        (" (sent)" if expected_pair is not None else " (status word's)"))
            break
    if mismatch is None and read_back and expected_cmd is not None:
        command_name(expected_cmd)
        if d["subcommand"] != expected_cmd & 0xF:
            mismatch = (f"status sub-command {d['subcommand']} ≠ {expected_cmd & 0xF} "
                        f"({command_name(expected_cmd)})")
    value = _signed28((d["value_hi"] << 14) | d["value_lo"])
    common: dict[str, Any] = dict(ack=bool(d["ack"]), pair_codes=pairs, value=value,
                                  valid=mismatch is None, mismatch=mismatch, read_back=read_back)
    if read_back:
        return AlinkResponse(**common, extended=bool(d["extended"]),
                             subcommand=d["subcommand"], param0=d["param0"])
    flags: dict[str, Any] = {k: bool(d[k]) for k in _FLAGS}
    return AlinkResponse(**common, **flags)


NAK_CAUSES = ("motor type differs", "parameter value not valid",
              "refused: driving (D5) or inhibit (D6)", "self-start speed > high speed",
              "origin not set")


def decode_nak_cause(param2: int) -> list[str]:
    """READ_STAT type 7 (Nak cause) PARAM2 bits D0–D4, as text."""
    require_int("param2", param2, 0, 0x3FFF)
    return [text for bit, text in enumerate(NAK_CAUSES) if param2 >> bit & 1]


# --- helpers -----------------------------------------------------------------------------------

def _words(data: bytes) -> tuple[int, int, int]:
    return (int.from_bytes(data[0:2], "little"), int.from_bytes(data[2:4], "little"),
            int.from_bytes(data[4:6], "little"))


def _pack_words(words: tuple[int, int, int]) -> bytes:
    for name, w in zip(_WORD_NAMES, words, strict=True):
        require_int(f"{name} word", w, 0, 0xFFFF)
    return b"".join(w.to_bytes(2, "little") for w in words)


def _signed28(raw: int) -> int:
    return raw - (1 << 28) if raw & (1 << 27) else raw


def _speed(name: str, value: Any) -> int:
    return require_int(name, value, SPEED_MIN_PPS, SPEED_MAX_PPS)


def _max_speed(value: Any) -> int:
    return require_int("max_pps", value, 0, SPEED_MAX_PPS)


def _max_setting(max_pps: Any) -> int:
    """MAX_SPEED from a user value: 0 (not set) or 1…100000 pps, rounded down."""
    if isinstance(max_pps, bool) or not isinstance(max_pps, int | float) or not (
            max_pps == 0 or SPEED_MIN_PPS <= max_pps <= SPEED_MAX_PPS):
        raise FieldRangeError("max_pps", max_pps, 0, SPEED_MAX_PPS)
    return math.floor(max_pps)
