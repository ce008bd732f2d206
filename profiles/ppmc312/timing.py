"""How long the PPMC-312 works on a table command before it takes a motion command.

The one model of these windows; the serial link (`link.py`) waits them out and the
serial emulator (`serial_chip.py`) refuses a motion command inside them. The manual:

- §7-1, after an init: 「命令の書込後、直線加減速共通で115mS、直線加減速別々で200mS、
  S字175mS後に動作命令の受付が可能となります。」 (115 ms linear LE=0, 200 ms linear
  LE=1, 175 ms S-curve, whatever its LE);
- §7-2 gives no figure for the free curve, and §21-4.4 names only the init (800 ms),
  the move (400/800 ms) and two high-rate commands (300 µs) among the commands during
  whose processing the inputs are not watched; every other command, the free curve
  included, is processed within 100 µs (「その他の命令の場合、100 μS の間、監視できま
  せん」). The chip builds nothing from a free curve (every stage comes ready), so we
  take those 100 µs, counted from its last block (header 01, the one that executes it).
  docs/manual-notes.md ("Serial link: the time the chip needs") records the reading.

A window counts from when the chip has the whole command. A master cannot know that
instant, only that it precedes the reply, so it counts from the reply: never too early.
"""

from __future__ import annotations

from dataclasses import dataclass

from .table import FreeCurveTable, InitTable

# (shape, LE=1) → seconds before a motion command is accepted after an init (§7-1).
INIT_WINDOWS_S: dict[tuple[str, bool], float] = {
    ("linear", False): 0.115,
    ("linear", True): 0.200,
    ("s_curve", False): 0.175,
    ("s_curve", True): 0.175,   # §7-1 gives S-curves one figure for both LEs
}
# §21-4.4: the processing of "other commands", the free curve among them.
FREE_CURVE_WINDOW_S = 100e-6


@dataclass(frozen=True)
class Window:
    """`seconds` after a table command before the chip accepts a motion command;
    `why` says so in one line, naming the manual's section."""

    seconds: float
    why: str


def motion_window(table: InitTable | FreeCurveTable) -> Window:
    """The window after the command that sets `table` (an init or a free curve)."""
    if isinstance(table, FreeCurveTable):
        return Window(FREE_CURVE_WINDOW_S, "the chip accepts motion commands "
                      f"{ms(FREE_CURVE_WINDOW_S)} ms after a free curve's last block "
                      "(§21-4.4: the free curve is among the 'other commands', 100 µs)")
    seconds = INIT_WINDOWS_S[(table.shape, table.separate)]
    return Window(seconds, f"the chip accepts motion commands {ms(seconds)} ms after an "
                           "init (§7-1)")


def ms(seconds: float) -> str:
    """`seconds` in milliseconds, four significant digits at most (115, 0.1, 87.35)."""
    return f"{seconds * 1e3:.4g}"


__all__ = ["FREE_CURVE_WINDOW_S", "INIT_WINDOWS_S", "Window", "motion_window", "ms"]
