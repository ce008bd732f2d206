"""The A-Link ALUM's ramps on the load angle, for `verify.safety.judge_safety`.

The unit's ramp is a stage model (`profiles.alink.ramp`); its motions — every move length,
a decel stop (STOP 31) from every pulse of the ramp, the homing legs — are flat segment
lists that the compiled load-angle kernel (`profiles.ppmc312.load_angle.judge`, the one
every PPMC-312 verdict runs) integrates, sampled as the PPMC-312's move families are:
each family (one dwell growing a pulse at a time) every `dwell_sampling` spacing, its
worst samples refined to every length (`refine`). Both directions when the motor has a
load torque; over a tolerance box at every corner, and its seeded Monte Carlo samples on
the moves worst at some corner (`tolerance_box.batch_sample_peaks`). The criterion is the
unit's: the start speed within the motor's self-start speed, the high speed within its
top, the ramp's peak acceleration within its capability both ways, a homing search's stop
at once within the self-start speed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from profiles.alink.homing import STEP_PPS, HomingSettings
from profiles.alink.model import MOVE_PULSES_MAX
from profiles.alink.planner import Judgement
from profiles.alink.ramp import (
    RAMP_HZ,
    AlinkRamp,
    Kind,
    RampShape,
    build_ramp,
    families,
    parts,
    segments,
)
from profiles.findings import Finding
from profiles.motor import Motor
from profiles.motor.angles import PEAK_DEG
from profiles.motor.rotor import Rotors, rotors
from profiles.ppmc312.load_angle import dwell_sampling, judge, refine, sample_grid
from profiles.ppmc312.move_batch import MoveBatch

S_CURVE_PEAK = math.pi / 2   # the 1 − cos law's peak over its average acceleration


@dataclass(frozen=True)
class Angles:
    """The worst |load angle| of every motion judged (`x`: its length or stop pulse) for
    every rotor row: `deg[row, motion]`."""

    x: np.ndarray
    deg: np.ndarray
    slipped: np.ndarray

    def worst(self) -> tuple[float, int, int]:
        """(worst angle, the row, the motion) over everything judged."""
        r, e = np.unravel_index(int(np.argmax(self.deg)), self.deg.shape)
        return float(self.deg[r, e]), int(r), int(e)

    def first_unstable(self) -> int | None:
        bad = self.x[np.any(self.deg >= PEAK_DEG, axis=0)]
        return int(bad.min()) if len(bad) else None


def batch(ramp: AlinkRamp, kind: Kind, x: np.ndarray) -> MoveBatch:
    """The motions of `kind` at `x` as the kernel's flat segment lists."""
    rate, count, offsets = segments(ramp, parts(ramp, kind, x))
    zeros = np.zeros(len(x), np.int64)
    return MoveBatch(np.asarray(x, np.int64), zeros, np.zeros(len(rate), np.int64), rate,
                     count, offsets)


def motion_angles(ramp: AlinkRamp, kind: Kind, rot: Rotors,
                  x: Iterable[int] | None = None) -> Angles:
    """The load angle of `kind`'s motions for every row of `rot`: at `x`, or over every
    one through its families (sampled, then refined)."""
    if x is not None:
        xs = np.asarray(sorted({int(n) for n in x}), dtype=np.int64)
        return _angles(ramp, kind, xs, rot)
    lo, hi, speed = families(ramp, kind)
    if not len(lo):
        return Angles(np.zeros(0, np.int64), np.zeros((len(rot), 0)),
                      np.zeros((len(rot), 0), bool))
    rotor_list = [rot.rotor(i) for i in range(len(rot))]
    spacing, dense = dwell_sampling(rotor_list, speed, lo, hi, 1)
    hi = np.where(hi >= MOVE_PULSES_MAX, dense, hi)  # a longer cruise repeats the settled one
    xs, fam = sample_grid(lo, spacing, dense, hi)
    xs, first = np.unique(xs, return_index=True)
    found = _angles(ramp, kind, xs, rot)
    extra = refine(xs, fam[first], spacing, found.deg.max(axis=0))
    if not len(extra):
        return found
    more = _angles(ramp, kind, extra, rot)
    order = np.argsort(np.concatenate((xs, extra)), kind="stable")
    return Angles(np.concatenate((xs, extra))[order],
                  np.concatenate((found.deg, more.deg), axis=1)[:, order],
                  np.concatenate((found.slipped, more.slipped), axis=1)[:, order])


def _angles(ramp: AlinkRamp, kind: Kind, xs: np.ndarray, rot: Rotors) -> Angles:
    lag, slipped = judge(batch(ramp, kind, xs), RAMP_HZ, rot)
    return Angles(xs, np.degrees(lag * rot.c_e), slipped)


def box_rotors(motors: Sequence[Motor], ways: Sequence[int]) -> Rotors:
    """Every motor of `motors` in every direction of `ways`, as rows of one call."""
    return Rotors.stack([rotors(m, direction=d) for m in motors for d in ways])


def ways_of(motor: Motor) -> tuple[int, ...]:
    """Both directions when the motor or its box has a load torque."""
    lo, hi = motor.tolerance("load_torque_nm")
    return (1, -1) if motor.load_torque_nm or lo or hi else (1,)


# --- the unit's criterion ----------------------------------------------------------------------

def ramp_criterion(ramp: AlinkRamp, motor: Motor, homing: HomingSettings | None
                   ) -> list[Finding]:
    """The unit's speed rules against the motor (`motor`: the box's worst case when it has
    one): `stall-start-speed`, `stall-top-speed`, `stall-accel`, `stall-decel`."""
    out = []
    start_cap = min(motor.start_pps, motor.jump_pps)
    if ramp.start_pps > start_cap:
        out.append(Finding("error", "stall-start-speed",
                           f"the unit starts every move at L_SPEED {ramp.start_pps:g} pps and "
                           f"stops from it, above the motor's self-start speed {start_cap:g} "
                           f"pps: lower L_SPEED to ≤ {start_cap:g} pps"))
    if ramp.high_pps > motor.top_pps:
        out.append(Finding("error", "stall-top-speed",
                           f"H_SPEED {ramp.high_pps:g} pps is above the motor's top usable "
                           f"speed {motor.top_pps:g} pps: lower it"))
    if ramp.high_pps > ramp.start_pps:
        peak = ramp.accel_pps2 * (S_CURVE_PEAK if ramp.shape == "s_curve" else 1.0)
        shape = "the S-curve's peak" if ramp.shape == "s_curve" else "the ramp's"
        for side, bound in (("accel", motor.min_a_acc_pps2(ramp.start_pps, ramp.high_pps)),
                            ("decel", motor.min_a_dec_pps2(ramp.start_pps, ramp.high_pps))):
            if peak > float(bound) * (1 + 1e-9):
                out.append(Finding("error", f"stall-{side}",
                                   f"{shape} {side}eration {peak:.6g} pps/s is above what "
                                   f"the motor can {side}erate over {ramp.start_pps:g}.."
                                   f"{ramp.high_pps:g} pps ({float(bound):.6g} pps/s): a "
                                   "larger UP_TIME para"))
    if homing is not None and homing.oh_pps > start_cap:
        out.append(Finding("error", "stall-start-speed",
                           f"a homing search stops at once from OH_SPEED {homing.oh_pps} pps "
                           f"at the origin, above the motor's self-start speed "
                           f"{start_cap:g} pps: lower OH_SPEED (stepramp alink homing)"))
    return out


def ramp_resonance(ramp: AlinkRamp, motor: Motor, *, strict: bool = False) -> list[Finding]:
    """`resonance-dwell` for the unit's cruise at H_SPEED inside one of the motor's bands (a
    warning; an error with `strict`). The ramp itself crosses a band at its acceleration: it
    cannot step over one as a table's jump does, so its stages there are no finding."""
    from profiles.motor.resonance import band_of, dwell_kind

    if dwell_kind(ramp.high_pps, True, motor) is None:
        return []
    lo, hi = band_of(ramp.high_pps, motor)
    return [Finding("error" if strict else "warning", "resonance-dwell",
                    f"every move that reaches H_SPEED cruises at {ramp.high_pps:g} pps, inside "
                    f"the resonance band [{lo:g}, {hi:g}] pps: choose a high speed outside it")]


# --- the families besides the moves --------------------------------------------------------------

@dataclass(frozen=True)
class MotionVerdict:
    """A family of the unit's motions other than its moves (decel stops, homing legs) on
    the load angle: what `SafetyVerdict.commands` holds for the A-Link."""

    name: str
    what: str
    worst_deg: float
    worst_x: int
    worst_direction: int
    executions: int
    aim_deg: float

    @property
    def safe(self) -> bool:
        return self.worst_deg < PEAK_DEG

    @property
    def within_aim(self) -> bool:
        return self.worst_deg <= self.aim_deg

    def _worst(self) -> str:
        way = "forward" if self.worst_direction > 0 else "backward"
        unit = "pulse" if self.name == "decel-stop" else "pulses"
        at = (f"from pulse {self.worst_x} of the ramp" if self.name == "decel-stop"
              else f"of {self.worst_x} {unit}")
        return f"{self.worst_deg:.1f}° electrical ({way}, {at})"

    def findings(self) -> list[Finding]:
        if not self.safe:
            (_, error), _ = RULES[self.name]
            return [Finding("error", error, f"{self.what} drive the rotor to {self._worst()}, "
                                            "past the 90° peak")]
        if not self.within_aim:
            _, (_, warning) = RULES[self.name]
            return [Finding("warning", warning,
                            f"{self.what}: worst load angle {self._worst()}, past the "
                            f"{self.aim_deg:g}° aim")]
        return []

    def describe(self) -> str:
        return f"{self.what}: worst load angle {self._worst()}"

    def to_json(self) -> dict[str, Any]:
        return {"safe": self.safe, "within_aim": self.within_aim,
                "worst_load_angle_deg": self.worst_deg, "worst_at": self.worst_x,
                "worst_direction": "forward" if self.worst_direction > 0 else "backward",
                "executions": self.executions, "what": self.what}


# each family's (severity, rule) past the 90° peak and past the aim
RULES: dict[str, tuple[tuple[str, str], tuple[str, str]]] = {
    "decel-stop": (("error", "alink-decel-stop-load-angle"),
                   ("warning", "alink-decel-stop-load-angle-margin")),
    "homing": (("error", "alink-homing-load-angle"),
               ("warning", "alink-homing-load-angle-margin"))}


def family_verdicts(ramp: AlinkRamp, homing: HomingSettings | None, rot: Rotors,
                    aim_deg: float) -> list[tuple[str, MotionVerdict]]:
    """The decel stops from every pulse of the ramp and, with `homing`, its legs (a search
    ramping OL → OH in the ramp's shape and stopping at once, the creep at OL), over every
    row of `rot`."""
    out = []
    if ramp.ramp_pulses > 1:
        out.append(("decel-stop", _verdict("decel-stop", "decel stops (STOP 31) from every "
                                           "pulse of the ramp",
                                           motion_angles(ramp, "stop", rot), rot, aim_deg)))
    if homing is not None:
        out.append(("homing", homing_verdict(homing, (ramp.shape,), rot, aim_deg)))
    return out


def homing_verdict(homing: HomingSettings, shapes: Sequence[RampShape], rot: Rotors,
                   aim_deg: float) -> MotionVerdict:
    """The homing legs on the load angle for every row of `rot`: a search ramping OL → OH
    at O_UPTIME (in each of `shapes`: MODE's, or both when it is not known) in steps of
    ×20, cruising at OH and stopping at once at the origin, and the creep at OL stopping
    at once at the edge (profiles/alink/ramp.py, 7)."""
    legs = [motion_angles(build_ramp(homing.ol_pps, homing.oh_pps, homing.accel_pps2,
                                     STEP_PPS, shape), "search", rot) for shape in shapes]
    legs.append(motion_angles(build_ramp(homing.ol_pps, homing.ol_pps, homing.accel_pps2,
                                         STEP_PPS), "creep", rot))
    worst = max(legs, key=lambda a: a.worst()[0] if a.deg.size else -1.0)
    return _verdict("homing", f"homing searches (OL {homing.ol_pps} → OH {homing.oh_pps} "
                    "pps, stopping at once) and the creep at OL", worst, rot, aim_deg,
                    sum(a.deg.size for a in legs))


def homing_judge(motor: Motor, *, aim_deg: float) -> Callable[[HomingSettings], Judgement]:
    """The homing legs' verdict as `profiles.alink.homing.tighten_homing`'s judge: over the
    motor's box corners, both ramp shapes (an `alink homing` file knows no MODE)."""
    from profiles.motor.tolerance import corners

    motors = [c.motor for c in corners(motor)] if motor.tolerances else [motor]
    rot = box_rotors(motors, ways_of(motor))

    def judged(homing: HomingSettings) -> Judgement:
        v = homing_verdict(homing, ("linear", "s_curve"), rot, aim_deg)
        return Judgement(v.within_aim, v.worst_deg, "start", v.describe())

    return judged


def _verdict(name: str, what: str, found: Angles, rot: Rotors, aim_deg: float,
             executions: int | None = None) -> MotionVerdict:
    deg, row, e = found.worst()
    return MotionVerdict(name, what, deg, int(found.x[e]), int(rot.direction[row]),
                         found.deg.size if executions is None else executions, aim_deg)


def nominal_rotors(motor: Motor) -> Rotors:
    """The motor's own rows (each direction)."""
    return box_rotors([motor], ways_of(motor))

