"""A motor from a datasheet: a NEMA17 (0.59 N·m holding, 2 A rated, run at 1.5 A, 24 V,
1/8 steps) on a lead screw (8 mm, 4 kg), as `stepramp motor new` writes it. Its plain
init table's origin return (11) reverses by twice a start speed the rotor cannot follow
(the report of issue 33): the motor the tightening and the datasheet checks are tried on."""

from __future__ import annotations

from pathlib import Path

from verify.cli import main

DATASHEET = ["--holding-torque-nm", "0.59", "--rated-current-a", "2", "--current-a", "1.5",
             "--resistance-ohm", "1.4", "--inductance-mh", "3.0", "--rotor-inertia-gcm2", "82",
             "--supply-v", "24", "--microstep", "8", "--load", "screw:lead_mm=8,mass_kg=4"]


def datasheet_motor_file(path: Path, *options: str) -> Path:
    """`stepramp motor new` of DATASHEET and `options` (`--name …`) written to `path`."""
    assert main(["motor", "new", *DATASHEET, *options, "-o", str(path)]) == 0
    return path
