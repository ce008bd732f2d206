"""Is this table safe? The one verdict every command asks for.

A table is stall-safe for a motor when every execution the chip can run with it (every
move length, both directions of a loaded move, every motor of the tolerance box) passes
both judges:

- the **criterion** (`verify.criterion`, on profiles.ppmc312.criterion): every speed
  change the chip emits is one the motor's capability follows; over a tolerance box
  it is judged on the box's worst-case capability, which is exact over the box;
- the **load angle** (`profiles.ppmc312.load_angle`, the compiled rotor model): the
  rotor's lag stays on the stable side of the torque–angle curve, below the 90° peak
  (electrical degrees; it slips a pole at 180°); over a tolerance box at every corner
  and over seeded Monte Carlo samples (`verify.tolerance_box`).

`aim_deg` (75° unless asked otherwise: `AIM_DEG`) is what planners aim at: a table
past it but below 90° is safe with a warning. Resonance dwells are warnings, errors
with `strict`. `check`, `plan`, `compare`, `sync`, `sweep`, the designer and the
notebooks all call `judge_safety` and show its `to_json()`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from profiles.findings import Finding
from profiles.motor import Motor
from profiles.motor.angles import AIM_DEG, PEAK_DEG
from profiles.ppmc312.table import FreeCurveTable, InitTable
from profiles.progress import Progress

from .check_options import DEFAULT_SAMPLES

if TYPE_CHECKING:
    from profiles.alink.homing import HomingSettings
    from profiles.alink.ramp import AlinkRamp

    from .command_verdicts import CommandVerdict


@dataclass(frozen=True)
class LoadAngle:
    """The load-angle judge's worst case over what was judged."""

    worst_deg: float                     # |load angle|, electrical degrees
    worst_pulses: int                    # the move length where it happens
    worst_direction: int                 # 1 forward, −1 backward
    worst_at: str                        # "nominal", or the corner or sample of the box
    first_unstable_pulses: int | None    # the shortest move past the 90° peak
    slips: bool                          # some move slips a pole (≥ 180°)
    executions: int                      # (move, rotor) pairs integrated
    sample_failures: int = 0             # Monte Carlo samples past the 90° peak

    @property
    def margin_deg(self) -> float:
        """Distance of the worst angle to the 90° peak (negative: past it)."""
        return PEAK_DEG - self.worst_deg

    @property
    def stable(self) -> bool:
        return self.worst_deg < PEAK_DEG and self.sample_failures == 0

    def describe(self) -> str:
        way = "forward" if self.worst_direction > 0 else "backward"
        where = "" if self.worst_at == "nominal" else f" at {self.worst_at}"
        text = (f"worst load angle {self.worst_deg:.1f}° electrical ({way} move of "
                f"{self.worst_pulses} pulses{where}), margin {self.margin_deg:+.1f}° to the "
                f"90° peak")
        if self.first_unstable_pulses is not None:
            text += (f"; the rotor leaves the stable side of the torque–angle curve from moves "
                     f"of {self.first_unstable_pulses} pulses"
                     + (" and slips a pole" if self.slips else ""))
        if self.sample_failures:
            text += f"; {self.sample_failures} Monte Carlo samples past the peak"
        return text


@dataclass(frozen=True)
class SafetyVerdict:
    """Both judges over every execution (or the moves of `moves`), and the box."""

    moves: tuple[int, ...] | None        # None: every move length the chip can run
    aim_deg: float
    criterion: tuple[Finding, ...]       # the criterion's findings (errors)
    load_angle: LoadAngle | None         # None: not judged (asked not to, or the stages
    #                                      are out of order: the criterion says why)
    box: Any                             # verify.tolerance_box.BoxVerdict, or None
    resonance: tuple[Finding, ...]       # resonance dwells (errors with `strict`)
    # the motion commands' own verdicts (verify.command_verdicts), by family name
    commands: tuple[tuple[str, CommandVerdict], ...] = ()

    @property
    def failed(self) -> tuple[str, ...]:
        """The judges that fail: "criterion", "load angle", "resonance" (strict only), and
        each command family whose own verdict fails ("decel-stop")."""
        out = []
        if any(f.severity == "error" for f in self.criterion):
            out.append("criterion")
        if self.load_angle is not None and not self.load_angle.stable:
            out.append("load angle")
        if any(f.severity == "error" for f in self.resonance):
            out.append("resonance")
        return tuple(out) + tuple(name for name, v in self.commands if not v.safe)

    @property
    def safe(self) -> bool:
        return not self.failed

    @property
    def within_aim(self) -> bool:
        """Every move, and every command family judged, within the aim."""
        return (self.load_angle is not None and self.load_angle.worst_deg <= self.aim_deg
                and all(v.within_aim for _, v in self.commands))

    def findings(self) -> list[Finding]:
        """The verdict as `check` reports it: the criterion's findings, `load-angle`
        (error) past the 90° peak or `load-angle-margin` (warning) past the aim, and the
        resonance dwells."""
        out = list(self.criterion)
        la = self.load_angle
        if la is not None and not la.stable:
            hint = ("; the criterion passes: the rotor rings after a step at this damping "
                    "(raise the counts around the steps, or lower the safety factor and plan "
                    "again)" if not self.criterion else "")
            out.append(Finding("error", "load-angle", la.describe() + hint))
        elif la is not None and la.worst_deg > self.aim_deg:
            out.append(Finding("warning", "load-angle-margin",
                               la.describe() + f" (stepramp plan aims at ≤ {self.aim_deg:g}°)"))
        return out + list(self.resonance) + [f for _, v in self.commands for f in v.findings()]

    def notes(self) -> list[str]:
        """What `check` notes beside the findings: the worst load angle (when no
        load-angle finding says it), the tolerance box's summary, and each command family
        with nothing to find (its findings say it otherwise), when the load angle was judged."""
        out = []
        if self.load_angle is not None and \
                not any(f.rule.startswith("load-angle") for f in self.findings()):
            out.append(self.load_angle.describe())
        if self.box is not None:
            out.append(self.box.describe())
        if self.load_angle is None:  # judged without the load angle: the criterion's alone
            return out
        return out + [v.describe() for _, v in self.commands if not v.findings()]

    def describe(self) -> str:
        """One paragraph: the verdict, which judge fails, the worst angle."""
        head = "SAFE" if self.safe else "UNSAFE (failed: " + ", ".join(self.failed) + ")"
        scope = ("every move length" if self.moves is None
                 else "moves of " + ", ".join(map(str, self.moves)) + " pulses")
        parts = [f"{head} over {scope}"]
        if self.criterion:
            parts.append(f"criterion: {len(self.criterion)} finding(s)")
        if self.load_angle is not None:
            parts.append(self.load_angle.describe())
        if self.box is not None:
            parts.append(self.box.describe())
        parts += [v.describe() for _, v in self.commands]
        return "; ".join(parts)

    def to_json(self) -> dict[str, Any]:
        """The same object wherever a verdict is shown (check, plan, compare, sync,
        sweep, the designer)."""
        la = self.load_angle
        return {
            "safe": self.safe, "failed": list(self.failed),
            "moves": "every" if self.moves is None else list(self.moves),
            "aim_deg": self.aim_deg, "within_aim": self.within_aim,
            "worst_load_angle_deg": None if la is None else la.worst_deg,
            "margin_deg": None if la is None else la.margin_deg,
            "worst_pulses": None if la is None else la.worst_pulses,
            "worst_direction": None if la is None else (
                "forward" if la.worst_direction > 0 else "backward"),
            "worst_at": None if la is None else la.worst_at,
            "first_unstable_pulses": None if la is None else la.first_unstable_pulses,
            "slips": None if la is None else la.slips,
            "executions": None if la is None else la.executions,
            "criterion_findings": [f.to_json() for f in self.criterion],
            "resonance_findings": [f.to_json() for f in self.resonance],
            "tolerance_box": None if self.box is None else self.box.to_json(),
            "commands": {name: v.to_json() for name, v in self.commands},
        }


def judge_safety(table: FreeCurveTable | InitTable | AlinkRamp, motor: Motor, *,
                 pulses: Iterable[int] | None = None, samples: int = DEFAULT_SAMPLES,
                 seed: int = 0, aim_deg: float = AIM_DEG, strict: bool = False,
                 load_angle: bool = True, commands: Iterable[str] | None = None,
                 progress: Progress | None = None,
                 homing: HomingSettings | None = None) -> SafetyVerdict:
    """The verdict on `table` for `motor` over every execution the chip can run with it
    (`pulses`: only the moves of those lengths). A motor with tolerances is judged over
    its box: the criterion at the box's worst case, the load angle at every corner and
    over `samples` Monte Carlo samples (`seed`). `load_angle=False` judges the criterion
    and resonance only. Besides every move (82), each motion command family with a
    verdict of its own (`verify.command_verdicts.FAMILIES`: a decel stop (81) at every
    pulse of the ramp under every reading) is judged alike; `commands` (names or hex
    codes of `motion.COMMANDS`; None: all) narrows them for a machine that never runs
    the others. A decel stop may come during any move, or a continuous run (85): its
    stops are judged over the whole ramp whatever `pulses` says.

    An A-Link ALUM ramp (`profiles.alink.ramp.AlinkRamp`, the unit's settings as stages)
    is judged alike (`verify.alink_safety`): the unit's criterion, every move length on
    the load angle over the box, and as its command families the decel stops (STOP 31)
    from every pulse of the ramp and, with `homing`, the homing legs (OL/OH, O_UPTIME, the
    stop at once at the origin)."""
    from profiles.errors import FieldRangeError
    from profiles.ppmc312.init_model import as_free_curve
    from profiles.ppmc312.load_angle import worst_load_angle

    from .command_verdicts import FAMILIES, judged_families
    from .resonance import resonance_findings

    if not 1.0 <= aim_deg <= PEAK_DEG:
        raise FieldRangeError("load angle aim [°]", aim_deg, 1, PEAK_DEG)
    if not isinstance(table, FreeCurveTable | InitTable):  # the A-Link unit's ramp
        return _judge_ramp(table, motor, pulses=pulses, samples=samples, seed=seed,
                           aim_deg=aim_deg, load_angle=load_angle, homing=homing,
                           strict=strict, commands=commands)
    families = judged_families(commands)  # an unknown command is refused before any work
    stages = as_free_curve(table)
    moves = None if pulses is None else tuple(sorted({int(n) for n in pulses}))
    criterion = _criterion(stages, motor, moves)
    la: LoadAngle | None = None
    box = None
    if load_angle and not any(f.rule == "stall-order" for f in criterion):
        if motor.tolerances:
            from .tolerance_box import judge_box

            box = judge_box(stages, motor, pulses=moves, samples=samples, seed=seed,
                            progress=progress)
            la = LoadAngle(box.worst_angle_deg, box.worst_pulses, box.worst_direction,
                           box.worst_where, box.first_unstable_pulses, box.slips,
                           box.executions, box.sample_failures)
        else:
            w = worst_load_angle(stages, motor, pulses=moves)
            la = LoadAngle(w.worst_angle_deg, w.worst_pulses, w.worst_direction, "nominal",
                           w.first_unstable_pulses, w.slipped, w.executions)
    resonance = resonance_findings(stages, motor, strict=strict)
    ordered = not any(f.rule == "stall-order" for f in criterion)
    verdicts = tuple((name, FAMILIES[name](stages, motor, aim_deg=aim_deg,
                                           load_angle=load_angle, samples=samples, seed=seed,
                                           moves=moves, progress=progress))
                     for name in families if ordered)
    return SafetyVerdict(moves, aim_deg, tuple(criterion), la, box, tuple(resonance),
                         verdicts)


def _judge_ramp(ramp: AlinkRamp, motor: Motor, *, pulses: Iterable[int] | None,
                samples: int, seed: int, aim_deg: float, load_angle: bool,
                homing: HomingSettings | None, strict: bool,
                commands: Iterable[str] | None = None) -> SafetyVerdict:
    """`judge_safety` on the A-Link unit's ramp (verify.alink_safety); `commands` names
    the unit's commands (`stepramp alink command`) whose families are judged."""
    from profiles.motor.tolerance import corners, worst_case_motor

    from . import alink_safety as al

    families = al.alink_families(commands)  # an unknown command is refused before any work

    moves = None if pulses is None else tuple(sorted({int(n) for n in pulses}))
    criterion = al.ramp_criterion(ramp, worst_case_motor(motor) if motor.tolerances
                                  else motor, homing)
    if motor.tolerances:
        criterion = [f.with_message(f.message + " (at the tolerance box's worst case)")
                     for f in criterion]
    resonance = tuple(al.ramp_resonance(ramp, motor, strict=strict))
    if not load_angle:
        return SafetyVerdict(moves, aim_deg, tuple(criterion), None, None, resonance)
    box_corners = corners(motor) if motor.tolerances else []
    ways = al.ways_of(motor)
    rot = al.box_rotors([c.motor for c in box_corners] or [motor], ways)
    found, verdicts = al.judged(ramp, motor, rot, moves, homing, aim_deg, families)
    deg, row, e = found.worst()
    where = box_corners[row // len(ways)].describe() if box_corners else "nominal"
    la = LoadAngle(deg, int(found.x[e]), int(rot.direction[row]), where,
                   found.first_unstable(), bool(found.slipped.any()), found.deg.size)
    box = _ramp_box(ramp, motor, found, la, len(box_corners), len(ways), samples, seed) \
        if box_corners else None
    if box is not None:
        la = LoadAngle(box.worst_angle_deg, box.worst_pulses, box.worst_direction,
                       box.worst_where, box.first_unstable_pulses, box.slips,
                       box.executions, box.sample_failures)
    return SafetyVerdict(moves, aim_deg, tuple(criterion), la, box, resonance, verdicts)


def _ramp_box(ramp: AlinkRamp, motor: Motor, found: Any, corner: LoadAngle, n_corners: int,
              n_ways: int, samples: int, seed: int) -> Any:
    """The tolerance box's verdict on the unit's moves: the corners (rows of `found`), the
    Monte Carlo samples on the moves worst at some corner."""
    import numpy as np

    from profiles.alink.ramp import RAMP_HZ
    from profiles.motor.tolerance import clopper_pearson_upper

    from . import alink_safety as al
    from .tolerance_box import CONFIDENCE, BoxVerdict, batch_sample_peaks

    per_corner = found.deg.reshape(n_corners, n_ways, -1).max(axis=1)
    sampled = tuple(sorted({int(found.x[k]) for k in np.argmax(per_corner, axis=1)}))
    worst = (corner.worst_deg, corner.worst_at, corner.worst_pulses, corner.worst_direction)
    sample_worst, failures, unstable = -1.0, 0, corner.first_unstable_pulses
    if samples:
        peaks, which, way = batch_sample_peaks(al.batch(ramp, "move", np.asarray(sampled)),
                                               RAMP_HZ, motor, samples, seed)
        failures = int(np.sum(peaks >= PEAK_DEG))
        i = int(np.argmax(peaks))
        sample_worst = float(peaks[i])
        if sample_worst > worst[0]:
            worst = (sample_worst, f"sample {i}", sampled[int(which[i])], int(way[i]))
        if failures:
            first = min(sampled[int(k)] for k in which[peaks >= PEAK_DEG])
            unstable = first if unstable is None else min(unstable, first)
    bound = clopper_pearson_upper(failures, samples, CONFIDENCE) if samples else 1.0
    return BoxVerdict(worst[0], worst[1], worst[2], worst[3], n_corners, corner.worst_deg,
                      samples, seed, sample_worst, failures, sampled, bound, unstable,
                      corner.slips, corner.executions + samples * len(sampled))


def _criterion(table: FreeCurveTable, motor: Motor,
               moves: tuple[int, ...] | None) -> list[Finding]:
    """The criterion's findings; over a tolerance box at its worst case (exact)."""
    from .criterion import check_stall

    if not motor.tolerances:
        return check_stall(table, motor, pulses=moves)
    from profiles.motor.tolerance import worst_case_motor

    return [f.with_message(f.message + " (at the tolerance box's worst case)")
            for f in check_stall(table, worst_case_motor(motor), pulses=moves)]


__all__ = ["AIM_DEG", "DEFAULT_SAMPLES", "LoadAngle", "SafetyVerdict", "judge_safety"]
