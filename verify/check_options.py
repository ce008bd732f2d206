"""How `stepramp check` judges a file: the options every device's judge receives."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

# the tolerance box's Monte Carlo samples unless told otherwise (profiles.verdict, read
# without numpy): every judge's default, check's and sweep's --samples
from profiles.verdict import DEFAULT_SAMPLES

if TYPE_CHECKING:
    from profiles.motor import Motor
    from profiles.progress import Progress



@dataclass(frozen=True)
class CheckOptions:
    """`motor` adds the safety verdict (over every execution; `pulses`: only the moves of
    those lengths; `physics`: the load angle too; `samples`/`seed`: the tolerance box's
    Monte Carlo; `strict`: resonance dwells are errors; `commands`: the motion commands
    judged besides every move, names or hex codes, None: all, profiles.ppmc312.command_verdicts).
    `extck_hz`: the external clock of EXTCK uploads; `clock`: the clock of a table-read
    answer (which does not carry it)."""

    motor: Motor | None = None
    extck_hz: float | None = None
    clock: str | None = None
    pulses: Iterable[int] | None = None
    physics: bool = True
    samples: int = DEFAULT_SAMPLES
    seed: int = 0
    strict: bool = False
    progress: Progress | None = None
    commands: tuple[str, ...] | None = None
