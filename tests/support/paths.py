"""The checkout's folders, as the tests see them (one ROOT for every test)."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
MOTOR_DATA = ROOT / "profiles" / "data"
