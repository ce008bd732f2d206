"""Motor files and folders: motor files written into a folder (a bundled motor renamed, or
on a lead screw), and the folders the motor catalogue looks in (STEPRAMP_MOTORS, the XDG
config folder) pointed at a test's own."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from profiles.motor.catalogue import ENV_VAR, resolve
from tests.support.paths import ROOT

NEMA17 = ROOT / "profiles" / "data" / "motor-nema17-1600.json"
LEAD_MM = 8.0   # nema17-1600 (1600 pulses/rev) on an 8 mm lead: 0.005 mm per pulse


def motor_file(folder: Path, file_name: str, name: str = "", steps: int = 400) -> Path:
    """A motor file `file_name` in `folder` (made if need be): the bundled NEMA17 named
    `name` (else its file name), `steps` a revolution, no holding torque."""
    obj = json.loads(NEMA17.read_text(encoding="utf-8"))
    obj.update(name=name or file_name, steps_per_rev=steps)
    del obj["holding_torque_nm"]  # `motor list` falls back on the curve at 0 pps
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / file_name
    path.write_text(json.dumps(obj), encoding="utf-8")
    return path


def motor_folders(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path, Path]:
    """Two STEPRAMP_MOTORS folders and the XDG config folder's motors, all empty."""
    env_a, env_b, config = tmp_path / "env-a", tmp_path / "env-b", tmp_path / "config"
    monkeypatch.setenv(ENV_VAR, f"{env_a}:{env_b}")
    monkeypatch.setenv("XDG_CONFIG_HOME", str(config))
    monkeypatch.chdir(tmp_path)
    return env_a, env_b, config / "stepramp" / "motors"


def screw_motor_file(folder: Path) -> str:
    """The bundled nema17-1600 with an 8 mm lead screw's travel, written into `folder`."""
    obj = json.loads(resolve("nema17-1600").read_text())
    path = folder / "screw.json"
    path.write_text(json.dumps({**obj, "travel_mm_per_rev": LEAD_MM}))
    return str(path)
