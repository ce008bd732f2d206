"""Is this table safe? The one verdict every command asks for.

`judge_safety` hands the table to its device's judge, found in the registry
(`verify.devices`: the device whose package made the table's type, its `safety` entry):
the PPMC-312's tables to `profiles.ppmc312.safety.judge_table`, the A-Link unit's ramp to
`profiles.alink.verdict.judge_ramp` (on `profiles.alink.safety`). Each judge lives beside
its device's rules, refuses an aim outside [1°, 90°] and speaks the verdict's nouns
(`profiles.verdict`: `SafetyVerdict`, `LoadAngle`, `BoxVerdict`).

`aim_deg` (75° unless asked otherwise: `AIM_DEG`) is what planners aim at: a table
past it but below 90° is safe with a warning. Resonance dwells are warnings, errors
with `strict`. `check`, `plan`, `compare`, `sync`, `sweep`, the designer and the
notebooks all call `judge_safety` and show its `to_json()`.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from profiles.motor import Motor
from profiles.motor.angles import AIM_DEG
from profiles.progress import Progress
from profiles.verdict import DEFAULT_SAMPLES, LoadAngle, SafetyVerdict

if TYPE_CHECKING:
    from profiles.alink.planner.homing import HomingSettings
    from profiles.alink.ramp import AlinkRamp
    from profiles.ppmc312.table import FreeCurveTable, InitTable


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
    verdict of its own (`profiles.ppmc312.command_verdicts.FAMILIES`: a decel stop (81) at every
    pulse of the ramp under every reading) is judged alike; `commands` (names or hex
    codes of `motion.COMMANDS`; None: all) narrows them for a machine that never runs
    the others. A decel stop may come during any move, or a continuous run (85): its
    stops are judged over the whole ramp whatever `pulses` says.

    An A-Link ALUM ramp (`profiles.alink.ramp.AlinkRamp`, the unit's settings as stages)
    is judged alike (`profiles.alink.safety`): the unit's criterion, every move length on
    the load angle over the box, and as its command families the decel stops (STOP 31)
    from every pulse of the ramp and, with `homing`, the homing legs (OL/OH, O_UPTIME, the
    stop at once at the origin)."""
    from .devices import safety_judge

    judge = safety_judge(table)  # each device's judge refuses an aim outside [1°, 90°]
    # the homing legs are the A-Link unit's alone: the other judges take no `homing`
    extra: dict[str, Any] = {} if homing is None else {"homing": homing}
    return judge(table, motor, pulses=pulses, samples=samples, seed=seed, aim_deg=aim_deg,
                 strict=strict, load_angle=load_angle, commands=commands, progress=progress,
                 **extra)


__all__ = ["AIM_DEG", "DEFAULT_SAMPLES", "LoadAngle", "SafetyVerdict", "judge_safety"]
