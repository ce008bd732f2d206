"""Loads reflected to the motor shaft: inertia, friction and load torque, with provenance.

Every builder returns `Contribution`s (field, value, where it came from) in the motor's
own terms (kg·m², N·m at the motor shaft); `combine` adds them up and keeps the list per
field for the motor file's `"sources"` object. Formulas (g = 9.80665 m/s²):

    disc / cylinder      J = m·(d² + d_i²)/8                      (d_i = 0: solid)
    lead screw           J = J_screw + m·(lead/2π)²,  J_screw = ρ·π·len·d⁴/32 (steel)
                         T_load = (m·g·sin θ + F)·lead/(2π·η)
                         T_fric = μ·m·g·cos θ·lead/(2π·η)
    belt and pulley      J = m·r² + J_pulleys,  T_load = (m·g·sin θ + F)·r/η,
                         T_fric = μ·m·g·cos θ·r/η
    gear (ratio n = motor revs per output rev, efficiency η): everything on its output side
                         J/n², T/(n·η); its own inertia (motor side) adds as is.

Sign of `load_torque_nm`: positive opposes motion in the positive direction (a weight
lifted by positive moves, incline θ > 0) and helps negative moves; friction always opposes.
The efficiency divides both directions (the lifting value, conservative when lowering).

Friction by default (issue 32 item 1; docs/manual-notes.md, "Friction by default"): a
value a spec leaves out is assumed from vendor sizing guides, never 0: a lead screw's
efficiency by kind (a trapezoidal/ACME sliding nut `LEAD_SCREW_EFFICIENCY`, a ball screw
`BALL_SCREW_EFFICIENCY`), a belt's and a gear's (`BELT_EFFICIENCY`, `GEAR_EFFICIENCY`), the
carriage's guide friction coefficient (`GUIDE_FRICTION_COEFF`) unless the friction at the
shaft is given (`friction_nm`). An assumed contribution says so in its source ("assumed")
and carries `low`, the least it can be (0 for an assumed coefficient; with η = 1 for an
assumed efficiency): friction helps a deceleration, so a motor file plans its friction
over [Σ low, Σ value] (its `tolerances`), the most where it slows the ramps up and the
least where it would help them stop.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from ..errors import FieldRangeError, FormatError, echo
from .units import G_MPS2

STEEL_KG_M3 = 7850.0
FIELDS = ("inertia_kgm2", "friction_torque_nm", "load_torque_nm")

# What a load spec leaves out is assumed from these (sources: docs/manual-notes.md,
# "Friction by default"); a value given replaces its assumption.
LEAD_SCREW_EFFICIENCY = 0.35  # trapezoidal/ACME screw, sliding nut: 25–40 % (vendor guides)
BALL_SCREW_EFFICIENCY = 0.9   # ball screw: 0.85–0.95 (Oriental Motor)
BELT_EFFICIENCY = 0.9         # timing belt and pulleys with their bearings
GEAR_EFFICIENCY = 0.9         # one gear stage (planetary: 0.9–0.97)
GUIDE_FRICTION_COEFF = 0.1    # a carriage's guide: rolling 0.002–0.02, dry plain 0.15–0.3
ASSUMED = "assumed"           # how an assumed value's source begins its note


@dataclass(frozen=True)
class Contribution:
    field: str          # one of FIELDS
    value: float        # in the field's unit, at the motor shaft
    source: str         # where it came from, in words and numbers
    # the least it can be when it rests on an assumption (None: as given); friction only
    low: float | None = None

    def to_json(self) -> dict[str, object]:
        return {"value": self.value, "from": self.source}

    @property
    def assumed(self) -> bool:
        return self.low is not None


@dataclass(frozen=True)
class Totals:
    inertia_kgm2: float
    friction_torque_nm: float
    load_torque_nm: float
    sources: dict[str, list[dict[str, object]]]
    # the least friction the contributions can give (their `low`s): below the total when
    # some rests on an assumption
    friction_low_nm: float = 0.0


def combine(contributions: Iterable[Contribution]) -> Totals:
    """Sum per field; `sources` lists every contribution of every field that has one."""
    sums = dict.fromkeys(FIELDS, 0.0)
    low = 0.0
    sources: dict[str, list[dict[str, object]]] = {}
    for c in contributions:
        sums[c.field] += c.value
        if c.field == "friction_torque_nm":
            low += c.value if c.low is None else c.low
        sources.setdefault(c.field, []).append(c.to_json())
    return Totals(sums["inertia_kgm2"], sums["friction_torque_nm"], sums["load_torque_nm"],
                  sources, min(low, sums["friction_torque_nm"]))


def _check(name: str, value: float, lo: float, hi: float, *, lo_open: bool = False) -> float:
    if not math.isfinite(value) or value < lo or value > hi or (lo_open and value == lo):
        raise FieldRangeError(name + (" (0 excluded)" if lo_open else ""), value, lo, hi)
    return value


def _g(x: float) -> str:
    return f"{x:.4g}"


# --- builders ----------------------------------------------------------------------------

def direct(inertia_kgm2: float = 0.0, friction_torque_nm: float = 0.0,
           load_torque_nm: float = 0.0, name: str = "direct") -> list[Contribution]:
    """Values already at the motor shaft (from a CAD model, a measurement, a datasheet)."""
    _check("inertia_kgm2", inertia_kgm2, 0, 1e3)
    _check("friction_torque_nm", friction_torque_nm, 0, 1e4)
    _check("load_torque_nm", load_torque_nm, -1e4, 1e4)
    out = []
    if inertia_kgm2:
        out.append(Contribution("inertia_kgm2", inertia_kgm2, f"{name}: {_g(inertia_kgm2)}"))
    if friction_torque_nm:
        out.append(Contribution("friction_torque_nm", friction_torque_nm,
                                f"{name}: {_g(friction_torque_nm)}"))
    if load_torque_nm:
        out.append(Contribution("load_torque_nm", load_torque_nm,
                                f"{name}: {_g(load_torque_nm)}"))
    return out


def disc(mass_kg: float, diameter_m: float, inner_diameter_m: float = 0.0,
         name: str = "disc") -> list[Contribution]:
    """A disc, solid cylinder (inner diameter 0) or tube on the shaft: J = m·(d² + d_i²)/8."""
    _check("mass_kg", mass_kg, 0, 1e4, lo_open=True)
    _check("diameter_m", diameter_m, 0, 10, lo_open=True)
    _check("inner_diameter_m", inner_diameter_m, 0, diameter_m)
    j = mass_kg * (diameter_m ** 2 + inner_diameter_m ** 2) / 8
    hole = f", bore {_g(inner_diameter_m * 1e3)} mm" if inner_diameter_m else ""
    return [Contribution("inertia_kgm2", j, f"{name}: {_g(mass_kg)} kg, Ø{_g(diameter_m * 1e3)} "
                         f"mm{hole}: m·(d²+d_i²)/8 = {_g(j)}")]


def lead_screw(lead_m: float, mass_kg: float, *, screw_inertia_kgm2: float | None = None,
               screw_diameter_m: float | None = None, screw_length_m: float | None = None,
               efficiency: float | None = None, incline_deg: float = 0.0,
               friction_coeff: float | None = None, friction_torque_nm: float | None = None,
               force_n: float = 0.0, ball: bool = False,
               name: str | None = None) -> list[Contribution]:
    """A carriage of `mass_kg` on a screw of `lead_m` per revolution (`ball`: a ball
    screw, else a trapezoidal/ACME lead screw); the screw's own inertia given, or from its
    size (solid steel), or left out (neither given). The efficiency and the guide's
    friction coefficient are assumed when not given (module docstring); `friction_torque_nm`
    gives the friction at the shaft instead of the coefficient."""
    name = name or ("ball screw" if ball else "lead screw")
    _check("lead_m", lead_m, 0, 1, lo_open=True)
    _check("mass_kg", mass_kg, 0, 1e5)
    _check("incline_deg", incline_deg, -90, 90)
    _check("force_n", force_n, -1e6, 1e6)
    eta = _assume("efficiency", efficiency, BALL_SCREW_EFFICIENCY if ball
                  else LEAD_SCREW_EFFICIENCY,
                  "a ball screw's" if ball else "a trapezoidal lead screw's, sliding nut")
    if screw_inertia_kgm2 is not None and (screw_diameter_m or screw_length_m):
        raise FormatError(f"{name}: give the screw's inertia or its size, not both")
    out: list[Contribution] = []
    if screw_inertia_kgm2 is not None:
        _check("screw_inertia_kgm2", screw_inertia_kgm2, 0, 1e3)
        out.append(Contribution("inertia_kgm2", screw_inertia_kgm2,
                                f"{name}: screw {_g(screw_inertia_kgm2)} (given)"))
    elif screw_diameter_m is not None or screw_length_m is not None:
        if screw_diameter_m is None or screw_length_m is None:
            raise FormatError(f"{name}: the screw's size needs both diameter and length")
        _check("screw_diameter_m", screw_diameter_m, 0, 1, lo_open=True)
        _check("screw_length_m", screw_length_m, 0, 100, lo_open=True)
        j = STEEL_KG_M3 * math.pi * screw_length_m * screw_diameter_m ** 4 / 32
        out.append(Contribution("inertia_kgm2", j,
                                f"{name}: steel screw Ø{_g(screw_diameter_m * 1e3)} × "
                                f"{_g(screw_length_m * 1e3)} mm: ρ·π·len·d⁴/32 = {_g(j)}"))
    r = lead_m / (2 * math.pi)   # travel per radian
    return out + _linear(name, f"lead {_g(lead_m * 1e3)} mm", r, mass_kg, eta, incline_deg,
                         _friction(name, friction_coeff, friction_torque_nm), force_n,
                         "lead/2π")


def belt(pulley_diameter_m: float, mass_kg: float, *, pulley_inertia_kgm2: float = 0.0,
         efficiency: float | None = None, incline_deg: float = 0.0,
         friction_coeff: float | None = None, friction_torque_nm: float | None = None,
         force_n: float = 0.0, name: str = "belt") -> list[Contribution]:
    """A carriage (belt included in `mass_kg`) driven by a pulley of pitch diameter d; the
    efficiency and the guide's friction coefficient assumed when not given."""
    _check("pulley_diameter_m", pulley_diameter_m, 0, 10, lo_open=True)
    _check("mass_kg", mass_kg, 0, 1e5)
    _check("pulley_inertia_kgm2", pulley_inertia_kgm2, 0, 1e3)
    _check("incline_deg", incline_deg, -90, 90)
    _check("force_n", force_n, -1e6, 1e6)
    eta = _assume("efficiency", efficiency, BELT_EFFICIENCY,
                  "a timing belt's with its pulleys' bearings")
    out: list[Contribution] = []
    if pulley_inertia_kgm2:
        out.append(Contribution("inertia_kgm2", pulley_inertia_kgm2,
                                f"{name}: pulleys {_g(pulley_inertia_kgm2)} (given)"))
    return out + _linear(name, f"pulley Ø{_g(pulley_diameter_m * 1e3)} mm",
                         pulley_diameter_m / 2, mass_kg, eta, incline_deg,
                         _friction(name, friction_coeff, friction_torque_nm), force_n, "r")


@dataclass(frozen=True)
class Assumable:
    """A value as given, or assumed (`why`: what it is assumed to be, "" when given)."""

    value: float
    why: str = ""

    def label(self, symbol: str) -> str:
        """`η = 0.35` or `η = 0.35 (assumed: a trapezoidal lead screw's)`."""
        return f"{symbol} = {_g(self.value)}" + (f" ({ASSUMED}: {self.why})" if self.why else "")


def _assume(field: str, given: float | None, default: float, why: str) -> Assumable:
    if given is None:
        return Assumable(default, why)
    _check(field, given, 0, 1, lo_open=True)
    return Assumable(given)


def _friction(name: str, coeff: float | None,
              torque_nm: float | None) -> Assumable | Contribution:
    """The guide's friction: the torque at the shaft as given, else the coefficient as
    given or assumed."""
    if torque_nm is not None:
        if coeff is not None:
            raise FormatError(f"{name}: give the guide's friction_coeff or the friction at "
                              "the shaft (friction_nm, friction_ncm), not both")
        _check("friction_torque_nm", torque_nm, 0, 1e4)
        return Contribution("friction_torque_nm", torque_nm,
                            f"{name}: friction at the shaft {_g(torque_nm)} (given)")
    if coeff is None:
        return Assumable(GUIDE_FRICTION_COEFF, "rolling guides 0.002–0.02, dry plain ones "
                                               "0.15–0.3: give friction_coeff")
    _check("friction_coeff", coeff, 0, 2)
    return Assumable(coeff)


def _linear(name: str, what: str, r: float, mass_kg: float, eta: Assumable,
            incline_deg: float, friction: Assumable | Contribution, force_n: float,
            r_name: str) -> list[Contribution]:
    """A mass moving r metres per radian of the shaft: inertia, gravity, friction (a
    coefficient, or the torque at the shaft as given)."""
    out = []
    if mass_kg:
        j = mass_kg * r * r
        out.append(Contribution("inertia_kgm2", j, f"{name}: {_g(mass_kg)} kg, {what}: "
                                f"m·({r_name})² = {_g(j)}"))
    theta = math.radians(incline_deg)
    lift_n = mass_kg * G_MPS2 * math.sin(theta) + force_n
    if lift_n:
        # an assumed efficiency makes |T_L| larger: conservative both ways, no range
        t = lift_n * r / eta.value
        parts = []
        if mass_kg * math.sin(theta):
            parts.append(f"m·g·sin({_g(incline_deg)}°)")
        if force_n:
            parts.append(f"{_g(force_n)} N")
        force = parts[0] if len(parts) == 1 else f"({' + '.join(parts)})"
        out.append(Contribution("load_torque_nm", t, f"{name}: {force}·{r_name}/η"
                                f", {eta.label('η')}: {_g(t)}"))
    if isinstance(friction, Contribution):
        return [*out, friction]
    t = friction.value * mass_kg * G_MPS2 * math.cos(theta) * r / eta.value
    if t > 1e-15:  # cos 90° is 6e-17, not 0: a vertical axis has no guide load
        # the least it can be: nothing from an assumed coefficient, η = 1 for an assumed η
        low = 0.0 if friction.why else t * eta.value if eta.why else None
        out.append(Contribution("friction_torque_nm", t,
                                f"{name}: μ·m·g·cos θ·{r_name}/η, {friction.label('μ')}, "
                                f"{eta.label('η')}: {_g(t)}", low))
    return out


def through_gear(ratio: float, downstream: Sequence[Contribution], *,
                 efficiency: float | None = None, gear_inertia_kgm2: float = 0.0,
                 name: str = "gear") -> list[Contribution]:
    """Reflect the output-side contributions through a gear of `ratio` motor revs per output
    rev: inertia / n², torques / (n·η) (η assumed when not given); the gear's own
    (motor-side) inertia adds as is."""
    _check("ratio", ratio, 0, 1e6, lo_open=True)
    eta = _assume("efficiency", efficiency, GEAR_EFFICIENCY, "one gear stage")
    _check("gear_inertia_kgm2", gear_inertia_kgm2, 0, 1e3)
    out = []
    if gear_inertia_kgm2:
        out.append(Contribution("inertia_kgm2", gear_inertia_kgm2,
                                f"{name}: own inertia {_g(gear_inertia_kgm2)}"))
    for c in downstream:
        low = None
        if c.field == "inertia_kgm2":
            value, how = c.value / ratio ** 2, f"/{_g(ratio)}²"
        else:
            value = c.value / (ratio * eta.value)
            how = f"/({_g(ratio)}·{_g(eta.value)}{f' {ASSUMED}' if eta.why else ''})"
            if c.field == "friction_torque_nm" and (c.assumed or eta.why):
                base = c.value if c.low is None else c.low
                low = base / (ratio * (1.0 if eta.why else eta.value))
        out.append(Contribution(c.field, value, f"{c.source} → {name} {how} = {_g(value)}",
                                low))
    return out


# --- the CLI's load specs ----------------------------------------------------------------

# kind → {key: (builder argument, factor to SI)}
_KEYS: dict[str, dict[str, tuple[str, float]]] = {
    "inertia": {"j_kgm2": ("inertia_kgm2", 1.0), "friction_nm": ("friction_torque_nm", 1.0),
                "load_torque_nm": ("load_torque_nm", 1.0),
                # N·cm, as datasheets print torque (issue 32 item 3)
                "friction_ncm": ("friction_torque_nm", 1e-2),
                "load_torque_ncm": ("load_torque_nm", 1e-2)},
    "disc": {"mass_kg": ("mass_kg", 1.0), "diameter_mm": ("diameter_m", 1e-3),
             "inner_diameter_mm": ("inner_diameter_m", 1e-3)},
    "screw": {"lead_mm": ("lead_m", 1e-3), "mass_kg": ("mass_kg", 1.0),
              "screw_inertia_kgm2": ("screw_inertia_kgm2", 1.0),
              "screw_diameter_mm": ("screw_diameter_m", 1e-3),
              "screw_length_mm": ("screw_length_m", 1e-3), "efficiency": ("efficiency", 1.0),
              "incline_deg": ("incline_deg", 1.0), "friction_coeff": ("friction_coeff", 1.0),
              "friction_nm": ("friction_torque_nm", 1.0),
              "friction_ncm": ("friction_torque_nm", 1e-2), "force_n": ("force_n", 1.0)},
    "belt": {"pulley_diameter_mm": ("pulley_diameter_m", 1e-3), "mass_kg": ("mass_kg", 1.0),
             "pulley_inertia_kgm2": ("pulley_inertia_kgm2", 1.0),
             "efficiency": ("efficiency", 1.0), "incline_deg": ("incline_deg", 1.0),
             "friction_coeff": ("friction_coeff", 1.0),
             "friction_nm": ("friction_torque_nm", 1.0),
             "friction_ncm": ("friction_torque_nm", 1e-2), "force_n": ("force_n", 1.0)},
    "gear": {"ratio": ("ratio", 1.0), "efficiency": ("efficiency", 1.0),
             "inertia_kgm2": ("gear_inertia_kgm2", 1.0)},
}
_KEYS["ballscrew"] = _KEYS["screw"]   # the same keys; its efficiency assumed higher
_REQUIRED_KEYS = {"inertia": set(), "disc": {"mass_kg", "diameter_mm"},
                  "screw": {"lead_mm", "mass_kg"}, "ballscrew": {"lead_mm", "mass_kg"},
                  "belt": {"pulley_diameter_mm", "mass_kg"}, "gear": {"ratio"}}
# Millimetre keys and the range of every real part (a lead in metres typed as mm is 0.008,
# not 8): docs/manual-notes.md, "Plausible motors".
PLAUSIBLE_MM = {"lead_mm": ("lead screw's lead", 0.1, 500.0),
                "pulley_diameter_mm": ("belt pulley's pitch diameter", 3.0, 1000.0),
                "screw_diameter_mm": ("lead screw's diameter", 1.0, 200.0)}
_ALIASES = {"cylinder": "disc", "leadscrew": "screw", "lead_screw": "screw", "pulley": "belt",
            "ball_screw": "ballscrew"}
LOAD_HELP = ("KIND:key=value,…  KIND: inertia (j_kgm2, friction_nm | friction_ncm, "
             "load_torque_nm | load_torque_ncm); "
             "disc|cylinder (mass_kg, diameter_mm, inner_diameter_mm); screw (a trapezoidal/"
             "ACME lead screw) or ballscrew (lead_mm, mass_kg, screw_inertia_kgm2 | "
             "screw_diameter_mm + screw_length_mm, efficiency, incline_deg [90 = vertical, up "
             "is positive], friction_coeff | friction_nm | friction_ncm, force_n); belt "
             "(pulley_diameter_mm, mass_kg, pulley_inertia_kgm2, efficiency, incline_deg, "
             "friction_coeff | friction_nm | friction_ncm, force_n); gear (ratio = motor revs "
             "per output rev, efficiency, inertia_kgm2): loads given after a gear sit on its "
             "output side. An efficiency or friction left out is assumed (said, and written "
             "with its source)")


def parse_load(spec: str) -> tuple[str, dict[str, float]]:
    """`KIND:key=value,…` → (kind, builder keyword arguments in SI)."""
    kind, _, rest = spec.partition(":")
    kind = _ALIASES.get(kind.strip().lower(), kind.strip().lower())
    if kind not in _KEYS:
        raise FormatError(f"load {echo(spec)}: unknown kind {echo(kind)} (expected one of "
                          f"{', '.join(_KEYS)}, cylinder)")
    args: dict[str, float] = {}
    seen = set()
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, text = item.partition("=")
        key = key.strip()
        if not eq or key not in _KEYS[kind]:
            raise FormatError(f"load {echo(spec)}: {echo(item)} is not one of "
                              f"{', '.join(k + '=…' for k in _KEYS[kind])}")
        try:
            value = float(text)
        except ValueError:
            raise FormatError(f"load {echo(spec)}: {key}: {echo(text)} is not a number") from None
        _refuse_implausible_mm(spec, key, value)
        arg, factor = _KEYS[kind][key]
        if arg in args:  # a key twice, or the N·m and N·cm keys of one value
            raise FormatError(f"load {echo(spec)}: {key} gives a value given already (one "
                              "key per value)")
        args[arg] = value * factor
        seen.add(key)
    missing = _REQUIRED_KEYS[kind] - seen
    if missing:
        raise FormatError(f"load {echo(spec)}: missing {', '.join(sorted(missing))}")
    return kind, args


def _refuse_implausible_mm(spec: str, key: str, value: float) -> None:
    """A millimetre value no such part has, named with its unit (and metres, when the
    value read in metres fits)."""
    if key not in PLAUSIBLE_MM:
        return
    what, lo, hi = PLAUSIBLE_MM[key]
    if math.isfinite(value) and lo <= value <= hi:
        return
    hint = (f"; m typed as mm? {value:g} m = {value * 1e3:g} mm"
            if lo <= value * 1e3 <= hi else "")
    raise FormatError(f"load {echo(spec)}: {key}: {value:g} mm is outside any {what} "
                      f"({lo:g}..{hi:g} mm){hint}")


def loads_from_specs(specs: Sequence[str]) -> list[Contribution]:
    """The contributions of CLI load specs, in order; a `gear` reflects every load given
    after it (gears after gears multiply)."""
    parsed = [parse_load(s) for s in specs]

    def build(i: int) -> list[Contribution]:
        out: list[Contribution] = []
        for j in range(i, len(parsed)):
            kind, args = parsed[j]
            if kind == "gear":
                return out + through_gear(args["ratio"], build(j + 1),
                                          efficiency=args.get("efficiency"),
                                          gear_inertia_kgm2=args.get("gear_inertia_kgm2", 0.0))
            builder: Callable[..., list[Contribution]] = _BUILDERS[kind]
            out += builder(**args)
        return out

    return build(0)


_BUILDERS: dict[str, Callable[..., list[Contribution]]] = {
    "inertia": direct, "disc": disc, "screw": lead_screw,
    "ballscrew": functools.partial(lead_screw, ball=True), "belt": belt}


def friction_warning(friction_nm: float, friction_high_nm: float) -> str | None:
    """The warning a motor without friction draws (`plan`, `check --motor`): every real
    axis has some (detent torque, bearings, a screw's nut, a guide), which accelerating
    needs torque for; a file saying 0 plans ramps the machine may not follow (the issue's
    4 000-pulse table was safe at 0 and slipped a pole at 0.032 N·m). `friction_high_nm`:
    the top of its tolerance range, when it has one."""
    if friction_nm > 0 or friction_high_nm > 0:
        return None
    return ("friction_torque_nm is 0: no detent, bearing, screw or guide friction, which a "
            "real axis has and accelerating needs torque for; give it, or its range in "
            "tolerances (`stepramp motor new` assumes it from the datasheet and the load)")


# --- the mechanism's travel (issue 32 item 5) --------------------------------------------

@dataclass(frozen=True)
class Mechanism:
    """A linear mechanism of the load specs: the axis travel per MOTOR revolution [mm]
    (a screw's lead or a pulley's π·d, divided by every gear ratio before it) and how."""

    travel_mm_per_rev: float
    source: str

    def to_json(self) -> dict[str, object]:
        return {"value": self.travel_mm_per_rev, "from": self.source}


def mechanisms_from_specs(specs: Sequence[str]) -> list[Mechanism]:
    """The linear mechanisms of CLI load specs (screws, ball screws, belts), in order, each
    through the gears given before it (their ratios multiply); none for rotary loads."""
    out: list[Mechanism] = []
    ratio, gears = 1.0, ""
    for kind, args in (parse_load(s) for s in specs):
        if kind == "gear":
            ratio *= args["ratio"]
            gears += f" / gear {_g(args['ratio'])}"
            continue
        if kind in ("screw", "ballscrew"):
            mm = args["lead_m"] * 1e3
            how = f"{'ball' if kind == 'ballscrew' else 'lead'} screw lead {_g(mm)} mm"
        elif kind == "belt":
            mm = math.pi * args["pulley_diameter_m"] * 1e3
            how = f"belt pulley π·Ø{_g(args['pulley_diameter_m'] * 1e3)} mm"
        else:
            continue
        out.append(Mechanism(mm / ratio, f"{how}{gears} = {_g(mm / ratio)} mm/rev"))
    return out
