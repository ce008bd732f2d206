"""A torque reserve at the working speed (issue 32 item 2).

The planner may otherwise cruise where the pull-out torque is a few per cent of what the
motor gives at standstill (the model's curve ends at 5 %): the move is stall-safe by the
criterion, and any disturbance stalls it. Vendors size a stepper with a reserve at the
working speed (docs/manual-notes.md, "A torque reserve at speed"); stepramp keeps one at
the top speed a plan may run:

    T(v_top) ≥ need_factor × (T_f + |T_L|)     what cruising needs: friction and load
    T(v_top) ≥ standstill_share × T(0)         and a share of the standstill pull-out

(by default 2× and 10 %), by capping the motor's top speed (`max_pps`) where the pull-out
curve first falls below the larger of the two: every planner chooses its top speed from
`Motor.top_pps`, so the free curve, init and A-Link planners all keep it. Over a
tolerance box the worst case counts (the largest friction and load, the weakest curve).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace

from ..errors import FormatError, PlanError, echo
from .model import Motor

NEED_FACTOR = 2.0        # pull-out ≥ 2 × what cruising needs (vendors' 1.5–2 and more)
STANDSTILL_SHARE = 0.10  # pull-out ≥ 10 % of the standstill pull-out torque
NEED_FACTOR_MAX = 100.0
_SPEC = re.compile(r"^\s*(?:(?P<x>[0-9.eE+-]+)\s*[x×]\s*)?(?:,?\s*(?P<p>[0-9.eE+-]+)\s*%)?\s*$")


@dataclass(frozen=True)
class CruiseReserve:
    """`need_factor` ≥ 1 (1: the pull-out torque only has to carry the cruise) and
    `standstill_share` in [0, 1) (0: none); `off()` is both at their floor."""

    need_factor: float = NEED_FACTOR
    standstill_share: float = STANDSTILL_SHARE

    def __post_init__(self) -> None:
        if not (math.isfinite(self.need_factor) and 1 <= self.need_factor <= NEED_FACTOR_MAX):
            raise FormatError(f"cruise reserve: {self.need_factor:g}× what cruising needs is "
                              f"outside 1..{NEED_FACTOR_MAX:g}×")
        if not (math.isfinite(self.standstill_share) and 0 <= self.standstill_share < 1):
            raise FormatError(f"cruise reserve: {self.standstill_share * 100:g} % of the "
                              "standstill torque is outside 0..100 % (100 excluded)")

    @classmethod
    def off(cls) -> CruiseReserve:
        return cls(1.0, 0.0)

    @property
    def is_off(self) -> bool:
        return self.need_factor == 1 and self.standstill_share == 0

    @property
    def spec(self) -> str:
        """As `--cruise-reserve` takes it: `2x,10%` or `off`."""
        return "off" if self.is_off else (f"{self.need_factor:g}x,"
                                          f"{self.standstill_share * 100:g}%")

    def floor_nm(self, motor: Motor) -> float:
        """The pull-out torque the top speed must keep [N·m]."""
        worst = _worst(motor)
        need = worst.friction_torque_nm + abs(worst.load_torque_nm)
        return max(self.need_factor * need,
                   self.standstill_share * float(worst.torque_nm(0.0)))

    def top_pps(self, motor: Motor) -> float:
        """The highest speed up to which the pull-out curve keeps the floor (where it first
        falls below it; the curve's end when it never does), at most `motor.top_pps`."""
        worst = _worst(motor)
        floor = self.floor_nm(motor)
        v, t = worst.curve_speed_pps, worst.curve_torque_nm
        top = float(v[-1])
        if t[0] < floor:
            top = 0.0
        for i in range(len(v) - 1):
            if t[i] >= floor > t[i + 1]:   # linear between points: where it crosses
                top = float(v[i] + (t[i] - floor) / (t[i] - t[i + 1]) * (v[i + 1] - v[i]))
                break
        return min(top, motor.top_pps)

    def applied(self, motor: Motor) -> Motor:
        """`motor` with its top speed capped to keep the reserve (itself when the cap is
        above its top already); a reserve that leaves no speed above the start speed is
        one line naming `--cruise-reserve`."""
        top = self.top_pps(motor)
        if top >= motor.top_pps:
            return motor
        if top <= motor.start_pps:
            floor = self.floor_nm(motor)
            where = (f"never reaches {floor:.4g} N·m (it is {float(motor.torque_nm(0.0)):.4g} "
                     "N·m at standstill)" if top == 0 else
                     f"keeps {floor:.4g} N·m only up to {top:.6g} pps, not above the start "
                     f"speed {motor.start_pps:g} pps")
            raise PlanError(f"--cruise-reserve {self.spec} ({self.describe()}): the pull-out "
                            f"torque {where}: give a smaller reserve (e.g. --cruise-reserve "
                            "1.5x,5%) or less friction and load")
        return replace(motor, max_pps=top)

    def at(self, motor: Motor, speed_pps: float) -> ReserveAt:
        """What the motor keeps at `speed_pps` (a table's top speed)."""
        worst = _worst(motor)
        need = worst.friction_torque_nm + abs(worst.load_torque_nm)
        return ReserveAt(self, speed_pps, float(worst.torque_nm(speed_pps)), need,
                         float(worst.torque_nm(0.0)))

    def describe(self) -> str:
        if self.is_off:
            return "no reserve"
        return (f"pull-out ≥ {self.need_factor:g}× what cruising needs and ≥ "
                f"{self.standstill_share * 100:g} % of standstill")


@dataclass(frozen=True)
class ReserveAt:
    """The reserve a motor keeps at one speed: its pull-out torque, what cruising needs
    (friction and load torque) and its standstill pull-out torque [N·m]."""

    reserve: CruiseReserve
    speed_pps: float
    pullout_nm: float
    need_nm: float
    standstill_nm: float

    @property
    def times_need(self) -> float:
        return math.inf if self.need_nm == 0 else self.pullout_nm / self.need_nm

    @property
    def share(self) -> float:
        return self.pullout_nm / self.standstill_nm if self.standstill_nm > 0 else 0.0

    @property
    def kept(self) -> bool:
        # a hair of slack: the cap lies on the curve, the table's top a rate above it
        r = self.reserve
        return (self.pullout_nm >= r.need_factor * self.need_nm * (1 - 1e-9)
                and self.share >= r.standstill_share * (1 - 1e-9))

    def to_json(self) -> dict[str, object]:
        return {"reserve": self.reserve.spec, "speed_pps": self.speed_pps,
                "pullout_torque_nm": self.pullout_nm, "cruise_torque_nm": self.need_nm,
                "times_cruise_torque": None if self.need_nm == 0 else self.times_need,
                "share_of_standstill": self.share, "kept": self.kept}

    def describe(self) -> str:
        """`at the top speed 18 000 pps the pull-out torque is 0.081 N·m: 4× what cruising
        needs (0.02 N·m), 18 % of standstill; reserve kept (≥ 2×, ≥ 10 %)`."""
        times = ("nothing to carry" if self.need_nm == 0 else
                 f"{self.times_need:.3g}× what cruising needs ({self.need_nm:.4g} N·m)")
        verdict = (" (--cruise-reserve off)" if self.reserve.is_off else
                   f"; {'kept' if self.kept else 'NOT kept'} ({self.reserve.spec}: "
                   f"{self.reserve.describe()})")
        return (f"cruise reserve at the top speed {self.speed_pps:.6g} pps: pull-out "
                f"{self.pullout_nm:.4g} N·m, {times}, {self.share * 100:.3g} % of standstill"
                + verdict)


def parse_cruise_reserve(text: str) -> CruiseReserve:
    """`--cruise-reserve`: `2x,10%` (both), `3x` or `15%` (one: the other at its default),
    `off` (none: the top speed is the curve's); one line naming the option otherwise."""
    if text.strip().lower() in ("off", "none", "0"):
        return CruiseReserve.off()
    match = _SPEC.match(text)
    if match is None or not (match["x"] or match["p"]):
        raise FormatError(f"--cruise-reserve: expected FACTORx,SHARE% (e.g. 2x,10%; a factor "
                          f"of what cruising needs, a share of the standstill torque) or off, "
                          f"got {echo(text)}")
    try:
        factor = float(match["x"]) if match["x"] else NEED_FACTOR
        share = float(match["p"]) / 100 if match["p"] else STANDSTILL_SHARE
    except ValueError:
        raise FormatError(f"--cruise-reserve: {echo(text)}: not numbers") from None
    try:
        return CruiseReserve(factor, share)
    except FormatError as e:  # the option as typed, not the library's field
        raise FormatError(str(e).replace("cruise reserve:", "--cruise-reserve:", 1)) from None


def _worst(motor: Motor) -> Motor:
    """The motor a reserve is judged on: over a tolerance box, the worst case (weakest
    curve, largest friction plus load: profiles.motor.tolerance.worst_case_motor)."""
    if not motor.tolerances:
        return motor
    from .tolerance import worst_case_motor

    return worst_case_motor(motor)
