"""A table against the continuous time optimum: the numbers behind `stepramp compare`.

The table's time is what the chip runs (`profiles.ppmc312.execution`, exact ticks); the
references are continuous profiles on the same move (`verify.references`);
the stall margin is capability / need over the table's stages (`verify.criterion`).
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

    @property
    def safe(self) -> bool:
        """Both judges pass the move asked for."""
        return self.move_verdict.safe

    @property
    def failed_judges(self) -> list[str]:
        return list(self.move_verdict.failed)

    @property
    def criterion(self) -> list[Any]:
        """The criterion's findings on the move (verify.findings.Finding)."""
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

    def figure(self) -> Any:
        from verify.plot import comparison_figure

        return comparison_figure(self)

    def plot(self, path: str | Path) -> None:
        from verify.plot import save_figure

        save_figure(self.figure(), path)


def compare_table(table: Table, motor: Motor, pulses: int, *,
                  include: tuple[str, ...] = DEFAULT_REFERENCES,
                  physics: bool = True) -> Comparison:
    """The table's move of `pulses` against the references, and the safety verdict on that
    move and on every move (`physics`: with the load angle)."""
    from profiles.ppmc312.execution import simulate_move
    from profiles.ppmc312.init_model import as_free_curve
    from verify.criterion import stall_margins
    from verify.references import best_reference, references
    from verify.safety import judge_safety

    table = as_free_curve(table)
    execution = simulate_move(table, pulses)
    refs = references(motor, pulses, include=include)
    best = best_reference(refs)
    optimum = next(name for name, r in refs.items() if r is best)
    return Comparison(table=table, motor=motor, pulses=pulses, execution=execution,
                      references=refs, optimum=optimum, margins=stall_margins(table, motor),
                      move_verdict=judge_safety(table, motor, pulses=[pulses],
                                                load_angle=physics),
                      every_verdict=judge_safety(table, motor, load_angle=physics))


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None
