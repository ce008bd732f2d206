"""A table against the continuous time optimum: the numbers behind `stepramp compare`.

The table's time is what the chip runs (`profiles.ppmc312.execution`, exact ticks); the
references are continuous profiles on the same move (`verify.references`);
the stall margin is capability / need over the table's stages (`profiles.ppmc312.criterion`).
The table is judged by the one verdict (`verify.safety.judge_safety`) twice: on the move
asked for, and on every move the table can run (what the chip does with it for other
lengths); `safe` is the move's verdict.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from profiles.motor import Motor
from profiles.ppmc312.table import FreeCurveTable, Table
from verify.references import SOLVERS as DEFAULT_REFERENCES
from verify.safety import SafetyVerdict

EVERY_MOVE = "every move"  # the every-move lines' prefix, where check names the file
START_MATCH = 0.005        # relative: a table starting within 0.5 % of v0 starts with them


@dataclass
class Comparison:
    table: FreeCurveTable
    motor: Motor
    pulses: int
    execution: Any  # profiles.ppmc312.execution.Execution
    references: dict[str, Any]  # name -> verify.references.Reference
    optimum: str
    margins: dict[str, Any]
    move_verdict: SafetyVerdict       # the move asked for
    every_verdict: SafetyVerdict      # every move the table can run
    extra: dict[str, Any] = field(default_factory=dict)
    # the references asked for whose solver failed: name → reason (`solve_references`)
    failed_references: dict[str, str] = field(default_factory=dict)
    # the exact optimum from the table's own start speed, when the references' start (the
    # motor's) differs from it by more than START_MATCH (the plan lowered its start speed)
    from_table_start: Any = None

    @property
    def safe(self) -> bool:
        """Both judges pass the move asked for."""
        return self.move_verdict.safe

    @property
    def failed_judges(self) -> list[str]:
        return list(self.move_verdict.failed)

    @property
    def criterion(self) -> list[Any]:
        """The criterion's findings on the move (profiles.findings.Finding)."""
        return list(self.move_verdict.criterion)

    @property
    def table_s(self) -> float:
        return float(self.execution.duration_s)

    @property
    def optimum_s(self) -> float:
        return float(self.references[self.optimum].duration_s)

    @property
    def ratio(self) -> float:
        return self.table_s / self.optimum_s

    @property
    def jerk_limited_optimum(self) -> Any:
        """With a jerk limit, casadi's jerk-limited move (the jerk-free optimum stays the
        lower bound a staircase is measured against: its stall rule limits slope changes
        of the ramp through stage starts, which is not the same as a continuous jerk)."""
        if self.motor.max_jerk_pps3 is None:
            return None
        return self.references.get("casadi")

    @property
    def stall_margin(self) -> float:
        return float(self.margins["min"])

    def to_json(self) -> dict[str, Any]:
        refs = {name: {"duration_s": r.duration_s, "ratio": self.table_s / r.duration_s,
                       "solve_s": r.solve_s, "info": r.info}
                for name, r in self.references.items()}
        out: dict[str, Any] = {
            "pulses": self.pulses, "shape": self.execution.shape,
            "table_s": self.table_s, "optimum": self.optimum, "optimum_s": self.optimum_s,
            "ratio": self.ratio, "stall_margin": _finite(self.stall_margin),
            "references": refs, "safe": self.safe, "failed_judges": self.failed_judges,
            "safety": {"move": self.move_verdict.to_json(),
                       "every_move": self.every_verdict.to_json()},
        }
        if self.jerk_limited_optimum is not None:
            out["jerk_limited_optimum_s"] = self.jerk_limited_optimum.duration_s
        if self.failed_references:
            out["failed_references"] = dict(self.failed_references)
        out.update(self.real_units())
        if self.from_table_start is not None:
            out["from_table_start"] = {"start_pps": self.table_start_pps,
                                       "reference_start_pps": self.reference_start_pps,
                                       "exact_s": self.from_table_start.duration_s}
        return out

    def to_text(self) -> str:
        lines = [f"move: {self.pulses} pulses ({self.execution.shape})",
                 f"table:   {self.table_s * 1e3:10.3f} ms",
                 f"optimum: {self.optimum_s * 1e3:10.3f} ms ({self.optimum}); "
                 f"ratio {self.ratio:.4f}"]
        for name, r in self.references.items():
            lines.append(f"  {name:8s} {r.duration_s * 1e3:10.3f} ms  table/ref "
                         f"{self.table_s / r.duration_s:.4f}  (solve {r.solve_s * 1e3:.1f} ms)"
                         + (f"  {r.info}" if r.info else ""))
        lines += [f"  {name:8s} failed ({why}): not drawn, not in the optimum"
                  for name, why in self.failed_references.items()]
        lines.append(self.real_units_line())
        lines += self.start_lines()
        jerk = self.jerk_limited_optimum
        if jerk is not None:
            lines.append(f"jerk-limited optimum (casadi): {jerk.duration_s * 1e3:.3f} ms; "
                         f"table/that {self.table_s / jerk.duration_s:.4f}")
        lines.append(f"smallest stall margin: {self.stall_margin:.3f} (capability / need; "
                     f"≥ 1 is stall-safe)")
        lines.append("criterion: " + ("passes" if not self.criterion else
                                      f"FAILS ({len(self.criterion)} finding(s))"))
        lines += [f"  [{f.rule}] {f.message}" for f in self.criterion]
        lines.append(f"this move: {self.move_summary()}")
        lines += self.every_move_lines()
        verdict = "SAFE" if self.safe else "UNSAFE (failed: " + ", ".join(self.failed_judges) + ")"
        lines.append(f"verdict: {verdict}")
        return "\n".join(lines) + "\n"

    def real_units(self) -> dict[str, Any]:
        """The move in mm (the motor file's `travel_mm_per_rev`) or rev, and the table's
        top and mean speed and the optimum's mean speed in mm/s or rpm
        (profiles/motor/travel.py): JSON keys beside the pulse ones."""
        from profiles.motor.travel import axis_units

        u = axis_units(self.motor)
        d, v = u.distance_key, u.speed_key
        top = float(max(self.execution.edges()[2]))
        return {"travel_mm_per_rev": u.mm_per_rev, f"move_{d}": u.distance(self.pulses),
                "table_top_pps": top, f"table_top_{v}": u.speed(top),
                f"table_mean_{v}": u.speed(self.pulses / self.table_s),
                f"optimum_mean_{v}": u.speed(self.pulses / self.optimum_s)}

    def real_units_line(self) -> str:
        """`in mm: a move of 16 mm; the table's top 111.7 mm/s, its mean 60.1 mm/s; the
        optimum's mean 70.3 mm/s` (or rev and rpm)."""
        from profiles.motor.travel import axis_units

        u = axis_units(self.motor)
        top = float(max(self.execution.edges()[2]))
        return (f"in {u.distance_unit}: a move of {u.distance_text(self.pulses)}; the "
                f"table's top {u.speed_text(top)}, its mean "
                f"{u.speed_text(self.pulses / self.table_s)}; the optimum's mean "
                f"{u.speed_text(self.pulses / self.optimum_s)}")

    def start_lines(self) -> list[str]:
        """When the table starts at another speed than the references (the motor's start
        speed): both speeds and the exact optimum from the table's start."""
        ref = self.from_table_start
        if ref is None:
            return []
        return [f"references start at the motor's start speed {self.reference_start_pps:.6g} "
                f"pps, the table at {self.table_start_pps:.6g} pps; the exact optimum from "
                f"{self.table_start_pps:.6g} pps: {ref.duration_s * 1e3:.3f} ms, table/that "
                f"{self.table_s / ref.duration_s:.4f}"]

    @property
    def table_start_pps(self) -> float:
        """The speed the table's move starts at (its slowest stage)."""
        return float(self.execution.edges()[2][0])

    @property
    def reference_start_pps(self) -> float:
        """The speed every reference starts and ends at (the motor's v0)."""
        return float(self.references["exact"].v_pps[0])

    def load_angle_curves(self) -> list[tuple[str, Any]]:
        """The move's load angle against time
        (`profiles.ppmc312.load_angle_trace.LoadAngleTrace`), each with its label: the
        nominal motor forward, and the motor and direction where the move's verdict found
        its worst when that is another (a tolerance-box corner or the backward move); none
        when the load angle was not judged (--no-physics)."""
        from profiles.motor.tolerance import corners
        from profiles.ppmc312.load_angle_trace import trace_load_angle

        worst = self.move_verdict.load_angle
        if worst is None:
            return []
        out = [("nominal, forward", trace_load_angle(self.execution, self.motor))]
        at = {c.label: c.motor for c in corners(self.motor)}.get(worst.worst_at)
        if worst.worst_at == "nominal":
            at = None
        if at is not None or (worst.worst_at == "nominal" and worst.worst_direction < 0):
            way = "forward" if worst.worst_direction > 0 else "backward"
            out.append((f"{worst.worst_at}, {way} (the verdict's worst)",
                        trace_load_angle(self.execution, at or self.motor,
                                         direction=worst.worst_direction)))
        return out

    def move_summary(self) -> str:
        """The move asked for in one line: safe or not, its worst load angle (its decel
        stops are every move's: the lines of `every_move_lines` say them)."""
        v = self.move_verdict
        head = "SAFE" if v.safe else "UNSAFE (failed: " + ", ".join(v.failed) + ")"
        return head + ("" if v.load_angle is None else f"; {v.load_angle.describe()}")

    def every_move_lines(self) -> list[str]:
        """Every move the table can run, reported as `stepramp check --motor` reports it
        (verify.report): the findings, a rule's many folded, then the notes."""
        from verify.report import FileResult, file_lines

        v = self.every_verdict
        found = v.findings()
        result = FileResult(EVERY_MOVE, not any(f.severity == "error" for f in found),
                            found, notes=v.notes())
        return file_lines(result)[0]

    def figure(self, motor_label: str | None = None) -> Any:
        """The figure (`verify.plot.comparison_figure`), with the move's load angle;
        `motor_label` names the motor where its file has no name (its file's stem)."""
        from verify.plot import comparison_figure

        return comparison_figure(self, angles=self.load_angle_curves(), motor_label=motor_label)

    def plot(self, path: str | Path, motor_label: str | None = None) -> None:
        from verify.plot import save_figure

        save_figure(self.figure(motor_label), path)


def compare_table(table: Table, motor: Motor, pulses: int, *,
                  include: tuple[str, ...] = DEFAULT_REFERENCES,
                  physics: bool = True) -> Comparison:
    """The table's move of `pulses` against the references, and the safety verdict on that
    move and on every move (`physics`: with the load angle)."""
    from profiles.ppmc312.criterion import stall_margins
    from profiles.ppmc312.execution import simulate_move
    from profiles.ppmc312.init_model import as_free_curve
    from verify.references import best_reference, solve_references
    from verify.safety import judge_safety

    table = as_free_curve(table)
    execution = simulate_move(table, pulses)
    # the continuous side first, then the device's: the motor goes down into the device's
    # room (its one verdict, twice, then its margins) and does not come back up
    # (tests/repo/test_walk.py)
    start = from_start(motor, pulses, execution)
    refs, failed = solve_references(motor, pulses, include=include)
    best = best_reference(refs)
    optimum = next(name for name, r in refs.items() if r is best)
    move_verdict = judge_safety(table, motor, pulses=[pulses], load_angle=physics)
    every_verdict = judge_safety(table, motor, load_angle=physics)
    return Comparison(table=table, motor=motor, pulses=pulses, execution=execution,
                      references=refs, optimum=optimum, margins=stall_margins(table, motor),
                      move_verdict=move_verdict, every_verdict=every_verdict,
                      failed_references=failed, from_table_start=start)


def from_start(motor: Motor, pulses: int, execution: Any) -> Any:
    """The exact optimum of the move from the table's start speed (a motor whose start
    and largest jump are that speed), or None when the table starts where the references
    do (within START_MATCH) or the motor cannot start there."""
    from dataclasses import replace

    from profiles.errors import StepRampError
    from verify.references import exact_optimum, move_limits

    v_table = float(execution.edges()[2][0])
    v0 = move_limits(motor, pulses).v0_pps
    if abs(v_table - v0) <= START_MATCH * v0:
        return None
    try:
        return exact_optimum(replace(motor, start_pps=v_table, max_jump_pps=None), pulses)
    except (StepRampError, ValueError):  # a start past the curve: no such optimum
        return None


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None
