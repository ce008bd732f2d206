"""The one result noun every planner returns.

A planner produces something a device runs (a PPMC-312 free-curve or init table,
A-Link ALUM settings) and knows how long the move takes, what stopped it from
doing better, and how long it thought. The same fields for every planner let
the CLI, the comparisons and the notebooks treat planners alike; what only one
planner knows goes into `extras`, keyed by a name with its unit.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Generic, Protocol, TypeVar

T = TypeVar("T")


class TimeBase(Protocol):
    """What a plan result says of the clock a device's table runs on (the PPMC-312's
    `profiles.ppmc312.clock.Clock` is one): the shared noun knows no device."""

    @property
    def name(self) -> str: ...

    @property
    def hz(self) -> float: ...


@dataclass(frozen=True)
class PlanResult(Generic[T]):
    """What a planner produced and why it is not faster.

    - `table`: what the device runs (a table, or for the A-Link its settings);
    - `duration_s`: the modelled move of `pulses`; None when planned without a move
      length (the A-Link's long-move setting);
    - `binds`: what limits the plan, a short phrase ("top speed", "stall criterion …");
    - `info`: one line for people;
    - `clock`: the clock the table runs on (a PPMC-312 `Clock`; None for other devices);
    - `solve_s`: wall time of the planning;
    - `warnings`: what the planner had to round or give up, one line each;
    - `extras`: planner-specific numbers (e.g. the quantiser's `max_step_error_us`).
    """

    table: T
    duration_s: float | None
    binds: str
    info: str
    pulses: int | None = None
    clock: TimeBase | None = None
    solve_s: float = 0.0
    warnings: tuple[str, ...] = ()
    extras: Mapping[str, Any] = field(default_factory=dict, hash=False)
