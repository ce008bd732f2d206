"""A motor file from a datasheet: the pull-out curve from an electrical model.

The model (per phase, sinusoidal currents, m phases, Nr electrical periods per rev):

    K_T = T_h / (√2·I_r)     torque per ampere of phase-current amplitude. The holding torque
                              of a datasheet is measured with two phases on at the rated current,
                              a current vector of amplitude √2·I_r (2-phase), so a microstepping
                              drive at I_r RMS (amplitude √2·I_r) gives T_h at standstill.
    k_e = 2·K_T/m            back-EMF amplitude per phase per rad/s (power balance:
                              T·ω = (m/2)·e·I; for 2 phases k_e = K_T, the "√2 convention")
    I_cmd = √2·I_set          the drive's current setting is RMS per phase
    ω_e = Nr·ω                electrical angular speed, ω the shaft speed in rad/s

The drive puts at most the supply voltage V across a phase (amplitude). Against the winding's
impedance Z = R + jω_e·L and the back-EMF E = k_e·ω, whatever the phase between them,
|I·Z + E| ≤ |I|·|Z| + |E| (triangle inequality), so the drive always reaches at least

    I_V(ω) = (V − k_e·ω) / √(R² + (ω_e·L)²)
    T(ω)   = K_T · min(I_cmd, max(I_V(ω), 0))       (0 once k_e·ω ≥ V)

This is a LOWER BOUND of the ideal circuit's pull-out torque (the current actually reached
depends on the load angle and is higher), the first-order formula of REFERENCES.md. Against
printed vendor curves (docs/manual-notes.md, tests/profiles/motor/test_datasheet.py) it lies
below every point, by 8–100 %: safe, pessimistic at high speed. Use a vendor curve
(`--curve`) when one exists. At standstill T = T_h·I_set/I_r. No detent torque,
saturation, iron losses or mid-band resonance are modelled.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import FieldRangeError, FormatError, echo, is_number, require_int
from .loads import ASSUMED, Contribution, combine
from .model import FORMAT

SQRT2 = math.sqrt(2.0)


@dataclass(frozen=True)
class Datasheet:
    """What a stepper motor's datasheet gives (SI units)."""
    step_angle_deg: float
    holding_torque_nm: float
    rated_current_a: float           # per phase, RMS (the datasheet's "rated current")
    resistance_ohm: float            # per phase
    inductance_h: float              # per phase
    rotor_inertia_kgm2: float
    phases: int = 2
    detent_torque_nm: float = 0.0
    rotor_teeth: int | None = None   # electrical periods per rev; None: from step angle
    name: str = ""

    def __post_init__(self) -> None:
        if self.phases not in (2, 3, 4, 5):
            raise FieldRangeError("phases", self.phases, 2, 5)
        _pos("step_angle_deg", self.step_angle_deg, 90)
        _pos("holding_torque_nm", self.holding_torque_nm, 1e4)
        _pos("rated_current_a", self.rated_current_a, 1e3)
        _pos("resistance_ohm", self.resistance_ohm, 1e4)
        _pos("inductance_h", self.inductance_h, 10)
        _pos("rotor_inertia_kgm2", self.rotor_inertia_kgm2, 1e3)
        if not 0 <= self.detent_torque_nm < self.holding_torque_nm:
            raise FieldRangeError("detent_torque_nm", self.detent_torque_nm, 0,
                                  self.holding_torque_nm)
        full_steps_per_rev(self.step_angle_deg)
        if self.rotor_teeth is not None:
            _pos("rotor_teeth", self.rotor_teeth, 10_000)

    @property
    def full_steps_per_rev(self) -> int:
        return full_steps_per_rev(self.step_angle_deg)

    @property
    def electrical_periods_per_rev(self) -> int:
        """Nr: an electrical period is 2·phases full steps (4 for 2-phase, 10 for 5-phase)."""
        return electrical_periods(self.step_angle_deg, self.phases, self.rotor_teeth)

    @property
    def torque_constant_nm_per_a(self) -> float:
        """K_T = T_h/(√2·I_r): N·m per ampere of phase-current amplitude."""
        return self.holding_torque_nm / (SQRT2 * self.rated_current_a)

    @property
    def back_emf_v_s_per_rad(self) -> float:
        """k_e = 2·K_T/m: peak back-EMF of one phase per rad/s of the shaft."""
        return 2 * self.torque_constant_nm_per_a / self.phases


def full_steps_per_rev(step_angle_deg: float) -> int:
    _pos("step_angle_deg", step_angle_deg, 90)
    fs = 360.0 / step_angle_deg
    if abs(fs - round(fs)) > 1e-6:
        raise FormatError(f"step_angle_deg: {step_angle_deg} does not divide 360°")
    return round(fs)


def electrical_periods(step_angle_deg: float, phases: int, rotor_teeth: int | None) -> int:
    if rotor_teeth is not None:
        return rotor_teeth
    return max(1, round(full_steps_per_rev(step_angle_deg) / (2 * phases)))


MICROSTEP_MAX = 1024  # microsteps per full step a driver setting may have
MIN_FRACTION = 0.05   # the model's curve ends where the torque falls to this share of T(0)
# A curve whose top is slower than this has no usable speed (and its points, written to
# 0.001 pps, would collapse onto each other): the supply cannot drive the back-EMF.
MIN_TOP_PPS = 40.0


@dataclass(frozen=True)
class Drive:
    """The driver's settings: supply voltage, current setting (RMS per phase), microsteps."""
    supply_v: float
    current_a: float
    microstep: int = 1

    def __post_init__(self) -> None:
        _pos("supply_v", self.supply_v, 1e4)
        _pos("current_a", self.current_a, 1e3)
        require_int("microstep", self.microstep, 1, MICROSTEP_MAX)


def _pos(name: str, value: float, hi: float) -> None:
    if not (isinstance(value, int | float) and math.isfinite(value) and 0 < value <= hi):
        raise FieldRangeError(name + " (0 excluded)", value, 0, hi)


def pullout_torque_nm(ds: Datasheet, drive: Drive, speed_rad_s: np.ndarray | float) -> np.ndarray:
    """The model's pull-out torque [N·m] at shaft speeds [rad/s] (see the module docstring)."""
    w = np.abs(np.asarray(speed_rad_s, dtype=float))
    x = ds.electrical_periods_per_rev * w * ds.inductance_h      # ω_e·L
    i_v = (drive.supply_v - ds.back_emf_v_s_per_rad * w) / np.hypot(ds.resistance_ohm, x)
    i = np.minimum(SQRT2 * drive.current_a, np.maximum(i_v, 0.0))
    return np.asarray(ds.torque_constant_nm_per_a * i)


def speed_rad_s(speed_pps: np.ndarray | float, steps_per_rev: int) -> np.ndarray:
    return np.asarray(speed_pps, dtype=float) * (2 * math.pi / steps_per_rev)


def pullout_curve(ds: Datasheet, drive: Drive, *, min_fraction: float = MIN_FRACTION,
                  tolerance: float = 0.002, dense: int = 4001) -> tuple[np.ndarray, np.ndarray]:
    """(speeds [pps], torques [N·m]) of the model as a piecewise-linear curve that never lies
    above the model: from 0 to the speed where the torque falls to `min_fraction` of its
    standstill value (the curve's last point, the top usable speed), with as few points as
    keep the gap below `tolerance` × T(0). Linear interpolation of a convex stretch lies above
    the curve, so every segment is lowered by its largest excess."""
    if not 0 < min_fraction < 1:
        raise FieldRangeError("min_fraction (0, 1 excluded)", min_fraction, 0, 1)
    spr = ds.full_steps_per_rev * drive.microstep
    t0 = float(pullout_torque_nm(ds, drive, 0.0))
    # the speed where E = V bounds the search: past it the torque is 0
    w_max = drive.supply_v / ds.back_emf_v_s_per_rad
    lo, hi = 0.0, w_max
    for _ in range(100):   # bisection: T is non-increasing in speed
        mid = 0.5 * (lo + hi)
        if float(pullout_torque_nm(ds, drive, mid)) > min_fraction * t0:
            lo = mid
        else:
            hi = mid
    w_end = lo
    w = np.linspace(0.0, w_end, dense)
    t = pullout_torque_nm(ds, drive, w)
    keep = _breakpoints(w, t, tolerance * t0)
    wk, tk = w[keep], t[keep].copy()
    for k in range(len(keep) - 1):   # lower each chord onto the curve, checked finely
        wa, wb = w[keep[k]], w[keep[k + 1]]
        fine = np.linspace(wa, wb, 4001)
        chord = np.interp(fine, [wa, wb], [tk[k], tk[k + 1]])
        excess = float(np.max(chord - pullout_torque_nm(ds, drive, fine)))
        if excess > 0:   # + a hair for what lies between the fine samples
            lower = excess + 1e-9 * t0
            tk[k] -= lower
            tk[k + 1] -= lower
    speeds = wk * spr / (2 * math.pi)
    return speeds, np.maximum(tk, 0.0)


def _breakpoints(x: np.ndarray, y: np.ndarray, tol: float) -> list[int]:
    """Greedy: from each breakpoint, the farthest next one (binary search) whose chord stays
    within tol of the samples in between."""
    def fits(i: int, j: int) -> bool:
        chord = np.interp(x[i:j + 1], [x[i], x[j]], [y[i], y[j]])
        return float(np.max(np.abs(chord - y[i:j + 1]))) <= tol

    keep = [0]
    i, n = 0, len(x)
    while i < n - 1:
        lo, hi = i + 1, n - 1
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if fits(i, mid):
                lo = mid
            else:
                hi = mid - 1
        keep.append(lo)
        i = lo
    return keep


def start_pps_estimate(torque_nm: float, inertia_kgm2: float, opposing_nm: float,
                       steps_per_rev: int, full_step_rad: float) -> float:
    """The fastest jump from rest a rotor follows within half a full step of lag (the project's
    stall criterion): accelerating at a = (T − opposing)/J, a lag of ω²/(2a) builds while it
    catches up with ω, so ω ≤ √(2·a·½·full step)."""
    a = (torque_nm - opposing_nm) / inertia_kgm2
    if a <= 0:
        raise FormatError("the motor cannot start: the usable torque at rest does not exceed "
                          "friction plus load torque")
    return math.sqrt(a * full_step_rad) * steps_per_rev / (2 * math.pi)


def motor_from_datasheet(ds: Datasheet, drive: Drive, loads: Sequence[Contribution] = (), *,
                         safety_factor: float = 0.6, start_pps: float | None = None,
                         name: str = "") -> dict[str, object]:
    """A `stepramp.motor/1` object with the model's pull-out curve at the drive's settings
    (see `motor_object` for the rest)."""
    speeds, torques = pullout_curve(ds, drive)
    if speeds[-1] < MIN_TOP_PPS:  # rounded to the file's 0.001 pps, the curve would collapse
        # The back-EMF eats the supply at once; the top speed grows about in proportion to
        # the voltage, so the bound is where it would reach MIN_TOP_PPS (no dots in the
        # field's note: the CLI reads the field's last dotted part).
        need = drive.supply_v * MIN_TOP_PPS / max(float(speeds[-1]), 1e-300)
        raise FieldRangeError("supply_v (no usable speed below it, for this back-EMF)",
                              drive.supply_v, float(f"{need:.3g}"), 1e4)
    obj = motor_object(
        speeds, torques, Mechanics(ds.step_angle_deg, ds.rotor_inertia_kgm2, ds.phases,
                                   ds.detent_torque_nm, ds.rotor_teeth),
        drive.microstep, loads, safety_factor=safety_factor, start_pps=start_pps,
        name=name or ds.name,
        curve_from=(f"model (profiles/datasheet.py): T_h {ds.holding_torque_nm:.4g} N·m at "
                    f"{ds.rated_current_a:.4g} A, R {ds.resistance_ohm:.4g} Ω, L "
                    f"{ds.inductance_h * 1e3:.4g} mH, {ds.phases} phases; drive "
                    f"{drive.supply_v:.4g} V, {drive.current_a:.4g} A RMS, "
                    f"1/{drive.microstep} step"), holding_torque_nm=ds.holding_torque_nm)
    return obj


@dataclass(frozen=True)
class Mechanics:
    """The mechanical half of a datasheet (all a vendor-curve motor needs besides its curve)."""
    step_angle_deg: float
    rotor_inertia_kgm2: float
    phases: int = 2
    detent_torque_nm: float = 0.0
    rotor_teeth: int | None = None

    def __post_init__(self) -> None:
        full_steps_per_rev(self.step_angle_deg)
        _pos("rotor_inertia_kgm2", self.rotor_inertia_kgm2, 1e3)
        if self.phases not in (2, 3, 4, 5):
            raise FieldRangeError("phases", self.phases, 2, 5)
        if not 0 <= self.detent_torque_nm < 1e4:
            raise FieldRangeError("detent_torque_nm", self.detent_torque_nm, 0, 1e4)


def motor_object(speeds: np.ndarray, torques: np.ndarray, mech: Mechanics, microstep: int,
                 loads: Sequence[Contribution] = (), *, safety_factor: float = 0.6,
                 start_pps: float | None = None, name: str = "", curve_from: str = "",
                 holding_torque_nm: float | None = None) -> dict[str, object]:
    """A `stepramp.motor/1` object from a pull-out curve (pps, N·m) and the motor's mechanics:
    the rotor plus `loads` (reflected to the shaft), detent torque counted as friction (it
    brakes a turning rotor; conservative), the self-start speed estimated when not given
    (`start_pps_estimate`, at most half the curve's top), the datasheet's holding torque
    when given, and where each number came from (`"sources"`). The safety factor and a
    given start speed are checked first, as given: the estimate and the file's rounding
    would otherwise blame another value."""
    if not (is_number(safety_factor, finite=True) and 0 < safety_factor <= 1):
        raise FieldRangeError("safety_factor", safety_factor, 0, 1, lo_excluded=True)
    top = float(speeds[-1])
    if start_pps is not None and not (is_number(start_pps, finite=True)
                                      and 0 < start_pps <= top):
        raise FieldRangeError("start_pps", start_pps, 0, round(top, 3), lo_excluded=True)
    spr = full_steps_per_rev(mech.step_angle_deg) * microstep
    contributions = [Contribution("inertia_kgm2", mech.rotor_inertia_kgm2,
                                  f"rotor (datasheet): {mech.rotor_inertia_kgm2:.4g}")]
    if mech.detent_torque_nm:
        contributions.append(Contribution(
            "friction_torque_nm", mech.detent_torque_nm,
            f"detent torque (datasheet): {mech.detent_torque_nm:.4g}"))
    totals = combine([*contributions, *loads])
    # friction resting on an assumption is planned over a range: the most where it slows
    # the ramps up, the least where it would help them stop (loads.py's docstring)
    friction_range = ([totals.friction_low_nm, totals.friction_torque_nm]
                      if totals.friction_low_nm < totals.friction_torque_nm else None)
    if start_pps is None:
        start_pps = start_pps_estimate(
            safety_factor * float(torques[0]), totals.inertia_kgm2,
            totals.friction_torque_nm + abs(totals.load_torque_nm), spr,
            math.radians(mech.step_angle_deg))
        start_pps = min(start_pps, float(speeds[-1]) / 2)
    obj: dict[str, object] = {"format": FORMAT}
    if name:
        obj["name"] = name
    obj.update(steps_per_rev=spr,
               pullout_torque=[[round(float(v), 3), round(float(t), 6)]
                               for v, t in zip(speeds, torques, strict=True)],
               inertia_kgm2=totals.inertia_kgm2, friction_torque_nm=totals.friction_torque_nm,
               safety_factor=safety_factor, start_pps=_round_pps(start_pps),
               rotor_teeth=electrical_periods(mech.step_angle_deg, mech.phases,
                                              mech.rotor_teeth))
    obj["phases"] = mech.phases
    if totals.load_torque_nm:
        obj["load_torque_nm"] = totals.load_torque_nm
    if holding_torque_nm is not None:
        obj["holding_torque_nm"] = holding_torque_nm
    obj["sources"] = {**totals.sources, "pullout_torque": [
        {"value": round(float(np.max(torques)), 6), "from": curve_from}]}
    if friction_range is not None:
        obj["tolerances"] = {"friction_torque_nm": friction_range}
    return obj


DETENT_SHARE_ASSUMED = 0.05  # of the holding torque: the low end of hybrid steppers' 5–10 %


def assumed_detent(holding_nm: float, what: str = "holding torque") -> Contribution:
    """The detent torque a datasheet that gives none is assumed to have (counted as
    friction, as a given one is; `low` 0: it may be less)."""
    value = DETENT_SHARE_ASSUMED * holding_nm
    return Contribution("friction_torque_nm", value,
                        f"detent torque ({ASSUMED}: {DETENT_SHARE_ASSUMED * 100:g} % of the "
                        f"{what} {holding_nm:.4g} N·m, the low end of a hybrid stepper's "
                        f"5–10 %; give --detent-torque-nm): {value:.4g}", low=0.0)


def _round_pps(speed: float) -> float:
    """A speed as the file writes it: to 0.001 pps, or to 6 digits below 1 pps (a slow
    start speed given as 1e-6 pps stays 1e-6, never 0)."""
    return round(speed, 3) if speed >= 1 else float(f"{speed:.6g}")


def curve_from_csv(text: str, *, speed_unit: str, torque_unit: str, steps_per_rev: int,
                   microstep: int, name: str = "curve") -> tuple[np.ndarray, np.ndarray]:
    """A vendor pull-out curve from CSV text (two columns: speed, torque in the declared units;
    a first line that is not numbers is a header; `#` starts a comment) as (pps, N·m), converted
    once here. A curve that starts above 0 gets a point at 0 with its first torque (vendors
    start their plots at a low speed; the motor file's curve starts at standstill)."""
    from .units import curve_speed_to_pps, torque_to_nm
    from .units import speed_unit as canon_speed
    from .units import torque_unit as canon_torque
    canon_speed(speed_unit)
    canon_torque(torque_unit)
    rows: list[tuple[float, float]] = []
    first = True
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        cells = [c.strip() for c in line.replace(";", ",").replace("\t", ",").split(",")]
        try:
            values = [float(c) for c in cells if c]
        except ValueError:
            if first:   # the header
                first = False
                continue
            raise FormatError(f"{name}: line {lineno}: expected two numbers, got {echo(raw)}") \
                from None
        first = False
        if len(values) != 2 or not all(math.isfinite(v) for v in values):
            raise FormatError(f"{name}: line {lineno}: expected two numbers, got {echo(raw)}")
        rows.append((values[0], values[1]))
    if len(rows) < 2:
        raise FormatError(f"{name}: needs at least two (speed, torque) rows")
    speeds = np.array([curve_speed_to_pps(s, speed_unit, steps_per_rev=steps_per_rev,
                                          microstep=microstep) for s, _ in rows])
    torques = np.array([torque_to_nm(t, torque_unit) for _, t in rows])
    if speeds[0] < 0 or np.any(np.diff(speeds) <= 0):
        raise FormatError(f"{name}: speeds must be ≥ 0 and strictly increase")
    if np.any(torques < 0):
        raise FormatError(f"{name}: torques must be ≥ 0")
    if speeds[0] > 0:
        speeds = np.concatenate([[0.0], speeds])
        torques = np.concatenate([[torques[0]], torques])
    return speeds, torques
