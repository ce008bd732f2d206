"""A free-curve table unsafe only for some move lengths, as `check` and `compare` are
tried on it."""

from __future__ import annotations

from pathlib import Path

from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import FreeCurveTable, dump_table


def switching_table(tmp_path: Path) -> Path:
    """A free-curve table (LE=1) with decel counts heavy at the slow end, so that short
    triangles switch down; written into `tmp_path`."""
    table = FreeCurveTable(Clock.internal("8MHz"), (1455, 1873, 2500), (40, 40, 40), (2, 2, 200))
    path = tmp_path / "switch.table.json"
    path.write_text(dump_table(table))
    return path
