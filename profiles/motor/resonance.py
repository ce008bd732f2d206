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
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..ppmc312.execution import move_families
from ..ppmc312.table import FreeCurveTable
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


def stage_allowed(speed_pps: Any, motor: Motor) -> np.ndarray:
    """A stage may run at these speeds: not inside a band the staircase can jump."""
    return ~in_bands(speed_pps, narrow_bands(motor))


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


def forbidden_dwells(table: FreeCurveTable, motor: Motor) -> list[Dwell]:
    """Every dwell in a band that some execution of `table` runs (every move length,
    through the table's move families): a cruise in any band, or a stage in a band
    narrower than the jump limit."""
    bands = motor.resonance_bands_pps
    if not bands:
        return []
    hz = table.clock.hz
    index = {r: i for i, r in enumerate(table.rates)}
    narrow = narrow_bands(motor)
    found: dict[tuple[str, int], list[int]] = {}
    for fam in move_families(table):
        for phase, rate, _ in fam.runs():
            v = hz / rate
            if phase == "cruise" and in_bands(v, bands):
                kind = "cruise"
            elif phase != "cruise" and in_bands(v, narrow):
                kind = "stage"
            else:
                continue
            span = found.setdefault((kind, rate), [fam.lo, fam.hi])
            span[0], span[1] = min(span[0], fam.lo), max(span[1], fam.hi)
    out = []
    for (kind, rate), (lo, hi) in sorted(found.items(), key=lambda e: (e[0][1], e[0][0])):
        v = hz / rate
        band = next(b for b in bands if b[0] <= v <= b[1])
        out.append(Dwell(kind, index.get(rate), v, band, lo, hi))
    return out
