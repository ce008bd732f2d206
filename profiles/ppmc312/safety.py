"""The PPMC-312's safety verdict on a table: what `verify.safety.judge_safety` gives for
a free-curve or init table (through the device registry), and what the init planner's
judge (`init_judge`) asks directly.

A table is stall-safe for a motor when every execution the chip can run with it (every
move length, both directions of a loaded move, every motor of the tolerance box) passes
both judges:

- the **criterion** (`criterion.check_stall`): every speed change the chip emits is one
  the motor's capability follows; over a tolerance box it is judged on the box's
  worst-case capability, which is exact over the box;
- the **load angle** (`load_angle`, the compiled rotor model): the rotor's lag stays on
  the stable side of the torque–angle curve, below the 90° peak (electrical degrees; it
  slips a pole at 180°); over a tolerance box at every corner and over seeded Monte
  Carlo samples (`tolerance_box`).

Besides every move (82), each motion command family with a verdict of its own
(`command_verdicts.FAMILIES`) is judged alike; resonance dwells are warnings, errors
with `strict`.
"""

from __future__ import annotations

from collections.abc import Iterable

from profiles.findings import Finding
from profiles.motor import Motor
from profiles.motor.angles import AIM_DEG
from profiles.progress import Progress
from profiles.verdict import DEFAULT_SAMPLES, BoxVerdict, LoadAngle, SafetyVerdict, require_aim

from .table import FreeCurveTable, InitTable


def judge_table(table: FreeCurveTable | InitTable, motor: Motor, *,
                pulses: Iterable[int] | None = None, samples: int = DEFAULT_SAMPLES,
                seed: int = 0, aim_deg: float = AIM_DEG, strict: bool = False,
                load_angle: bool = True, commands: Iterable[str] | None = None,
                progress: Progress | None = None) -> SafetyVerdict:
    """The verdict on `table` for `motor` over every execution the chip can run with it
    (`pulses`: only the moves of those lengths). A motor with tolerances is judged over
    its box: the criterion at the box's worst case, the load angle at every corner and
    over `samples` Monte Carlo samples (`seed`). `load_angle=False` judges the criterion
    and resonance only. `commands` (names or hex codes of `motion.COMMANDS`; None: all)
    narrows the command families judged besides every move; a decel stop may come during
    any move, or a continuous run (85): its stops are judged over the whole ramp whatever
    `pulses` says. An `aim_deg` outside [1°, 90°] is refused."""
    from .command_verdicts import FAMILIES, judged_families
    from .init_model import as_free_curve
    from .resonance import resonance_findings

    require_aim(aim_deg)
    families = judged_families(commands)  # an unknown command is refused before any work
    stages = as_free_curve(table)
    moves = None if pulses is None else tuple(sorted({int(n) for n in pulses}))
    criterion = _criterion(stages, motor, moves)
    ordered = not any(f.rule == "stall-order" for f in criterion)
    la, box = (_load_angle(stages, motor, moves, samples, seed, progress)
               if load_angle and ordered else (None, None))
    resonance = resonance_findings(stages, motor, strict=strict)
    verdicts = tuple((name, FAMILIES[name](stages, motor, aim_deg=aim_deg,
                                           load_angle=load_angle, samples=samples, seed=seed,
                                           moves=moves, progress=progress))
                     for name in families if ordered)
    return SafetyVerdict(moves, aim_deg, tuple(criterion), la, box, tuple(resonance),
                         verdicts)


def _load_angle(stages: FreeCurveTable, motor: Motor, moves: tuple[int, ...] | None,
                samples: int, seed: int, progress: Progress | None
                ) -> tuple[LoadAngle, BoxVerdict | None]:
    """The load angle's worst case over every move (or `moves`): over the tolerance box
    when the motor has one (with the box's verdict), else the nominal motor's."""
    from .load_angle import worst_load_angle

    if motor.tolerances:
        from .tolerance_box import judge_box

        box = judge_box(stages, motor, pulses=moves, samples=samples, seed=seed,
                        progress=progress)
        return LoadAngle(box.worst_angle_deg, box.worst_pulses, box.worst_direction,
                         box.worst_where, box.first_unstable_pulses, box.slips,
                         box.executions, box.sample_failures), box
    w = worst_load_angle(stages, motor, pulses=moves)
    return LoadAngle(w.worst_angle_deg, w.worst_pulses, w.worst_direction, "nominal",
                     w.first_unstable_pulses, w.slipped, w.executions), None


def _criterion(table: FreeCurveTable, motor: Motor,
               moves: tuple[int, ...] | None) -> list[Finding]:
    """The criterion's findings; over a tolerance box at its worst case (exact)."""
    from .criterion import check_stall

    if not motor.tolerances:
        return check_stall(table, motor, pulses=moves)
    from profiles.motor.tolerance import worst_case_motor

    return [f.with_message(f.message + " (at the tolerance box's worst case)")
            for f in check_stall(table, worst_case_motor(motor), pulses=moves)]


__all__ = ["judge_table"]
