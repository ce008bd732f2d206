"""The PPMC-312's dwells in a motor's resonance bands, over every move length.

The rules are the motor's (`profiles.motor.resonance`): a cruise in any band, a stage in
a band narrower than the jump limit. Which dwells the chip runs is the table's move
families' (`execution.move_families`): every execution the chip can run with it; each
is a `resonance-dwell` finding (`resonance_findings`).
"""

from __future__ import annotations

from ..findings import Finding
from ..motor import Motor
from ..motor.resonance import Dwell, band_of, dwell_kind
from .execution import move_families
from .table import FreeCurveTable


def forbidden_dwells(table: FreeCurveTable, motor: Motor) -> list[Dwell]:
    """Every dwell in a band that some execution of `table` runs (every move length,
    through the table's move families): a cruise in any band, or a stage in a band
    narrower than the jump limit."""
    if not motor.resonance_bands_pps:
        return []
    hz = table.clock.hz
    index = {r: i for i, r in enumerate(table.rates)}
    found: dict[tuple[str, int], list[int]] = {}
    for fam in move_families(table):
        for phase, rate, _ in fam.runs():
            kind = dwell_kind(hz / rate, phase == "cruise", motor)
            if kind is None:
                continue
            span = found.setdefault((kind, rate), [fam.lo, fam.hi])
            span[0], span[1] = min(span[0], fam.lo), max(span[1], fam.hi)
    out = []
    for (kind, rate), (lo, hi) in sorted(found.items(), key=lambda e: (e[0][1], e[0][0])):
        v = hz / rate
        out.append(Dwell(kind, index.get(rate), v, band_of(v, motor), lo, hi))
    return out


def resonance_findings(table: FreeCurveTable, motor: Motor, *,
                       strict: bool = False) -> list[Finding]:
    """One finding per forbidden dwell over every move length: a warning (an error with
    `strict`)."""
    out = []
    for d in forbidden_dwells(table, motor):
        lo, hi = d.band
        moves = (f"moves of {d.pulses_lo}..{d.pulses_hi} pulses" if d.pulses_hi > d.pulses_lo
                 else f"the move of {d.pulses_lo} pulses")
        if d.kind == "cruise":
            what = (f"{moves} cruise at {d.speed_pps:.6g} pps, inside the resonance band "
                    f"[{lo:g}, {hi:g}] pps: choose a top speed outside it")
        else:
            what = (f"{moves} dwell at {d.speed_pps:.6g} pps, inside the resonance band "
                    f"[{lo:g}, {hi:g}] pps, which is narrower than the jump limit "
                    f"{motor.jump_pps:g} pps: step over it from below {lo:g} to above {hi:g}")
        out.append(Finding("error" if strict else "warning", "resonance-dwell", what,
                           stage=d.stage))
    return out
