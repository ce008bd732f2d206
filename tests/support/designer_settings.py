"""The designer tests' motor and move (tests/verify/designer/): the bundled NEMA17 and a
move whose plain table rings past the load-angle aim, so a change shows a first table
and then a different, tightened final one (4 plans)."""

from __future__ import annotations

from profiles.motor import bundled_motor_paths, load_motor
from verify.designer import Settings

NEMA17_PATH = next(p for p in bundled_motor_paths() if "nema17" in p.name)
NEMA17 = load_motor(NEMA17_PATH)
RINGS = Settings(pulses=5_000, safety_factor=NEMA17.safety_factor)
