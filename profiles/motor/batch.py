"""Moves as flat segment arrays, whatever device runs them (`MoveBatch`): the input of
the load-angle verdict's compiled kernel (`batch_angle.judge`). A device builds its
batches from its own model of what it runs (the PPMC-312's executions:
`profiles.ppmc312.move_batch.moves`; the A-Link unit's motions: `profiles.alink.safety`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

Phase = Literal["accel", "cruise", "decel"]
PhaseRuns = list[tuple[Phase, int, int]]

PHASE_CODES = {"accel": 0, "cruise": 1, "decel": 2}
PHASES: tuple[Phase, ...] = ("accel", "cruise", "decel")

@dataclass(frozen=True)
class MoveBatch:
    """Moves of several lengths as flat segment arrays: move e is the segments
    offsets[e]..offsets[e+1] of (phase, rate, count); phase indexes PHASES, shape
    the device's own shapes (the PPMC-312's `move_batch.SHAPES`)."""

    pulses: np.ndarray
    shape: np.ndarray
    phase: np.ndarray
    rate: np.ndarray
    count: np.ndarray
    offsets: np.ndarray

    def __len__(self) -> int:
        return len(self.pulses)

    def runs(self, e: int) -> PhaseRuns:
        """Move e's segments as (phase, rate, pulses)."""
        a, b = int(self.offsets[e]), int(self.offsets[e + 1])
        return [(PHASES[f], r, c) for f, r, c in zip(self.phase[a:b].tolist(),
                                                     self.rate[a:b].tolist(),
                                                     self.count[a:b].tolist(), strict=True)]

    def repeats(self) -> np.ndarray:
        """For each move, whether it has the shape and the sequence of (phase, rate) of
        the move before it (only the segments' counts differ)."""
        size = np.diff(self.offsets)
        same = np.zeros(len(size), bool)
        same[1:] = (size[1:] == size[:-1]) & (self.shape[1:] == self.shape[:-1])
        alike = np.flatnonzero(same & (size > 0))
        if len(alike):
            n = size[alike]
            rows = ranges(self.offsets[alike], n)
            before = rows - np.repeat(n, n)  # the same segment of the move before
            differ = (self.rate[rows] != self.rate[before]) | \
                (self.phase[rows] != self.phase[before])
            same[alike] = ~np.logical_or.reduceat(differ, np.cumsum(n) - n)
        return same


def ranges(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The indices starts[i] .. starts[i] + lengths[i] − 1, concatenated."""
    return np.repeat(starts - np.cumsum(lengths) + lengths, lengths) + np.arange(lengths.sum())


__all__ = ["PHASES", "PHASE_CODES", "MoveBatch", "Phase", "PhaseRuns", "ranges"]
