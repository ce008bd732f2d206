"""`resonance-dwell` findings: dwells of a table's executions inside the motor's
resonance bands (the rules: profiles.motor.resonance)."""

from __future__ import annotations

from profiles.findings import Finding
from profiles.motor import Motor
from profiles.ppmc312.resonance import forbidden_dwells
from profiles.ppmc312.table import FreeCurveTable


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
