"""Several axes, one move: what every device's synchronised plan shares.

A synchronised plan (a device's `sync` package: PPMC-312 tables, A-Link settings) has
axes that each know their move's `duration_s` and their own fastest move's `fastest_s`.
`SyncTimes` gives the plan's times from them; `spread_tolerance_s` is the finish spread
a move may have (docs/manual-notes.md, "Synchronised axes"); the line deviation of the
joint path is `profiles.pulses.line_deviation` over each axis's pulse train.

Device-neutral: no device and no motor here (the devices import this, never the other
way round).
"""

from __future__ import annotations

from typing import Any, Literal

Mode = Literal["time", "line"]
MODES: tuple[Mode, ...] = ("time", "line")

SPREAD_REL = 1e-3          # finish spread allowed: 0.1 % of the move …
SPREAD_ABS_S = 200e-6      # … or 200 µs, whichever is larger


def spread_tolerance_s(duration_s: float) -> float:
    """The finish spread allowed for a move of `duration_s`."""
    return max(SPREAD_REL * duration_s, SPREAD_ABS_S)


class SyncTimes:
    """The times of a plan whose axes each have `duration_s` and `fastest_s`."""

    axes: tuple[Any, ...]

    @property
    def duration_s(self) -> float:
        return max(a.duration_s for a in self.axes)

    @property
    def spread_s(self) -> float:
        d = [a.duration_s for a in self.axes]
        return max(d) - min(d)

    @property
    def unsynchronised_s(self) -> float:
        """The slowest axis's fastest move: no synchronised move can be shorter."""
        return max(a.fastest_s for a in self.axes)

# The C header of every axis that a synchronised move's files include (axes.h): its
# include guard is STEPRAMP_SYNC_H; each axis's symbols carry the axis's name.
SYNC_HEADER_NAME = "stepramp_sync"
SYNC_HEADER_FILE = "axes.h"
