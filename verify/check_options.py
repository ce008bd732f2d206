"""How `stepramp check` judges a file: the options every device's judge receives."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from profiles.motor import Motor
    from profiles.progress import Progress

# Monte Carlo samples of a motor's tolerance box, unless told otherwise: the default of
# check's and sweep's --samples and of the library's judges, here where the CLI reads it
# without numpy
DEFAULT_SAMPLES = 1000


@dataclass(frozen=True)
class CheckOptions:
    """`motor` adds the safety verdict (over every execution; `pulses`: only the moves of
    those lengths; `physics`: the load angle too; `samples`/`seed`: the tolerance box's
    Monte Carlo; `strict`: resonance dwells are errors; `commands`: the motion commands
    judged besides every move, names or hex codes, None: all, verify.command_verdicts).
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
