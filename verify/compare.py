"""A table against the continuous time optimum: the numbers behind `stepramp compare`.

The table's time is what the chip runs (`profiles.ppmc312.execution`, exact ticks); the
references are continuous profiles on the same move (`verify.references`);
the stall margin is capability / need over the table's stages (`verify.stall`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from profiles.motor import Motor
from profiles.ppmc312.table import FreeCurveTable, Table
from verify.references import SOLVERS as DEFAULT_REFERENCES


@dataclass
class Comparison:
    table: FreeCurveTable
    motor: Motor
    pulses: int
    execution: Any  # profiles.ppmc312.execution.Execution
    references: dict[str, Any]  # name -> verify.references.Reference
    optimum: str
    margins: dict[str, Any]
    physics: Any = None  # verify.physics.PhysicsResult
    extra: dict[str, Any] = field(default_factory=dict)

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
            "references": refs,
        }
        if self.jerk_limited_optimum is not None:
            out["jerk_limited_optimum_s"] = self.jerk_limited_optimum.duration_s
        if self.physics is not None:
            out["physics"] = {"worst_lag_full_steps": self.physics.worst_lag_full_steps,
                              "stalled": self.physics.stalled,
                              "stall_time_s": self.physics.stall_time_s}
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
        if self.physics is not None:
            verdict = "STALLS" if self.physics.stalled else "no stall"
            lines.append(f"load-angle simulation: worst lag "
                         f"{self.physics.worst_lag_full_steps:.3f} full steps, {verdict}")
        return "\n".join(lines) + "\n"

    def figure(self) -> Any:
        from verify.plot import comparison_figure

        return comparison_figure(self)

    def plot(self, path: str | Path) -> None:
        from verify.plot import save_figure

        save_figure(self.figure(), path)


def compare_table(table: Table, motor: Motor, pulses: int, *,
                  include: tuple[str, ...] = DEFAULT_REFERENCES,
                  physics: bool = False) -> Comparison:
    from profiles.ppmc312.execution import simulate_move
    from profiles.ppmc312.init_model import as_free_curve
    from verify.references import best_reference, references
    from verify.stall import stall_margins

    table = as_free_curve(table)
    execution = simulate_move(table, pulses)
    refs = references(motor, pulses, include=include)
    best = best_reference(refs)
    optimum = next(name for name, r in refs.items() if r is best)
    result = Comparison(table=table, motor=motor, pulses=pulses, execution=execution,
                        references=refs, optimum=optimum, margins=stall_margins(table, motor))
    if physics:
        from verify.physics import load_angle_check

        result.physics = load_angle_check(execution, motor)
    return result


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None
