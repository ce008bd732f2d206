"""The one safety verdict as the init-table planner's judge (issue 33 item 2).

`profiles.ppmc312.planner.init_planner.tighten_init` plans an init table again, gentler, while
its judge says the table is past the load-angle aim; profiles never import verify, so
the planner takes the judge as a callable and `stepramp plan --kind linear|s-curve`
hands it this one: the table's verdict (`safety.judge_table`, which
`verify.safety.judge_safety` gives too) on the table (every move length, every
command family `commands` leaves, the tolerance box), its word cut down to what the
planner needs (`InitJudgement`): safe, within the aim, and the worst angles by the
lever they come from.

- the **start** lever: a move short enough to stay near rest (its ramp pulse, half its
  length, within the first START_SHARE of the accel ramp), a decel stop (81) that early
  on the ramp, and the commands run from the start speed (constant 83, origin search
  10, immediate stop 80 and the limits, and the origin return 11, whose reversal jumps
  by twice the start speed);
- the **ramp** lever: the rest (longer moves, stops further up, an immediate speed
  change 88 at the top, a criterion finding).

A Monte Carlo sample past the 90° peak counts as the peak.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from profiles.motor import Motor
from profiles.motor.angles import AIM_DEG, PEAK_DEG
from profiles.ppmc312.planner.init_planner import START_PARTS, InitJudgement
from profiles.ppmc312.table import InitTable

START_SHARE = 0.25   # the share of the accel ramp (from rest) whose ringing the start drives
START_PULSES_MIN = 16  # and at least these pulses of it


def init_judge(motor: Motor, *, aim_deg: float = AIM_DEG,
               commands: Iterable[str] | None = None) -> Callable[[InitTable], InitJudgement]:
    """The judge `tighten_init` takes: `judge_safety` on `motor` at `aim_deg` over the
    motion commands `commands` (None: all), as `judgement`."""
    from .safety import judge_table

    kept = None if commands is None else tuple(commands)

    def judge(table: InitTable) -> InitJudgement:
        return judgement(judge_table(table, motor, aim_deg=aim_deg, commands=kept), table)

    return judge


def judgement(verdict: Any, table: InitTable) -> InitJudgement:
    """A `profiles.verdict.SafetyVerdict` on `table` as the init planner reads it (module
    docstring): each part's angle, blamed on the start or on the ramp."""
    zone = max(START_PULSES_MIN, int(table.accel_pulses * START_SHARE))
    parts: list[tuple[str, float, bool, str]] = []   # (name, deg, the start's, where)
    if any(f.severity == "error" for f in verdict.criterion):
        parts.append(("criterion", PEAK_DEG, False, "nominal"))
    la = verdict.load_angle
    if la is not None:
        deg = la.worst_deg if la.sample_failures == 0 else max(la.worst_deg, PEAK_DEG)
        parts.append(("moves", deg, la.worst_pulses // 2 <= zone, la.worst_at))
    for name, v in verdict.commands:
        if name == "decel-stop":
            if v.worst_deg is not None:
                deg = v.worst_deg if v.sample_failures == 0 else max(v.worst_deg, PEAK_DEG)
                early = v.ramp_pulse is None or v.ramp_pulse <= zone
                parts.append((name, deg, early, v.worst_at))
        elif v.use_deg is not None:
            parts.append((name, v.use_deg, name in START_PARTS, "nominal"))
    start = max((d for _, d, s, _ in parts if s), default=0.0)
    ramp = max((d for _, d, s, _ in parts if not s), default=0.0)
    worst_at = max(parts, key=lambda p: p[1])[3] if parts else "nominal"
    failing = tuple(n for n, d, _, _ in parts if d > verdict.aim_deg)
    return InitJudgement(verdict.safe, verdict.within_aim, start, ramp, failing, worst_at)


__all__ = ["START_PULSES_MIN", "START_SHARE", "init_judge", "judgement"]
