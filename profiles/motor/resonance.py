"""Resonance bands: speeds where the machine resonates (`resonance_bands_pps`).

A band is a closed interval [lo, hi] of speeds. What the planner and `check`
hold to (docs/manual-notes.md, "Resonance bands: what dwelling means"):

- a *dwell* is a run of pulses at one constant speed: every stage of a
  staircase is one, and so is the cruise;
- the cruise (the top stage, which a trapezoid cruises at) never lies in a band;
- a band narrower than the jump limit (hi − lo < jump_pps) holds no stage: the
  staircase steps from below it to above it in one jump;
- a wider band cannot be jumped: its stages are crossed with the criterion's
  minimal counts (the fewest pulses the motor can follow), and are no finding.

These rules are the motor's, whatever drives it (`dwell_kind`); which dwells a
device's executions run is the device's (profiles/ppmc312/resonance.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .model import Motor


def in_bands(speed_pps: Any, bands: tuple[tuple[float, float], ...]) -> np.ndarray:
    """Whether each speed lies in some band (closed intervals)."""
    v = np.asarray(speed_pps, dtype=float)
    out = np.zeros(v.shape, dtype=bool)
    for lo, hi in bands:
        out |= (v >= lo) & (v <= hi)
    return out


def narrow_bands(motor: Motor) -> tuple[tuple[float, float], ...]:
    """The bands a single jump can step over (narrower than the jump limit)."""
    return tuple((lo, hi) for lo, hi in motor.resonance_bands_pps if hi - lo < motor.jump_pps)


def top_allowed(speed_pps: Any, motor: Motor) -> np.ndarray:
    """The top stage (the cruise) may run at these speeds: outside every band."""
    return ~in_bands(speed_pps, motor.resonance_bands_pps)


def band_edges_rates(motor: Motor, hz: float) -> list[int]:
    """For each band the integer rates just outside it (speed just below lo and just
    above hi): the stages a jump over it needs."""
    out = []
    for lo, hi in motor.resonance_bands_pps:
        out += [int(np.floor(hz / lo)) + 1, int(np.ceil(hz / hi)) - 1]
    return [r for r in out if r >= 1]


@dataclass(frozen=True)
class Dwell:
    """A dwell inside a band that the rules above forbid, over a range of move lengths."""

    kind: str                  # "cruise" (the cruise speed) or "stage" (a jumpable band)
    stage: int | None          # fastest-first stage index (None: a high-rate cruise)
    speed_pps: float
    band: tuple[float, float]
    pulses_lo: int             # the shortest and longest move lengths that run it
    pulses_hi: int


def dwell_kind(speed_pps: float, cruise: bool, motor: Motor) -> str | None:
    """Which rule a dwell at `speed_pps` breaks: "cruise" (a cruise in any band), "stage"
    (a stage in a band narrower than the jump limit), or None (allowed)."""
    if cruise and bool(in_bands(speed_pps, motor.resonance_bands_pps)):
        return "cruise"
    if not cruise and bool(in_bands(speed_pps, narrow_bands(motor))):
        return "stage"
    return None


def band_of(speed_pps: float, motor: Motor) -> tuple[float, float]:
    """The first resonance band holding `speed_pps` (the speed lies in one)."""
    return next(b for b in motor.resonance_bands_pps if b[0] <= speed_pps <= b[1])
