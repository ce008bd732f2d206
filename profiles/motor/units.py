"""Unit conversions at the edge: vendor curves and machine speeds to SI and pps, and back.

stepramp works in pulses per second (pps) of the driver's step input and N·m inside;
everything a user types in another unit is converted once, here.

Speed units of a vendor curve (`curve_speed_to_pps`):
    pps   pulses per second at the motor file's resolution (steps_per_rev, microsteps included)
    Hz    FULL steps per second. Vendors print "pulse rate [Hz]" or "[pps]" for a curve measured
          at the step mode they state; stepramp reads "Hz" as full steps/s and converts with the
          microstep factor, and reads "pps" as already being the motor file's own pulse rate.
    rps   revolutions per second
    rpm   revolutions per minute
Torque units: N·m, N·cm (most datasheets' and curves' unit; also Ncm, N.cm), mN·m, oz·in
(ounce-force inch), kgf·cm (also written kg·cm on datasheets).
"""

from __future__ import annotations

import math
import re

from ..errors import FieldRangeError, FormatError, echo

G_MPS2 = 9.80665                      # standard gravity (kgf definition)
OZF_IN_NM = 0.028349523125 * G_MPS2 * 0.0254   # 1 oz·in = 7.0615518e-3 N·m
KGF_CM_NM = G_MPS2 * 0.01             # 1 kgf·cm = 0.0980665 N·m

# canonical name → N·m per unit
TORQUE_UNITS: dict[str, float] = {"N·m": 1.0, "N·cm": 1e-2, "mN·m": 1e-3, "oz·in": OZF_IN_NM,
                                  "kgf·cm": KGF_CM_NM}
SPEED_UNITS = ("pps", "Hz", "rps", "rpm")
MACHINE_SPEED_UNITS = ("pps", "rps", "rpm", "mm/s", "m/s", "m/min")

_TORQUE_ALIASES = {"nm": "N·m", "ncm": "N·cm", "mnm": "mN·m", "ozin": "oz·in", "ozfin": "oz·in",
                   "kgfcm": "kgf·cm", "kgcm": "kgf·cm"}


def torque_unit(name: str) -> str:
    """The canonical torque unit for `name` (N·m, N.m, Nm, N·cm, Ncm, mNm, oz-in, kg·cm, …)."""
    key = re.sub(r"[\s·*.\-_]", "", name).lower()
    if key not in _TORQUE_ALIASES:
        raise FormatError(f"torque unit {echo(name)}: expected one of {', '.join(TORQUE_UNITS)}")
    return _TORQUE_ALIASES[key]


def speed_unit(name: str) -> str:
    """The canonical curve speed unit for `name` (case-insensitive: pps, Hz, rps, rpm)."""
    for unit in SPEED_UNITS:
        if name.strip().lower() == unit.lower():
            return unit
    raise FormatError(f"speed unit {echo(name)}: expected one of {', '.join(SPEED_UNITS)}")


def torque_to_nm(value: float, unit: str) -> float:
    return value * TORQUE_UNITS[torque_unit(unit)]


def nm_to_torque(value_nm: float, unit: str) -> float:
    return value_nm / TORQUE_UNITS[torque_unit(unit)]


def _pps_per(unit: str, steps_per_rev: int, microstep: int) -> float:
    """pps in one `unit` of a curve speed."""
    unit = speed_unit(unit)
    if unit == "pps":
        return 1.0
    if unit == "Hz":
        if microstep < 1:
            raise FieldRangeError("microstep", microstep, 1, 2**20)
        return float(microstep)
    per_rev = float(steps_per_rev)
    return per_rev if unit == "rps" else per_rev / 60.0


def curve_speed_to_pps(value: float, unit: str, *, steps_per_rev: int, microstep: int) -> float:
    """A vendor-curve speed in `unit` as pps of the motor file (see the module docstring)."""
    return value * _pps_per(unit, steps_per_rev, microstep)


def pps_to_curve_speed(speed_pps: float, unit: str, *, steps_per_rev: int,
                       microstep: int) -> float:
    return speed_pps / _pps_per(unit, steps_per_rev, microstep)


def _pps_per_machine(unit: str, steps_per_rev: int, mm_per_rev: float | None) -> float:
    """pps in one `unit` of machine speed (linear units need mm travelled per motor rev)."""
    if unit == "pps":
        return 1.0
    if unit == "rps":
        return float(steps_per_rev)
    if unit == "rpm":
        return steps_per_rev / 60.0
    mm_per_unit = {"mm/s": 1.0, "m/s": 1000.0, "m/min": 1000.0 / 60.0}.get(unit)
    if mm_per_unit is None:
        raise FormatError(f"speed unit {echo(unit)}: expected one of "
                          f"{', '.join(MACHINE_SPEED_UNITS)}")
    if mm_per_rev is None or not math.isfinite(mm_per_rev) or mm_per_rev <= 0:
        raise FormatError(f"a speed in {unit} needs the travel per motor revolution "
                          "(mm_per_rev > 0)")
    return mm_per_unit * steps_per_rev / mm_per_rev


def machine_to_pps(value: float, unit: str, *, steps_per_rev: int,
                   mm_per_rev: float | None = None) -> float:
    """A machine speed (pps, rps, rpm of the motor shaft; mm/s, m/s, m/min of the axis) as
    pps. `mm_per_rev` is the axis travel per MOTOR revolution (lead / gear ratio, or pulley
    circumference / gear ratio)."""
    return value * _pps_per_machine(unit, steps_per_rev, mm_per_rev)


def pps_to_machine(speed_pps: float, unit: str, *, steps_per_rev: int,
                   mm_per_rev: float | None = None) -> float:
    return speed_pps / _pps_per_machine(unit, steps_per_rev, mm_per_rev)
