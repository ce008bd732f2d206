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

from profiles.alink.model import MOVE_PULSES_MAX
from profiles.alink.planner import Judgement
from profiles.alink.planner.homing import STEP_PPS, HomingSettings
from profiles.alink.ramp import (
    RAMP_HZ,
    AlinkRamp,
    Kind,
    RampShape,
    build_ramp,
    build_ramps,
    families,
    parts,
    segments,
)
from profiles.findings import Finding
from profiles.motor import Motor
from profiles.motor.angles import PEAK_DEG
from profiles.motor.batch import MoveBatch
from profiles.motor.batch_angle import (
    STOP_REFINE_DEG,
    dwell_sampling,
    judge,
    merged,
    refine,
    refine_toward,
    sample_grid,
)
from profiles.motor.rotor import Rotors, rotors
from profiles.remembered import Remembered
from profiles.verdict import envelope_findings

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
    """The motions of `kind` at `x` as the kernel's flat segment lists: assembled by the
    PPMC-312's compiled twin (`assemble_kernel.assemble`: an accel part up the ramp, the
    cruise at H, a decel part down it; numpy's passes over the ~10⁶ segments of a
    verdict's motions were half of it), or by `ramp.segments` when a middle runs below H
    (an avoided triangle's). The kernel sees the same rates and counts either way (it
    joins neighbours of one rate; the phases differ, which it does not read)."""
    from profiles.motor.assemble_kernel import assemble

    p = parts(ramp, kind, x)
    xs = np.asarray(x, np.int64)
    shape = np.zeros(len(xs), np.int64)
    if np.any((p.middle > 0) & (p.up < ramp.ramp_pulses)):
        rate, count, offsets = segments(ramp, p)
        return MoveBatch(xs, shape, np.zeros(len(rate), np.int64), rate, count, offsets)
    zero = np.zeros_like(p.up)
    phase, rate, count, offsets = assemble(np.stack((p.up, zero, p.middle, p.down, zero)),
                                           *_ladders(ramp), ramp.high_rate, zero.astype(bool))
    return MoveBatch(xs, shape, phase, rate, count, offsets)


def _ladders(ramp: AlinkRamp) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The ramp as `assemble`'s five parts' stages (starts, rates, counts, cum): the ramp
    for the first accel part and the first decel part, none for the others."""
    n = len(ramp.pulses)
    counts = np.asarray(ramp.pulses, np.int64)
    cum = np.cumsum(counts)
    starts = np.array([0, n, n, n, 2 * n, 2 * n], np.int64)
    return (starts, np.concatenate((ramp.rates, ramp.rates)),
            np.concatenate((counts, counts)), np.concatenate((cum, cum)))


def motion_angles(ramp: AlinkRamp, kind: Kind, rot: Rotors,
                  x: Iterable[int] | None = None, *, upto: int | None = None,
                  aim_deg: float | None = None, every_pulse: bool = False) -> Angles:
    """The load angle of `kind`'s motions for every row of `rot`: at `x`, or over every
    one: the stops (`RAMP_STOPS`) sampled along the ramp and refined (`stop_angles`;
    `aim_deg`: where the first stop past it comes is exact too; `upto`: none past it;
    `every_pulse`: every stop judged, the oracle the samples are tested against), the
    others through their families (sampled, then refined)."""
    if x is not None:
        xs = np.asarray(sorted({int(n) for n in x}), dtype=np.int64)
        return _angles(ramp, kind, xs, rot)
    if kind in RAMP_STOPS:
        return stop_angles(ramp, kind, rot, upto=upto, aim_deg=aim_deg,
                           every_pulse=every_pulse)
    lo, hi, speed = families(ramp, kind)
    if not len(lo):
        return _no_angles(rot)
    rotor_list = [rot.rotor(i) for i in range(len(rot))]
    spacing, dense = dwell_sampling(rotor_list, speed, lo, hi, 1)
    hi = np.where(hi >= MOVE_PULSES_MAX, dense, hi)  # a longer cruise repeats the settled one
    xs, fam = sample_grid(lo, spacing, dense, hi)
    xs, first = np.unique(xs, return_index=True)
    found = [_angles(ramp, kind, xs, rot)]

    def judge_at(extra: np.ndarray) -> np.ndarray:
        mine = extra if upto is None else extra[extra <= upto]  # ascending: a prefix
        worst = np.full(len(extra), -np.inf)  # past `upto`: never the top searched for
        if len(mine):
            found.append(_angles(ramp, kind, mine, rot))
            worst[:len(mine)] = found[-1].deg.max(axis=0)
        return worst

    refine(xs, fam[first], spacing, found[0].deg.max(axis=0), judge_at)
    return _merged(found)


# The stops judged along the ramp rather than stage by stage (docs/manual-notes.md, "A-Link
# ALUM: stops sampled along the ramp"): a stop (STOP 31) from pulse x, a stop at once
# (STOP 28, EL, a homing search) after x pulses.
RAMP_STOPS: tuple[Kind, ...] = ("stop", "search")


def stop_grid(ramp: AlinkRamp, kind: Kind, rot: Rotors, upto: int | None = None
              ) -> tuple[np.ndarray, int]:
    """The stops that stand for every stop of `kind` (ascending x) and the last x judged:
    one every 1/8 natural period (the stiffest row's) at the speed each pulse runs at,
    as `load_angle.dwell_sampling` spaces a dwell, along the ramp (and, for a stop at
    once, the cruise at H until it has lasted ten natural periods: a longer one repeats
    that settled state); for STOP 31 a stage longer than its spacing also at its first
    and last pulse (each stage's stops decelerate through it whole: its first stop
    dwells longer at a higher speed than the last of the stage below); the first and
    the last stop."""
    r = ramp.ramp_pulses
    n = len(ramp.pulses)
    speeds = np.append(ramp.speeds_pps, ramp.high_pps)
    lo = np.ones(n + 1, np.int64)
    lo[-1] = max(r, 1)
    hi = np.append(np.maximum(ramp.pulses, 2), MOVE_PULSES_MAX)
    spacing, dense = dwell_sampling([rot.rotor(i) for i in range(len(rot))], speeds, lo,
                                    hi, 1)
    end = max(r - 1, 0) if kind == "stop" else int(dense[-1])
    if upto is not None:
        end = min(end, upto)
    if end < 1:
        return np.zeros(0, np.int64), 0
    cruise = np.full(max(end - r, 0), min(int(spacing[-1]), max(end - r, 1)))
    per_pulse = np.concatenate((np.repeat(spacing[:-1], ramp.pulses), cruise))[:end]
    tick = np.floor(np.cumsum(1.0 / per_pulse) + 1e-9)
    along = np.flatnonzero(np.diff(tick, prepend=0.0) > 0) + 1
    ends = np.cumsum(ramp.pulses)
    # a stop at once only adds pulses as x grows; STOP 31 past a stage's last pulse also
    # decelerates through the next stage whole: a jump where that stage is long
    long = (ramp.pulses > spacing[:-1]) & (kind == "stop")
    edges = np.concatenate((ends[long] - ramp.pulses[long] + 1, ends[long]))
    xs = np.unique(np.concatenate(([1, end], along, edges)))
    return xs[(xs >= 1) & (xs <= end)].astype(np.int64), end


def stop_angles(ramp: AlinkRamp, kind: Kind, rot: Rotors, *, upto: int | None = None,
                aim_deg: float | None = None, every_pulse: bool = False) -> Angles:
    """Every stop of `kind` (`RAMP_STOPS`) on the load angle: `stop_grid`'s samples, then
    the stops around the worst ones (`refine_stops`); with `every_pulse`, every stop."""
    xs, end = stop_grid(ramp, kind, rot, upto)
    if every_pulse:
        xs = np.arange(1, end + 1, dtype=np.int64)
    if not len(xs):
        return _no_angles(rot)
    found = _angles(ramp, kind, xs, rot)
    if every_pulse:
        return found
    marks = (PEAK_DEG,) if aim_deg is None else (aim_deg, PEAK_DEG)
    extra = refine_stops(xs, found.deg.max(axis=0), marks)
    return _with_extra(ramp, kind, rot, found, extra)


def refine_stops(xs: np.ndarray, worst: np.ndarray, marks: Sequence[float]) -> np.ndarray:
    """The stops still to judge around the samples `xs` (their worst angles `worst`): each
    rise and fall of the samples (from one local minimum to the next) is a range the
    PPMC-312's decel stops' `batch_angle.refine_toward` refines as it does a stage's dwells —
    between its top and the larger neighbour, for the tops within STOP_REFINE_DEG of the
    worst — and, for each angle of `marks` the verdict reads where it is first passed
    (the aim, the 90° peak), every stop before the first sample past it and the ranges
    before it whose top comes within STOP_REFINE_DEG of it. Past the peak a stop slips
    and its angle is no longer smooth in x: its number there is a sample's (the verdict
    reads only that it is past the peak)."""
    if len(xs) < 3:
        return np.zeros(0, np.int64)
    falling = np.diff(worst) < 0
    valley = np.flatnonzero(falling[:-1] & ~falling[1:]) + 1   # local minima
    family = np.zeros(len(xs), np.int64)
    family[valley] = 1
    family = np.cumsum(family)
    extra = [refine_toward(xs, family, worst)]
    for mark in marks:
        past = np.flatnonzero(worst >= mark)
        first = int(past[0]) if len(past) else len(xs)
        if 0 < first < len(xs):
            extra.append(np.arange(xs[first - 1] + 1, xs[first]))
        near = family[:first][worst[:first] >= mark - STOP_REFINE_DEG]
        for f in np.unique(near).tolist():
            mine = np.flatnonzero(family == f)
            # the range alone: its top the worst refine_toward compares with
            extra.append(refine_toward(xs[mine], family[mine], worst[mine]))
    return np.setdiff1d(np.concatenate(extra), xs).astype(np.int64)


def _no_angles(rot: Rotors) -> Angles:
    """No motion judged, for every row of `rot`."""
    return Angles(np.zeros(0, np.int64), np.zeros((len(rot), 0)),
                  np.zeros((len(rot), 0), bool))


def _with_extra(ramp: AlinkRamp, kind: Kind, rot: Rotors, found: Angles, extra: np.ndarray
                ) -> Angles:
    """`found` with the motions at `extra` (none of its x) judged too, in order of x."""
    return _merged([found, _angles(ramp, kind, extra, rot)]) if len(extra) else found


def _merged(parts: Sequence[Angles]) -> Angles:
    """The motions of `parts` (no x twice) as one verdict, in order of x."""
    return Angles(*merged([(p.x, p.deg, p.slipped) for p in parts]))


def _angles(ramp: AlinkRamp, kind: Kind, xs: np.ndarray, rot: Rotors) -> Angles:
    lag, slipped = judge(batch(ramp, kind, xs), RAMP_HZ, rot, share_slipped=True)
    return Angles(xs, np.degrees(lag * rot.c_e), slipped)


RAMP_VERDICTS_KEPT = 16   # the ramps' load-angle verdicts remembered (a few KB each)
_kept: Remembered[tuple[Angles, tuple[tuple[str, Any], ...]]] = Remembered(RAMP_VERDICTS_KEPT)


def judged(ramp: AlinkRamp, motor: Motor, rot: Rotors, moves: tuple[int, ...] | None,
           homing: HomingSettings | None, aim_deg: float, families: Sequence[str]
           ) -> tuple[Angles, tuple[tuple[str, Any], ...]]:
    """The moves' angles (`motion_angles`, at `moves` or every length) and the command
    families' verdicts (`family_verdicts`) of `ramp` for `motor`'s rows `rot`, the last
    RAMP_VERDICTS_KEPT remembered by ramp, motor values and the rest, read-only: a
    tightening judges settings and then sync's report or `check` asks for them again."""
    def judge_now() -> tuple[Angles, tuple[tuple[str, Any], ...]]:
        from profiles.threads import pool

        # the families side by side: each call of the kernel runs on every core, but
        # between them (a reference integrated alone, the batches built) one core
        # idles; the stops at once and the limit runs together (the limit reads the
        # stops' memo)
        groups = [g for g in (("decel-stop",), ("stop", "limit"), ("change-speed",),
                              ("homing",)) if set(g) & set(families)]
        workers = pool("alink-verdict", 4)
        parts = [workers.submit(family_verdicts, ramp, homing, rot, aim_deg,
                                [f for f in g if f in families]) for g in groups]
        found = motion_angles(ramp, "move", rot, moves)
        for a in (found.x, found.deg, found.slipped):
            a.flags.writeable = False
        done = dict(v for part in parts for v in part.result())
        return found, tuple((name, done[name]) for name in FAMILY_ORDER if name in done)

    key = (ramp.key(), motor.values_key(), moves, homing, aim_deg, tuple(families))
    return _kept.get(key, judge_now)[0]


def forget_ramp_verdicts() -> None:
    """Forget the remembered ramp verdicts (a benchmark times a first verdict)."""
    _kept.clear()


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
                    aim_deg: float, families: Sequence[str] | None = None
                    ) -> list[tuple[str, Any]]:
    """The decel stops from every pulse of the ramp, the immediate stops, the speed
    changes and the limit runs (envelopes: `EnvelopeVerdict`) and, with `homing`, its legs
    (a search ramping OL → OH in the ramp's shape and stopping at once, the creep at OL),
    over every row of `rot`; `families` narrows them (`alink_families`)."""
    out: list[tuple[str, Any]] = []
    families = FAMILY_ORDER if families is None else families
    memo: dict[tuple[object, ...], Angles] = {}   # the ramp stops stop and limit share
    judges: dict[str, Callable[[AlinkRamp, Rotors, float], EnvelopeVerdict]] = {
        "stop": lambda r, rows, aim: stop_envelope(r, rows, aim, memo=memo),
        "change-speed": change_envelope,
        "limit": lambda r, rows, aim: limit_envelope(r, rows, aim, memo=memo)}
    if ramp.ramp_pulses > 1 and "decel-stop" in families:
        out.append(("decel-stop", _verdict("decel-stop", "decel stops (STOP 31) from every "
                                           "pulse of the ramp",
                                           motion_angles(ramp, "stop", rot), rot, aim_deg)))
    out += [(name, judges[name](ramp, rot, aim_deg)) for name in families if name in judges]
    if homing is not None and "homing" in families:
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
    """The homing legs' verdict as `profiles.alink.planner.homing.tighten_homing`'s judge: over the
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



# --- the commands that run the ramp at a speed the machine chooses (issue 33) ------------------

# The unit's commands (`stepramp alink command` names) and the families of the verdict they
# run besides the moves (judged always: MOVE_R, MOVE_A, OFFSET, RESET_POS run the ramp as a
# move). STOP: both forms (28 at once, 31 decelerating); the homing commands: the legs.
COMMAND_FAMILIES: dict[str, tuple[str, ...]] = {
    "move-r": (), "move-a": (), "offset": (), "reset-pos": (),
    "stop": ("decel-stop", "stop"), "decel-stop": ("decel-stop",),
    "change-speed": ("change-speed",), "limit": ("limit",),
    **{name: ("homing",) for name in ("home", "homing", "p-search", "m-search", "p-org",
                                        "m-org")}}
FAMILY_ORDER = ("decel-stop", "stop", "change-speed", "limit", "homing")
ENVELOPE_GRID = 17     # target speeds an envelope is judged at (with H and the cap)


def alink_families(commands: Iterable[str] | None) -> tuple[str, ...]:
    """The families of the unit's verdict `commands` (names of `stepramp alink command`;
    None: every one) run, in `FAMILY_ORDER`; an unknown name is refused, naming them."""
    from profiles.errors import FormatError, echo

    if commands is None:
        return FAMILY_ORDER
    chosen: set[str] = set()
    for item in commands:
        name = str(item).strip().lower()
        if name not in COMMAND_FAMILIES:
            raise FormatError(f"commands: {echo(item)} is not an A-Link command that runs the "
                              f"ramp ({', '.join(COMMAND_FAMILIES)})")
        chosen.update(COMMAND_FAMILIES[name])
    return tuple(f for f in FAMILY_ORDER if f in chosen)


ENVELOPE_TITLES = {"stop": "immediate stops (STOP 28, the EL and STP inputs) from every pulse",
                   "change-speed": "speed changes during a move (CHANGE_SPD)",
                   "limit": "limit runs (LIMIT) stopped by EL at once or SD decelerating"}


@dataclass(frozen=True)
class EnvelopeVerdict:
    """A family run at a speed the machine chooses, on the load angle: the worst angle
    at each speed of `speeds_pps` (a stop, a limit run: of everything up to that speed;
    a speed change: of the change to it from a cruise at H), the use the settings always
    leave (`use_pps`: a stop from L, a limit run at L, no speed change) and the unit's own
    use (`top_pps`: from H, at H, to the cap). Safe when the use left is below the 90°
    peak (as the PPMC-312's `command-envelope` families); the envelope is how far the
    speed may go within the aim."""

    name: str
    aim_deg: float
    speeds_pps: tuple[float, ...]
    degs: tuple[float, ...]
    use_pps: float
    top_pps: float
    direction: int
    executions: int
    note: str = ""          # a family the unit does not run (change-speed in S-curve)

    def _deg_at(self, speed: float) -> float:
        return self.degs[self.speeds_pps.index(speed)] if self.degs else 0.0

    @property
    def use_deg(self) -> float:
        return self._deg_at(self.use_pps)

    @property
    def top_deg(self) -> float:
        return self._deg_at(self.top_pps)

    @property
    def safe(self) -> bool:
        return self.use_deg < PEAK_DEG

    @property
    def within_aim(self) -> bool:
        return self.use_deg <= self.aim_deg

    def reach(self, limit: float, upward: bool = True) -> float | None:
        """The farthest speed from the use left (up, or down) with every speed between
        within `limit` (PEAK_DEG: below the peak); None: not even the use."""
        ok = (lambda d: d < limit) if limit >= PEAK_DEG else (lambda d: d <= limit)
        k = self.speeds_pps.index(self.use_pps) if self.degs else 0
        if not self.degs or not ok(self.degs[k]):
            return None
        step = 1 if upward else -1
        while 0 <= k + step < len(self.degs) and ok(self.degs[k + step]):
            k += step
        return self.speeds_pps[k]

    def describe(self) -> str:
        head = ENVELOPE_TITLES[self.name]
        if self.note:
            return f"{head}: {self.note}"
        fast = self.reach(self.aim_deg)
        if fast is None:
            text = f"none within the {self.aim_deg:g}° aim, even at {self.use_pps:g} pps"
        elif self.name == "change-speed":
            low = self.reach(self.aim_deg, upward=False)
            text = (f"within the {self.aim_deg:g}° aim up to {fast:g} pps and down to "
                    f"{low:g} pps")
        else:
            text = f"within the {self.aim_deg:g}° aim at {fast:g} pps and slower"
        at = "to" if self.name == "change-speed" else "at"
        return f"{head}: {text}; {at} {self.top_pps:g} pps: {self.top_deg:.1f}°"

    def findings(self) -> list[Finding]:
        return envelope_findings("alink-command-envelope", self.describe(), "these settings",
                                 safe=self.safe, within_aim=self.within_aim,
                                 aim_deg=self.aim_deg)

    def to_json(self) -> dict[str, Any]:
        return {"command": self.name, "safe": self.safe, "within_aim": self.within_aim,
                "worst_load_angle_deg": self.top_deg, "worst_at_pps": self.top_pps,
                "worst_direction": "forward" if self.direction > 0 else "backward",
                "executions": self.executions, "what": ENVELOPE_TITLES[self.name],
                "note": self.note or None,
                "envelope": {
                    "fastest_pps": self.reach(self.aim_deg),
                    "fastest_safe_pps": self.reach(PEAK_DEG),
                    "lowest_pps": (self.reach(self.aim_deg, upward=False)
                                   if self.name == "change-speed" else None),
                    "use_pps": self.use_pps, "use_deg": self.use_deg,
                    "top_pps": self.top_pps, "top_deg": self.top_deg,
                    "speeds_pps": list(self.speeds_pps), "load_angle_deg": list(self.degs)}}


def change_cap_pps(ramp: AlinkRamp) -> float:
    """The fastest a CHANGE_SPD (and, our reading, a LIMIT run's speed) goes: MAX_SPEED,
    or without it twice the high speed (§11-7 (1)), within the unit's 100 kpps."""
    from profiles.alink.model import SPEED_MAX_PPS

    return float(min(ramp.max_pps or 2 * ramp.high_pps, SPEED_MAX_PPS))


def _grid(ramp: AlinkRamp, lo: float, hi: float) -> list[float]:
    """Target speeds lo..hi on the unit's steps (multiples of the multiplier above L), with
    L, H and hi themselves."""
    m = ramp.multiplier
    base = ramp.start_pps
    points = np.linspace(lo, hi, ENVELOPE_GRID)
    steps = {base + round((p - base) / m) * m for p in points.tolist()}
    steps |= {lo, hi, float(ramp.high_pps), float(ramp.start_pps)}
    return sorted(s for s in steps if lo <= s <= hi)


def _settle(rot: Rotors, speeds: Sequence[float]) -> list[int]:
    """Pulses of a cruise at each speed after which every row of `rot` has settled."""
    v = np.asarray(speeds, float)
    ones = np.ones(len(v), np.int64)
    _, dense = dwell_sampling([rot.rotor(i) for i in range(len(rot))], v, ones,
                              np.full(len(v), MOVE_PULSES_MAX, np.int64), 1)
    return [int(d) for d in dense]


def _rate(speed: float) -> int:
    return round(RAMP_HZ / speed)


def _run(motions: list[list[tuple[int, int]]], rot: Rotors) -> tuple[np.ndarray, np.ndarray]:
    """Hand-built motions (lists of (rate, pulses)) on the kernel: (worst angle per motion
    over the rows [°], the row of it)."""
    rate = np.array([r for m in motions for r, n in m if n > 0], np.int64)
    count = np.array([n for m in motions for _, n in m if n > 0], np.int64)
    sizes = [sum(1 for _, n in m if n > 0) for m in motions]
    offsets = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
    x = np.arange(1, len(motions) + 1, dtype=np.int64)
    b = MoveBatch(x, np.zeros(len(x), np.int64), np.zeros(len(rate), np.int64), rate, count,
                  offsets)
    lag, _ = judge(b, RAMP_HZ, rot, share_slipped=True)
    deg = np.degrees(lag * rot.c_e)
    return deg.max(axis=0), deg.argmax(axis=0)


def _stages(ramp: AlinkRamp) -> list[tuple[int, int]]:
    return list(zip(ramp.rates.tolist(), ramp.pulses.tolist(), strict=True))


def stop_envelope(ramp: AlinkRamp, rot: Rotors, aim_deg: float, *,
                  memo: dict[tuple[object, ...], Angles] | None = None) -> EnvelopeVerdict:
    """STOP 28 (and an EL or STP input, 「即時停止」) from every pulse of every move: the
    ramp's stops at once (the homing search's motion on the unit's ramp), from each speed
    of the ramp and from the cruise at H; the worst at a speed counts every stop up to it.
    `memo` keeps them for `limit_envelope` (its ramp to H is this one in S-curve)."""
    found = motion_angles(ramp, "search", rot, aim_deg=aim_deg)
    if memo is not None:
        memo[_stops_key(ramp)] = found
    ends = np.cumsum(ramp.pulses)
    stage = np.searchsorted(ends, found.x, side="left")
    speeds = np.where(stage < len(ends), ramp.speeds_pps[np.minimum(stage, len(ends) - 1)]
                      if len(ends) else ramp.high_pps, ramp.high_pps)
    worst = found.deg.max(axis=0)
    grid = sorted({float(ramp.start_pps), float(ramp.high_pps), *speeds.tolist()})
    degs = [float(worst[speeds <= s + 1e-9].max(initial=0.0)) for s in grid]
    _, row, _ = found.worst()
    return EnvelopeVerdict("stop", aim_deg, tuple(grid), _cummax(degs),
                           float(ramp.start_pps), float(ramp.high_pps),
                           int(rot.direction[row]), found.deg.size)


def _cummax(degs: Sequence[float]) -> tuple[float, ...]:
    return tuple(np.maximum.accumulate(np.asarray(degs, float)).tolist()) if len(degs) else ()


def limit_envelope(ramp: AlinkRamp, rot: Rotors, aim_deg: float, *,
                   memo: dict[tuple[object, ...], Angles] | None = None) -> EnvelopeVerdict:
    """LIMIT at each speed s (0: H) up to the cap: the ramp L → s at UP_TIME in MODE's
    shape, then either an EL input stopping it at once from any pulse (「+EL検出で即時
    停止」) or an SD input decelerating it to a stop along the ramp (「SD信号は減速停止に
    なります」) from the settled cruise; the worst at s counts every run up to s. A linear
    ramp to s is the first steps of the ramp to the cap: its stops at once from the ramp
    are judged once, on that ramp; a ramp whose stops `memo` holds (`stop_envelope`'s) is
    not judged again."""
    grid = _grid(ramp, float(ramp.start_pps), change_cap_pps(ramp))
    settle = _settle(rot, grid)
    ramps = build_ramps(ramp.start_pps, grid, ramp.accel_pps2, ramp.multiplier, ramp.shape)
    runs = np.stack([_limit_runs(r, dwell, rot) for r, dwell in zip(ramps, settle,
                                                                   strict=True)], axis=1)
    deg = runs.max(axis=0).reshape(-1)   # EL then SD at each speed, over the rows
    row = runs.argmax(axis=0).reshape(-1)
    degs = deg.reshape(len(grid), 2).max(axis=1)
    way = int(rot.direction[int(row[int(np.argmax(deg))])])
    executions = len(deg) * len(rot)
    # what the verdict reads (the envelope's speeds, the use at L, the worst at H) is
    # settled by the stops up to H and up to the first speed whose run passes the peak
    # (every crossing comes by then): a ramp's faster stops are not judged
    past = np.flatnonzero(degs >= PEAK_DEG)
    bound = max(float(ramp.high_pps), grid[int(past[0])] if len(past) else math.inf)
    if ramp.shape == "linear":
        ramp_stops = [_ramp_stops(ramps[-1], rot, aim_deg, memo, bound)]
    else:
        ramp_stops = [_ramp_stops(r, rot, aim_deg, memo, bound) for r in ramps]
    for speeds, worst, n in ramp_stops:
        executions += n
        for k, s in enumerate(grid):
            below = worst[speeds <= s + 1e-9]
            if len(below) and below.max() > degs[k]:
                degs[k] = float(below.max())
    return EnvelopeVerdict("limit", aim_deg, tuple(grid), _cummax(degs.tolist()),
                           float(ramp.start_pps), float(ramp.high_pps), way, executions)


def _limit_runs(ramp: AlinkRamp, dwell: int, rot: Rotors) -> np.ndarray:
    """A limit run up `ramp` to its top, `dwell` pulses there, then stopped by EL at once
    (a search's motion) or by SD down the ramp (a move's): their angles [°], rows × 2. One
    call of the kernel each speed, whose reference, the SD run, the EL run follows to its
    stop (all of them in one call, each but the reference integrated its ramp from rest:
    most of the family's steps)."""
    r = ramp.ramp_pulses
    el = batch(ramp, "search", np.array([r + dwell]))
    sd = batch(ramp, "move", np.array([2 * r + dwell]))
    both = MoveBatch(np.concatenate((el.pulses, sd.pulses)), np.zeros(2, np.int64),
                     np.concatenate((el.phase, sd.phase)), np.concatenate((el.rate, sd.rate)),
                     np.concatenate((el.count, sd.count)),
                     np.concatenate((el.offsets, sd.offsets[1:] + el.offsets[-1])))
    lag, _ = judge(both, RAMP_HZ, rot, share_slipped=True)
    return np.degrees(lag * rot.c_e)


def _stops_key(ramp: AlinkRamp) -> tuple[object, ...]:
    """What the stops at once from a ramp depend on: its stages and its top."""
    return (ramp.high_pps, ramp.pulses.tobytes(), ramp.speeds_pps.tobytes())


def _ramp_stops(ramp: AlinkRamp, rot: Rotors, aim_deg: float,
                memo: dict[tuple[object, ...], Angles] | None = None,
                upto_pps: float = math.inf) -> tuple[np.ndarray, np.ndarray, int]:
    """The stops at once from every pulse of `ramp` up to `upto_pps` (not its cruise;
    `memo`'s when it has them; where the first past `aim_deg` comes exact): (the speed
    of each stop judged, its worst angle over the rows, the executions)."""
    found = (memo or {}).get(_stops_key(ramp))
    if found is None:
        slow = np.cumsum(ramp.pulses)[ramp.speeds_pps <= upto_pps + 1e-9]
        upto = min(ramp.ramp_pulses, int(slow[-1]) if len(slow) else 1)
        found = motion_angles(ramp, "search", rot, upto=upto, aim_deg=aim_deg)
    on_ramp = found.x <= ramp.ramp_pulses
    stage = np.searchsorted(np.cumsum(ramp.pulses), found.x[on_ramp], side="left")
    return (ramp.speeds_pps[stage], found.deg[:, on_ramp].max(axis=0, initial=0.0),
            found.deg.size)


def change_envelope(ramp: AlinkRamp, rot: Rotors, aim_deg: float) -> EnvelopeVerdict:
    """CHANGE_SPD from the settled cruise at H to each speed above L up to the cap, under
    both readings the manual leaves open (it says only 「駆動中の軸速度を変更します」): (a)
    at once, (b) along the unit's steps at UP_TIME; then the cruise at the new speed and
    the decel along the ramp from it (a counted move's end). Not in S-curve (「S字駆動時は
    変更できません」: a Nak)."""
    high = float(ramp.high_pps)
    if ramp.shape == "s_curve":
        return EnvelopeVerdict("change-speed", aim_deg, (high,), (0.0,), high, high, 1, 0,
                               "the unit refuses them in S-curve (a Nak): none to judge")
    cap = change_cap_pps(ramp)
    grid = [s for s in _grid(ramp, float(ramp.start_pps), cap) if s > ramp.start_pps]
    if high not in grid:
        grid.append(high)
        grid.sort()
    settle = _settle(rot, [high, *grid])
    up = _stages(ramp)
    motions = []
    tos = build_ramps(ramp.start_pps, grid, ramp.accel_pps2, ramp.multiplier)
    for s, dwell, to in zip(grid, settle[1:], tos, strict=True):
        down = _stages(to)[::-1]
        head = [*up, (_rate(high), settle[0])]
        stepped = ([st for st in _stages(to) if RAMP_HZ / st[0] >= high - 1e-9] if s > high
                   else [st for st in _stages(ramp)[::-1] if s < RAMP_HZ / st[0] < high])
        for between in ([], stepped):
            motions.append([*head, *between, (_rate(s), dwell), *down])
    deg, row = _run(motions, rot)
    pair = deg.reshape(len(grid), 2).max(axis=1)
    k = int(np.argmax(deg))
    return EnvelopeVerdict("change-speed", aim_deg, tuple(grid), tuple(pair.tolist()),
                           high, cap, int(rot.direction[int(row[k])]), len(motions) * len(rot))
