"""Motor files (`stepramp.motor/1`) and the acceleration capability they give.

Capability (issue #3; load torque: docs/manual-notes.md, "Motor model"):
    a_acc(v) = (sf·T(v) − T_f − |T_L|) / J · steps_per_rev / 2π   [pps/s]
    a_dec(v) = (sf·T(v) + T_f − |T_L|) / J · steps_per_rev / 2π
with T(v) the pull-out torque, piecewise linear in speed; its last point is
the top usable speed. T_L (`load_torque_nm`, signed, > 0 opposes forward
motion) helps one direction and hinders the other; the chip runs one table
both ways, so the capability is the worse direction's. Everything here is SI
(speeds in pps, torque in N·m).
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import (
    FieldRangeError,
    FormatError,
    StepRampError,
    echo,
    is_number,
    require_int,
)
from ..reading import display_path, read_json

FORMAT = "stepramp.motor/1"
REQUIRED_KEYS = {"format", "steps_per_rev", "pullout_torque", "inertia_kgm2",
                 "safety_factor", "start_pps"}
OPTIONAL_KEYS = {"friction_torque_nm", "max_jump_pps", "max_pps", "max_jerk_pps3", "name",
                 "holding_torque_nm", "rotor_teeth", "phases", "damping_ratio",
                 "load_torque_nm", "sources", "tolerances", "resonance_bands_pps",
                 "travel_mm_per_rev"}
# Parameters a `tolerances` entry may range over (docs/manual-notes.md, "Tolerance box").
TOLERANCE_KEYS = ("inertia_kgm2", "friction_torque_nm", "load_torque_nm", "torque_scale",
                  "damping_ratio")
# Defaults where a motor file is silent (docs/manual-notes.md, "Load-angle model").
DEFAULT_PHASES = 2
DEFAULT_ROTOR_TEETH = 50        # the 1.8° (2-phase) and 0.72° (5-phase) hybrid rotor
DEFAULT_DAMPING_RATIO = 0.1
MAX_TORQUE_NM = 1e6
MAX_SPEED_PPS = 1e9
# The axis travel per motor revolution a file may state [mm] (physical bounds; `motor new`
# and `motor check` refuse the implausible: profiles/motor/plausible.py).
TRAVEL_MM_PER_REV_RANGE = (1e-6, 1e6)


@dataclass(frozen=True)
class Motor:
    steps_per_rev: int
    curve_speed_pps: np.ndarray = field(repr=False)
    curve_torque_nm: np.ndarray = field(repr=False)
    inertia_kgm2: float
    safety_factor: float
    start_pps: float
    friction_torque_nm: float = 0.0
    max_jump_pps: float | None = None
    max_pps: float | None = None
    max_jerk_pps3: float | None = None
    name: str = ""
    holding_torque_nm: float | None = None
    rotor_teeth: int | None = None
    phases: int = DEFAULT_PHASES
    damping_ratio: float = DEFAULT_DAMPING_RATIO
    load_torque_nm: float = 0.0
    # provenance: field → [{"value": number, "from": text}, …] (informative, never used)
    sources: dict[str, list[dict[str, Any]]] | None = field(default=None, repr=False,
                                                            compare=False)
    # absolute [low, high] per TOLERANCE_KEYS entry; the plain fields stay the nominal
    tolerances: tuple[tuple[str, float, float], ...] = ()
    # speeds [pps] where the machine resonates: closed intervals [lo, hi]
    resonance_bands_pps: tuple[tuple[float, float], ...] = ()
    # the axis travel per motor revolution [mm] (a screw's lead, a pulley's π·d, through
    # its gears): what `plan`, `show` and the figures give mm in (profiles/motor/travel.py);
    # None: a rotary axis, shown in rev and rpm. Never used by the physics.
    travel_mm_per_rev: float | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        v = np.asarray(self.curve_speed_pps, dtype=float)
        t = np.asarray(self.curve_torque_nm, dtype=float)
        v.setflags(write=False)
        t.setflags(write=False)
        object.__setattr__(self, "curve_speed_pps", v)
        object.__setattr__(self, "curve_torque_nm", t)
        if v.ndim != 1 or len(v) < 2 or len(v) != len(t):
            raise FormatError("pullout_torque: needs at least two [speed_pps, torque_nm] points")
        if v[0] != 0 or np.any(np.diff(v) <= 0):
            raise FormatError("pullout_torque: speeds must start at 0 and strictly increase")
        if np.any(t < 0) or not np.all(np.isfinite(t)):
            raise FormatError("pullout_torque: torques must be finite and ≥ 0")
        # physical bounds keep the capability's arithmetic finite (1e6 N·m, 1e9 pps)
        if np.any(t > MAX_TORQUE_NM) or v[-1] > MAX_SPEED_PPS:
            raise FormatError(f"pullout_torque: torques up to {MAX_TORQUE_NM:g} N·m and "
                              f"speeds up to {MAX_SPEED_PPS:g} pps")
        _positive("steps_per_rev", self.steps_per_rev, 1, 10_000_000)
        _positive("inertia_kgm2", self.inertia_kgm2, 1e-12, 1e3)
        if not 0 < self.safety_factor <= 1:
            raise FieldRangeError("safety_factor", self.safety_factor, 0, 1,
                                  lo_excluded=True)
        if not 0 <= self.friction_torque_nm < 1e4:
            raise FieldRangeError("friction_torque_nm", self.friction_torque_nm, 0, 1e4)
        _positive("start_pps", self.start_pps, 1e-9, self.top_curve_pps)
        for name in ("max_jump_pps", "max_pps", "max_jerk_pps3", "holding_torque_nm"):
            value = getattr(self, name)
            if value is not None:
                _positive(name, value, 1e-12, 1e18)
        require_int("phases", self.phases, 2, 10)
        if self.rotor_teeth is not None:
            require_int("rotor_teeth", self.rotor_teeth, 1, self.steps_per_rev)
        if not 0 <= self.damping_ratio <= 10:
            raise FieldRangeError("damping_ratio", self.damping_ratio, 0, 10)
        if not abs(self.load_torque_nm) < 1e4:
            raise FieldRangeError("load_torque_nm", self.load_torque_nm, -1e4, 1e4)
        if self.travel_mm_per_rev is not None:
            _positive("travel_mm_per_rev", self.travel_mm_per_rev, *TRAVEL_MM_PER_REV_RANGE)
        _check_tolerances(self)
        _check_bands(self.resonance_bands_pps)
        if self.a_acc_pps2(0.0) <= 0:
            raise FormatError("the motor cannot accelerate from rest: safety_factor × torque at "
                              "0 pps does not exceed the friction and load torque")

    def values_key(self) -> Hashable:
        """The fields that make the motor what it is (those it compares; not its
        provenance, a dict), its arrays as bytes: a Motor holds arrays, so it has no hash
        of its own. What a verdict or a plan is remembered by."""
        values = (getattr(self, f.name) for f in fields(self) if f.compare)
        return tuple((v.dtype.str, v.tobytes()) if isinstance(v, np.ndarray) else v
                     for v in values)

    # --- capability -------------------------------------------------------
    @property
    def top_curve_pps(self) -> float:
        return float(self.curve_speed_pps[-1])

    @property
    def top_pps(self) -> float:
        """Highest usable speed: the curve's last point, capped by max_pps."""
        top = self.top_curve_pps
        return top if self.max_pps is None else min(top, self.max_pps)

    @property
    def jump_pps(self) -> float:
        """Largest instantaneous step of pulse frequency (default: start_pps)."""
        return self.start_pps if self.max_jump_pps is None else self.max_jump_pps

    @property
    def pps2_per_nm(self) -> float:
        """Torque to acceleration: pps/s per N·m (steps_per_rev / (2π · J))."""
        return self.steps_per_rev / (2 * math.pi * self.inertia_kgm2)

    def torque_nm(self, speed_pps: Any) -> Any:
        """Pull-out torque at `speed_pps` (linear interpolation; 0 beyond the curve)."""
        return np.interp(speed_pps, self.curve_speed_pps, self.curve_torque_nm, right=0.0)

    @property
    def teeth(self) -> int:
        """Rotor teeth Nr: electrical periods per revolution."""
        return DEFAULT_ROTOR_TEETH if self.rotor_teeth is None else self.rotor_teeth

    @property
    def electrical_deg_per_pulse(self) -> float:
        """Load angle per pulse of lag: 360° · Nr / steps_per_rev (2- and 5-phase alike)."""
        return 360.0 * self.teeth / self.steps_per_rev

    @property
    def full_step_electrical_deg(self) -> float:
        """One full step: 90° electrical (2-phase), 36° (5-phase): 180° / phases."""
        return 180.0 / self.phases

    def a_acc_pps2(self, speed_pps: Any) -> Any:
        return (self.safety_factor * self.torque_nm(speed_pps) - self.friction_torque_nm
                - abs(self.load_torque_nm)) * self.pps2_per_nm

    def a_dec_pps2(self, speed_pps: Any) -> Any:
        return (self.safety_factor * self.torque_nm(speed_pps) + self.friction_torque_nm
                - abs(self.load_torque_nm)) * self.pps2_per_nm

    def min_a_acc_pps2(self, lo_pps: Any, hi_pps: Any) -> Any:
        """Exact minimum of a_acc over [lo, hi] (vectorised): the curve is piecewise
        linear, so the minimum sits at an end or at a breakpoint inside."""
        return self._min_over(lo_pps, hi_pps, self.a_acc_pps2)

    def min_a_dec_pps2(self, lo_pps: Any, hi_pps: Any) -> Any:
        return self._min_over(lo_pps, hi_pps, self.a_dec_pps2)

    def _min_over(self, lo: Any, hi: Any, f: Any) -> Any:
        lo_a = np.asarray(lo, dtype=float)
        hi_a = np.asarray(hi, dtype=float)
        out = np.minimum(f(lo_a), f(hi_a))
        bp = self.curve_speed_pps[1:-1]
        if len(bp):
            # the breakpoints strictly inside (lo, hi) are bp[i:j]; `least[i, j]` is their
            # minimum (inf when none): one lookup instead of a pass per breakpoint, which
            # the planner's thousands of calls spent most of their time in
            i = np.searchsorted(bp, lo_a, side="right")
            j = np.searchsorted(bp, hi_a, side="left")
            out = np.minimum(out, _range_min(np.asarray(f(bp), dtype=float))[i, j])
        return out if out.ndim else float(out)

    # --- file format ------------------------------------------------------
    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"format": FORMAT}
        if self.name:
            out["name"] = self.name
        out.update(steps_per_rev=self.steps_per_rev,
                   pullout_torque=[[float(v), float(t)] for v, t in
                                   zip(self.curve_speed_pps, self.curve_torque_nm, strict=True)],
                   inertia_kgm2=self.inertia_kgm2, friction_torque_nm=self.friction_torque_nm,
                   safety_factor=self.safety_factor, start_pps=self.start_pps)
        for key in ("max_jump_pps", "max_pps", "max_jerk_pps3", "holding_torque_nm",
                    "rotor_teeth"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        if self.phases != DEFAULT_PHASES:
            out["phases"] = self.phases
        if self.damping_ratio != DEFAULT_DAMPING_RATIO:
            out["damping_ratio"] = self.damping_ratio
        if self.load_torque_nm:
            out["load_torque_nm"] = self.load_torque_nm
        if self.sources is not None:
            out["sources"] = self.sources
        if self.tolerances:
            out["tolerances"] = {k: [lo, hi] for k, lo, hi in self.tolerances}
        if self.resonance_bands_pps:
            out["resonance_bands_pps"] = [[lo, hi] for lo, hi in self.resonance_bands_pps]
        if self.travel_mm_per_rev is not None:
            out["travel_mm_per_rev"] = self.travel_mm_per_rev
        return out

    @classmethod
    def from_json(cls, obj: Any) -> Motor:
        if not isinstance(obj, dict):
            raise FormatError("a motor file holds one JSON object")
        if obj.get("format") != FORMAT:
            raise FormatError(f"format: expected {echo(FORMAT)}, got {echo(obj.get('format'))}")
        unknown = set(obj) - REQUIRED_KEYS - OPTIONAL_KEYS
        if unknown:
            raise FormatError(f"unknown key(s) in motor file: {', '.join(sorted(unknown))}")
        missing = REQUIRED_KEYS - set(obj)
        if missing:
            raise FormatError(f"missing key(s) in motor file: {', '.join(sorted(missing))}")
        curve = obj["pullout_torque"]
        if not isinstance(curve, list) or not all(
                isinstance(p, list) and len(p) == 2 and all(_is_num(x) for x in p) for p in curve):
            raise FormatError("pullout_torque: expected a list of [speed_pps, torque_nm] pairs")
        for key in (REQUIRED_KEYS | OPTIONAL_KEYS) - {"format", "pullout_torque", "name", "sources",
                                              "tolerances", "resonance_bands_pps"}:
            if key in obj and not _is_num(obj[key]):
                raise FormatError(f"{key}: expected a number, got {echo(obj[key])}")
        for key in ("steps_per_rev", "rotor_teeth", "phases"):
            if key in obj and not isinstance(obj[key], int):
                raise FormatError(f"{key}: expected an integer, got {echo(obj[key])}")
        return cls(steps_per_rev=obj["steps_per_rev"],
                   curve_speed_pps=np.array([p[0] for p in curve], dtype=float),
                   curve_torque_nm=np.array([p[1] for p in curve], dtype=float),
                   inertia_kgm2=float(obj["inertia_kgm2"]),
                   safety_factor=float(obj["safety_factor"]),
                   start_pps=float(obj["start_pps"]),
                   friction_torque_nm=float(obj.get("friction_torque_nm", 0.0)),
                   max_jump_pps=_opt(obj, "max_jump_pps"), max_pps=_opt(obj, "max_pps"),
                   max_jerk_pps3=_opt(obj, "max_jerk_pps3"), name=str(obj.get("name", "")),
                   holding_torque_nm=_opt(obj, "holding_torque_nm"),
                   rotor_teeth=int(obj["rotor_teeth"]) if "rotor_teeth" in obj else None,
                   phases=int(obj.get("phases", DEFAULT_PHASES)),
                   damping_ratio=float(obj.get("damping_ratio", DEFAULT_DAMPING_RATIO)),
                   load_torque_nm=float(obj.get("load_torque_nm", 0.0)),
                   sources=_sources(obj["sources"]) if "sources" in obj else None,
                   tolerances=_read_tolerances(obj.get("tolerances", {})),
                   resonance_bands_pps=_read_bands(obj.get("resonance_bands_pps", [])),
                   travel_mm_per_rev=_opt(obj, "travel_mm_per_rev"))

    def nominal(self, name: str) -> float:
        """The nominal value of a TOLERANCE_KEYS parameter (torque_scale: 1)."""
        return 1.0 if name == "torque_scale" else float(getattr(self, name))

    def tolerance(self, name: str) -> tuple[float, float]:
        """The [low, high] range of a TOLERANCE_KEYS parameter (its nominal when none)."""
        for key, lo, hi in self.tolerances:
            if key == name:
                return lo, hi
        value = self.nominal(name)
        return value, value


def load_motor(spec: str | Path) -> Motor:
    """The motor of a file path, or of a name in the motor catalogue (`stepramp motor
    list`; profiles/motor/catalogue.py says how a name is looked up)."""
    from .catalogue import resolve

    path = resolve(spec)
    obj = read_json(path)
    try:
        return Motor.from_json(obj)
    except StepRampError as e:  # a file that reads but is no motor: name the file
        name = display_path(path)
        if not str(e).startswith(name):
            e.args = (f"{name}: {e}",)
        raise


def bundled_motor_paths() -> list[Path]:
    """The example motors shipped with stepramp."""
    from .catalogue import BUNDLED_DIR

    return sorted(BUNDLED_DIR.glob("motor-*.json"))


def _read_tolerances(obj: Any) -> tuple[tuple[str, float, float], ...]:
    if not isinstance(obj, dict):
        raise FormatError("tolerances: expected an object of \"field\": [low, high] entries")
    out = []
    for key, pair in obj.items():
        if key not in TOLERANCE_KEYS:
            raise FormatError(f"tolerances: unknown field {echo(key)} (allowed: "
                              f"{', '.join(TOLERANCE_KEYS)})")
        if not (isinstance(pair, list) and len(pair) == 2 and all(_is_num(x) for x in pair)):
            raise FormatError(f"tolerances.{key}: expected [low, high] (two numbers), got "
                              f"{echo(pair)}")
        out.append((key, float(pair[0]), float(pair[1])))
    return tuple(sorted(out, key=lambda e: TOLERANCE_KEYS.index(e[0])))


def _read_bands(obj: Any) -> tuple[tuple[float, float], ...]:
    if not isinstance(obj, list) or not all(
            isinstance(b, list) and len(b) == 2 and all(_is_num(x) for x in b) for b in obj):
        raise FormatError("resonance_bands_pps: expected a list of [lo_pps, hi_pps] pairs")
    return tuple((float(lo), float(hi)) for lo, hi in obj)


def _check_tolerances(motor: Motor) -> None:
    """Each range is ordered, holds the nominal value and stays physical."""
    seen = set()
    for key, lo, hi in motor.tolerances:
        if key not in TOLERANCE_KEYS or key in seen:
            raise FormatError(f"tolerances: {echo(key)} is not a tolerance field or is repeated")
        seen.add(key)
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
            raise FormatError(f"tolerances.{key}: low {lo:g} must not exceed high {hi:g}")
        nominal = motor.nominal(key)
        if not lo <= nominal <= hi:
            raise FieldRangeError(f"tolerances.{key} (must hold the nominal {nominal:g})",
                                  nominal, lo, hi)
        floor = {"inertia_kgm2": 1e-12, "torque_scale": 1e-9}.get(key)
        if floor is not None and lo < floor:
            raise FieldRangeError(f"tolerances.{key} low", lo, floor, hi)
        if key in ("friction_torque_nm", "damping_ratio") and lo < 0:
            raise FieldRangeError(f"tolerances.{key} low", lo, 0, hi)


def _check_bands(bands: tuple[tuple[float, float], ...]) -> None:
    for i, (lo, hi) in enumerate(bands):
        if not (math.isfinite(lo) and math.isfinite(hi)) or not 0 < lo < hi:
            raise FormatError(f"resonance_bands_pps[{i}]: expected 0 < lo < hi, got "
                              f"[{lo:g}, {hi:g}]")


def _is_num(x: Any) -> bool:
    return is_number(x, finite=True)


def _sources(obj: Any) -> dict[str, list[dict[str, Any]]]:
    """The provenance object: field → list of {"value": number, "from": text}."""
    def ok(c: Any) -> bool:
        return (isinstance(c, dict) and set(c) == {"value", "from"} and _is_num(c["value"])
                and isinstance(c["from"], str))
    if not isinstance(obj, dict) or not all(
            isinstance(v, list) and all(ok(c) for c in v) for v in obj.values()):
        raise FormatError('sources: expected {field: [{"value": number, "from": text}, …]}')
    return obj


def _opt(obj: dict[str, Any], key: str) -> float | None:
    return float(obj[key]) if key in obj else None


def _range_min(values: np.ndarray) -> np.ndarray:
    """`least[i, j]` = min(values[i:j]) for i < j, inf otherwise ((B + 1)² for B values)."""
    b = len(values)
    rows = np.where(np.arange(b)[None, :] >= np.arange(b + 1)[:, None], values[None, :], np.inf)
    least = np.full((b + 1, b + 1), np.inf)
    least[:, 1:] = np.minimum.accumulate(rows, axis=1)
    return least


def _positive(name: str, value: float, lo: float, hi: float) -> None:
    if not lo <= value <= hi:
        raise FieldRangeError(name, value, lo, hi)
