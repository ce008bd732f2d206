"""The A-Link unit's safety verdict (the registry's `safety` entry of the A-Link, which
`verify.safety.judge_safety` hands the unit's ramps: `judge_ramp`) on its ramp's motions
(`safety`: every move length, the decel stops, the homing legs, the command families'
envelopes), over the motor's tolerance box (its corners, then Monte Carlo samples on the
moves worst at some corner); and that verdict as the planner's judge
(`settings_judge`, which `planner.tighten_settings` takes).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from ..verdict import DEFAULT_SAMPLES

if TYPE_CHECKING:
    from ..motor import Motor
    from ..progress import Progress
    from ..verdict import LoadAngle, SafetyVerdict
    from .model import AlinkSettings
    from .planner import HomingSettings, SettingsJudge
    from .ramp import AlinkRamp


def judge_ramp(ramp: AlinkRamp, motor: Motor, *, pulses: Iterable[int] | None = None,
               samples: int = DEFAULT_SAMPLES, seed: int = 0, aim_deg: float | None = None,
               strict: bool = False, load_angle: bool = True,
               commands: Iterable[str] | None = None, progress: Progress | None = None,
               homing: HomingSettings | None = None) -> SafetyVerdict:
    """`judge_safety` on the A-Link unit's ramp (safety.py; the registry's
    `safety` entry of the A-Link): the unit's criterion, every move length on the load
    angle over the box, and as its command families the decel stops (STOP 31) from every
    pulse of the ramp and, with `homing`, the homing legs (OL/OH, O_UPTIME, the stop at
    once at the origin); `commands` names the unit's commands (`stepramp alink
    command`) whose families are judged. `progress` is not reported: the unit's verdict
    is one batch."""
    from profiles.motor.tolerance import corners, worst_case_motor
    from profiles.verdict import LoadAngle, SafetyVerdict, require_aim

    from . import safety as al

    if aim_deg is None:  # the motor's landmarks load numpy: read on use
        from profiles.motor.angles import AIM_DEG

        aim_deg = AIM_DEG
    require_aim(aim_deg)

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
    from profiles.motor.angles import PEAK_DEG
    from profiles.motor.batch_angle import batch_sample_peaks
    from profiles.motor.tolerance import clopper_pearson_upper
    from profiles.verdict import CONFIDENCE, BoxVerdict

    from . import safety as al

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


def settings_judge(motor: Motor, *, aim_deg: float) -> SettingsJudge:
    """The one verdict (`judge_safety`) as the A-Link planner's judge
    (`profiles.alink.planner.tighten_settings`): within the aim or not, the worst angle,
    and the lever it blames — the start speed when the worst is a short move, an early
    decel stop or the start itself (its speed in the lowest 30 % of the ramp), else the
    ramp."""
    from profiles.alink.planner import Judgement
    from profiles.alink.ramp import ramp_of

    def judged(settings: AlinkSettings) -> Judgement:
        ramp = ramp_of(settings)
        v = judge_ramp(ramp, motor, samples=0, aim_deg=aim_deg)
        rules = {f.rule for f in v.criterion}
        worst, speed, what = _worst_speed(ramp, v)
        near_start = speed <= ramp.start_pps + START_SHARE * (ramp.high_pps - ramp.start_pps)
        # a command family past the aim at its use from L (a stop at once, a limit run)
        from_start = any(not c.within_aim and name in ("stop", "limit")
                         for name, c in v.commands)
        start = "stall-start-speed" in rules or from_start or (not rules and near_start)
        return Judgement(v.within_aim and v.safe, worst, "start" if start else "ramp", what)

    return judged


START_SHARE = 0.3   # a worst angle peaking below L + this × (H − L) is the start speed's


def _worst_speed(ramp: AlinkRamp, v: SafetyVerdict) -> tuple[float, float, str]:
    """(the worst angle over the moves and the decel stops, the speed its motion peaks at,
    a phrase naming it)."""
    import numpy as np

    from profiles.alink.ramp import parts

    la = v.load_angle
    best = (-1.0, float(ramp.start_pps), "nothing judged")
    if la is not None:
        up = int(parts(ramp, "move", np.array([la.worst_pulses])).up[0])
        best = (la.worst_deg, _speed_at(ramp, up), f"a move of {la.worst_pulses} pulses")
    for name, c in v.commands:
        deg = float(c.to_json()["worst_load_angle_deg"])
        if name == "decel-stop" and deg > best[0]:
            x = int(c.to_json()["worst_at"])
            best = (deg, _speed_at(ramp, x), f"a decel stop from pulse {x} of the ramp")
    return best


def _speed_at(ramp: AlinkRamp, pulse: int) -> float:
    """The speed of the ramp's stage holding pulse `pulse` (H past the ramp)."""
    import numpy as np

    ends = np.cumsum(ramp.pulses)
    k = int(np.searchsorted(ends, pulse, side="left"))
    return float(ramp.speeds_pps[k]) if k < len(ends) else float(ramp.high_pps)


__all__ = ["START_SHARE", "judge_ramp", "settings_judge"]
