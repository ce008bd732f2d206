"""Real units: pulses, pps and pps² as the axis moves them (issue 32 item 5), the one place
these conversions happen.

A motor file may state its axis's travel per motor revolution (`travel_mm_per_rev`: a lead
screw's lead, a belt pulley's π·d, divided by the gear ratio between; `stepramp motor new`
writes it from its `--load` specs). With it, a length is in mm, a speed in mm/s and an
acceleration in mm/s²; without it (a rotary axis) in motor revolutions, rpm and rev/s².

    mm      = pulses · travel_mm_per_rev / steps_per_rev
    rev     = pulses / steps_per_rev
    rpm     = pps · 60 / steps_per_rev

`AxisUnits` holds the factor and the labels (for text, "12.5 mm"; for JSON keys, the
suffix "mm", "mm_s", "mm_s2" or "rev", "rpm", "rev_s2"); `axis_units(motor)` makes it.
Physics stays in pulses: these only show it, and `pulses_of` turns a length a user typed
(`plan --distance-mm`) into pulses at the edge, once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..errors import FieldRangeError, FormatError

SECONDS_PER_MINUTE = 60.0


@dataclass(frozen=True)
class AxisUnits:
    """How one axis's pulses read in real units: mm when `mm_per_rev` is known, else motor
    revolutions."""

    steps_per_rev: int
    mm_per_rev: float | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.steps_per_rev, int) and self.steps_per_rev >= 1):
            raise FieldRangeError("steps_per_rev", self.steps_per_rev, 1, 10_000_000)
        if self.mm_per_rev is not None and not (math.isfinite(self.mm_per_rev)
                                                and self.mm_per_rev > 0):
            raise FieldRangeError("travel_mm_per_rev (0 excluded)", self.mm_per_rev, 0, 1e6)

    @property
    def linear(self) -> bool:
        """True when lengths are in mm (the motor file states its travel)."""
        return self.mm_per_rev is not None

    @property
    def per_pulse(self) -> float:
        """One pulse in the distance unit: mm or rev."""
        per_rev = 1.0 if self.mm_per_rev is None else self.mm_per_rev
        return per_rev / self.steps_per_rev

    # --- labels -----------------------------------------------------------------------
    @property
    def distance_unit(self) -> str:
        return "mm" if self.linear else "rev"

    @property
    def speed_unit(self) -> str:
        return "mm/s" if self.linear else "rpm"

    @property
    def accel_unit(self) -> str:
        return "mm/s²" if self.linear else "rev/s²"

    @property
    def distance_key(self) -> str:
        """The suffix of a JSON key holding a distance: `move_mm`, `move_rev`."""
        return "mm" if self.linear else "rev"

    @property
    def speed_key(self) -> str:
        return "mm_s" if self.linear else "rpm"

    @property
    def accel_key(self) -> str:
        return "mm_s2" if self.linear else "rev_s2"

    # --- conversions (floats or numpy arrays alike) -------------------------------------
    def distance(self, pulses: Any) -> Any:
        """Pulses as mm (or rev)."""
        return pulses * self.per_pulse

    def speed(self, speed_pps: Any) -> Any:
        """pps as mm/s (or rpm)."""
        return speed_pps * (self.per_pulse if self.linear
                            else self.per_pulse * SECONDS_PER_MINUTE)

    def accel(self, accel_pps2: Any) -> Any:
        """pps² as mm/s² (or rev/s²)."""
        return accel_pps2 * self.per_pulse

    def pulses(self, distance: Any) -> Any:
        """A distance in mm (or rev) as pulses, unrounded: `distance`'s inverse."""
        return distance / self.per_pulse

    def speed_pps(self, speed: Any) -> Any:
        """A speed in mm/s (or rpm) as pps: `speed`'s inverse."""
        return speed / (self.per_pulse if self.linear
                        else self.per_pulse * SECONDS_PER_MINUTE)

    def accel_pps2(self, accel: Any) -> Any:
        """An acceleration in mm/s² (or rev/s²) as pps²: `accel`'s inverse."""
        return accel / self.per_pulse

    # --- text -------------------------------------------------------------------------
    def distance_text(self, pulses: float) -> str:
        """"12.5 mm" (4 significant digits)."""
        return f"{self.distance(pulses):.4g} {self.distance_unit}"

    def speed_text(self, speed_pps: float) -> str:
        return f"{self.speed(speed_pps):.4g} {self.speed_unit}"

    def accel_text(self, accel_pps2: float) -> str:
        return f"{self.accel(accel_pps2):.4g} {self.accel_unit}"

    def describe(self) -> str:
        """"8 mm/rev, 1600 pulses/rev: 0.005 mm per pulse", or the rotary equivalent."""
        if self.mm_per_rev is None:
            return f"rotary: {self.steps_per_rev} pulses/rev (no travel_mm_per_rev)"
        return (f"{self.mm_per_rev:.6g} mm/rev, {self.steps_per_rev} pulses/rev: "
                f"{self.per_pulse:.4g} mm per pulse")


def axis_units(motor: Any) -> AxisUnits:
    """The real units of a `Motor` (anything with `steps_per_rev` and
    `travel_mm_per_rev`)."""
    return AxisUnits(int(motor.steps_per_rev), getattr(motor, "travel_mm_per_rev", None))


@dataclass(frozen=True)
class Rounded:
    """A distance turned into whole pulses: the pulses, the distance they travel and the
    distance asked for (equal when `exact`)."""

    pulses: int
    distance: float
    asked: float
    unit: str

    @property
    def exact(self) -> bool:
        return math.isclose(self.distance, self.asked, rel_tol=1e-9, abs_tol=1e-12)

    def note(self, flag: str) -> str:
        """What the rounding did, in one line ("" when exact)."""
        if self.exact:
            return ""
        return (f"{flag} {self.asked:g} {self.unit} is {self.pulses} pulses (rounded to the "
                f"nearest pulse): {self.distance:.6g} {self.unit}, "
                f"{self.distance - self.asked:+.3g} {self.unit}")


def pulses_of(units: AxisUnits, distance: float, *, flag: str, lo_pulses: int,
              hi_pulses: int) -> Rounded:
    """A length the user typed after `flag` (in `units`' distance unit: mm, or rev when
    the flag is a rotary one) as the nearest whole number of pulses in [lo, hi]; refused in
    one line naming the flag, the value, its unit and the range in that unit."""
    unit = units.distance_unit
    if not math.isfinite(distance):
        raise FormatError(f"{flag}: {distance} {unit} is not a finite length")
    pulses = round(units.pulses(distance))
    if not lo_pulses <= pulses <= hi_pulses:
        lo, hi = units.distance(lo_pulses), units.distance(hi_pulses)
        raise FormatError(f"{flag}: {distance:g} {unit} is {units.pulses(distance):.6g} "
                          f"pulses, outside {lo_pulses}..{hi_pulses} pulses "
                          f"({lo:.6g}..{hi:.6g} {unit} at "
                          f"{units.per_pulse:.6g} {unit} per pulse)")
    return Rounded(int(pulses), float(units.distance(pulses)), float(distance), unit)
