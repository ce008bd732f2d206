"""The bundled NEMA17 and the free-curve table the planner gives it for one move length,
the table the resonance tests put bands across, and a table's stage speeds."""

from __future__ import annotations

import numpy as np

from profiles.motor import Motor, load_motor
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import FreeCurveTable
from tests.support.paths import ROOT

NEMA17 = ROOT / "profiles" / "data" / "motor-nema17-1600.json"
PULSES = 20000


def speeds(table: FreeCurveTable) -> np.ndarray:
    """The table's stage speeds [pps], ascending."""
    return np.sort(table.clock.hz / np.asarray(table.rates, dtype=float))


def nominal_plan() -> tuple[Motor, FreeCurveTable]:
    """The NEMA17 and its planned table for moves of PULSES pulses."""
    m = load_motor(NEMA17)
    return m, plan_free_curve(m, pulses=PULSES).table
