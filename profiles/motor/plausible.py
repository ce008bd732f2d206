"""Plausible motor values: the ranges every stepper motor's datasheet lies in, so a value
typed in the wrong unit (henries as mH, N·cm as N·m, kg·m² as g·cm²) is refused before it
becomes a confident answer (issue 32 item 3).

The ranges (docs/manual-notes.md, "Plausible motors", cites the datasheets): wide enough
for every stepper from a micro can-stack to a NEMA 42, a factor of several beyond the
extremes found, never a judgement of a real motor. Each problem is one line naming the
value as the user gave it: an option and its unit (`motor new`) or a motor file's JSON
pointer and its SI unit (`motor check`), and, when the value fits the range in another
unit of the same quantity, that unit ("N·cm typed as N·m? 59 N·cm = 0.59 N·m").

The loader (`Motor`) does not apply these: a file made by hand for a test rig still plans;
`motor new` and `motor check` refuse.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from .units import OZF_IN_NM

Problem = tuple[str, str]   # (where: an option or a JSON pointer, message)


@dataclass(frozen=True)
class Quantity:
    """A datasheet quantity: what it is, its SI unit, the range of every stepper's values
    (SI) and the units it is printed in (name → SI per unit), for naming a unit slip."""

    what: str
    si_unit: str
    lo: float
    hi: float
    units: tuple[tuple[str, float], ...]


TORQUE_UNITS = (("N·m", 1.0), ("N·cm", 1e-2), ("mN·m", 1e-3), ("oz·in", OZF_IN_NM))
QUANTITIES: dict[str, Quantity] = {
    "holding_torque_nm": Quantity("holding torque", "N·m", 1e-3, 50.0, TORQUE_UNITS),
    "rated_current_a": Quantity("rated current", "A", 0.05, 15.0, (("A", 1.0), ("mA", 1e-3))),
    "current_a": Quantity("drive current", "A", 0.05, 15.0, (("A", 1.0), ("mA", 1e-3))),
    "resistance_ohm": Quantity("phase resistance", "Ω", 0.05, 1000.0,
                               (("Ω", 1.0), ("mΩ", 1e-3), ("kΩ", 1e3))),
    "inductance_h": Quantity("phase inductance", "H", 5e-5, 0.5,
                             (("H", 1.0), ("mH", 1e-3), ("µH", 1e-6))),
    "rotor_inertia_kgm2": Quantity("rotor inertia", "kg·m²", 1e-9, 1e-2,
                                   (("kg·m²", 1.0), ("g·cm²", 1e-7), ("kg·cm²", 1e-4))),
    "supply_v": Quantity("supply voltage", "V", 1.0, 400.0, (("V", 1.0), ("mV", 1e-3))),
    # not a stepper's but its axis's: a 0.5 mm lead through a 500:1 gear (0.001 mm) to a
    # Ø1.6 m pulley (5000 mm)
    # (docs/manual-notes.md, "Real units"); the field is in mm, as screws and pulleys are
    "travel_mm_per_rev": Quantity("axis travel per motor revolution", "mm", 1e-3, 5000.0,
                                  (("mm", 1.0), ("m", 1e3), ("µm", 1e-3))),
}
# Holding (or standstill pull-out) torque per rotor inertia [rad/s²]: datasheets give
# 1.7e4 (a 5 N·m NEMA 23) to 1.1e5 (a 0.4 N·m NEMA 17); a slip of units in either value
# moves it by 100× or more.
TORQUE_PER_INERTIA = (3e3, 1e6)
# A pull-out curve starts at or under the holding torque (the two-phase-on value at the
# rated current); 1.5× leaves room for a drive set a little above the rating.
CURVE_OVER_HOLDING = 1.5


@dataclass(frozen=True)
class Label:
    """How the user gave a value: `name` (an option or a JSON pointer) in `unit`, `scale`
    of those units per SI unit (1e3 for mH)."""

    name: str
    unit: str
    scale: float = 1.0


def si_label(field: str) -> Label:
    """A motor file's field as its JSON pointer, in the field's SI unit."""
    return Label("/" + field, QUANTITIES[field].si_unit)


def value_problem(field: str, value_si: float, label: Label) -> str | None:
    """The one-line refusal of `value_si` for `field`, or None when it is plausible."""
    q = QUANTITIES[field]
    if math.isfinite(value_si) and q.lo <= value_si <= q.hi:
        return None
    shown = value_si * label.scale
    return (f"{label.name}: {_g(shown)} {label.unit} is outside any stepper's {q.what} "
            f"({_g(q.lo * label.scale)}..{_g(q.hi * label.scale)} {label.unit})"
            f"{slip_hint(q, shown, label)}")


def slip_hint(q: Quantity, shown: float, label: Label) -> str:
    """"; N·cm typed as N·m? 59 N·cm = 0.59 N·m" when `shown` (in the label's unit) fits
    the range read in another unit of the quantity; "" otherwise."""
    if not math.isfinite(shown) or shown <= 0:
        return ""
    for unit, si_per_unit in q.units:
        if math.isclose(si_per_unit * label.scale, 1.0) or unit == label.unit:
            continue  # the unit it was given in
        si = shown * si_per_unit
        if q.lo <= si <= q.hi:
            return (f"; {unit} typed as {label.unit}? {_g(shown)} {unit} = "
                    f"{_g(si * label.scale)} {label.unit}")
    return ""


def ratio_problem(torque_nm: float, inertia_kgm2: float, torque: Label,
                  inertia: Label) -> str | None:
    """A torque and a rotor inertia that no stepper pairs (one of them in another unit)."""
    if not (torque_nm > 0 and inertia_kgm2 > 0):
        return None
    ratio = torque_nm / inertia_kgm2
    lo, hi = TORQUE_PER_INERTIA
    if lo <= ratio <= hi:
        return None
    return (f"{torque.name} {_g(torque_nm * torque.scale)} {torque.unit} against "
            f"{inertia.name} {_g(inertia_kgm2 * inertia.scale)} {inertia.unit}: "
            f"{ratio:.2g} rad/s² of torque per inertia, where steppers' datasheets give "
            f"{lo:.0e}..{hi:.0e} (one of the two in another unit?)")


def curve_problem(curve_max_nm: float, holding_nm: float, curve: Label,
                  holding: Label) -> str | None:
    """A pull-out curve far above the holding torque (a torque unit slip in either)."""
    if not holding_nm > 0 or curve_max_nm <= CURVE_OVER_HOLDING * holding_nm:
        return None
    return (f"{curve.name}: pull-out torque up to {_g(curve_max_nm * curve.scale)} "
            f"{curve.unit} is {curve_max_nm / holding_nm:.3g}× the holding torque "
            f"{_g(holding_nm * holding.scale)} {holding.unit} ({holding.name}); a pull-out "
            f"curve stays under the holding torque (at most {CURVE_OVER_HOLDING:g}× allowed: "
            "check the torque unit)")


def overcurrent_problem(current_a: float, rated_a: float, current: str, rated: str,
                        allow: str) -> str | None:
    """A drive current above the motor's rating, unless the user says it is meant."""
    if current_a <= rated_a * (1 + 1e-9):
        return None
    return (f"{current}: {_g(current_a)} A is above the motor's rated {_g(rated_a)} A "
            f"({rated}): the motor overheats and its torque is not the datasheet's "
            f"({allow} if the datasheet allows it)")


def datasheet_problems(values: Mapping[str, float | None], labels: Mapping[str, Label], *,
                       allow_overcurrent: str | None = None) -> list[str]:
    """A datasheet's implausible values (`motor new`), each in one line naming its label:
    every value out of range (`values` in SI by QUANTITIES' field, None: not given), a drive
    current above the rated one (unless `allow_overcurrent`, the option that allows it,
    is None: then it is allowed), the holding torque against the rotor inertia."""
    out = [msg for field, v in values.items() if v is not None
           and (msg := value_problem(field, v, labels[field])) is not None]
    current, rated = values.get("current_a"), values.get("rated_current_a")
    if (not out and allow_overcurrent is not None and current is not None and rated is not None
            and (msg := overcurrent_problem(current, rated, labels["current_a"].name,
                                            labels["rated_current_a"].name,
                                            allow_overcurrent))):
        out.append(msg)
    holding, inertia = values.get("holding_torque_nm"), values.get("rotor_inertia_kgm2")
    if not out and holding is not None and inertia is not None and (msg := ratio_problem(
            holding, inertia, labels["holding_torque_nm"], labels["rotor_inertia_kgm2"])):
        out.append(msg)
    return out


def file_problems(obj: Mapping[str, Any]) -> list[Problem]:
    """A motor file's implausible values (`motor check`), each (JSON pointer, message
    without the pointer): its holding torque, its pull-out curve against the holding
    torque and against its inertia, its inertia below any rotor's. The file's inertia
    includes its load, so only its lower bound and the torque-per-inertia ceiling apply."""
    return [(where, msg.removeprefix(f"{where}: ")) for where, msg in _file_problems(obj)]


def _file_problems(obj: Mapping[str, Any]) -> list[Problem]:
    out: list[Problem] = []
    holding = obj.get("holding_torque_nm")
    if isinstance(holding, int | float):
        msg = value_problem("holding_torque_nm", float(holding), si_label("holding_torque_nm"))
        if msg:
            out.append(("/holding_torque_nm", msg))
    curve = [float(t) for _, t in obj["pullout_torque"]]
    top = max(curve)
    inertia = float(obj["inertia_kgm2"])
    curve_label = Label("/pullout_torque", "N·m")
    if isinstance(holding, int | float) and (msg := curve_problem(
            top, float(holding), curve_label, Label("/holding_torque_nm", "N·m"))):
        out.append(("/pullout_torque", msg))
    travel = obj.get("travel_mm_per_rev")
    if isinstance(travel, int | float) and (msg := value_problem(
            "travel_mm_per_rev", float(travel), si_label("travel_mm_per_rev"))):
        out.append(("/travel_mm_per_rev", msg))
    q = QUANTITIES["rotor_inertia_kgm2"]
    if inertia < q.lo:
        label = Label("/inertia_kgm2", "kg·m²")
        out.append(("/inertia_kgm2", f"/inertia_kgm2: {_g(inertia)} kg·m² is below any "
                    f"stepper's rotor alone ({_g(q.lo)} kg·m² = 0.01 g·cm²)"
                    f"{slip_hint(q, inertia, label)}"))
    elif curve[0] / inertia > TORQUE_PER_INERTIA[1] and (msg := ratio_problem(
            curve[0], inertia, Label("/pullout_torque/0/1", "N·m"),
            Label("/inertia_kgm2", "kg·m²"))):
        out.append(("/inertia_kgm2", msg))
    return out


def _g(x: float) -> str:
    return f"{x:.4g}"
