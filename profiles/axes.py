"""Axes files (`stepramp.axes/1`): several axes that make one move together.

    {"format": "stepramp.axes/1", "mode": "time" | "line", "device": NAME,
     "axes": [{"name": "x", "motor": "x.motor.json", "pulses": 12000}, ...]}

`mode` (default "time"): every axis finishes together, or positions stay
proportional (the joint path follows the straight line). `device`: which device
runs the axes; the devices an axes file may name, how many axes and pulses each
takes, and the default are the caller's (`devices`: the registry's entries,
verify/devices, e.g. one PPMC-312 per axis or the two axes of one A-Link ALUM
unit). Each axis names a motor file (to plan) or a table file (`"table"`: to
simulate a hand-made set), with paths relative to the axes file; `pulses` is
signed (negative = CCW). The JSON Schema is profiles/data/axes.schema.json.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from .errors import FieldRangeError, FormatError, echo, require_int
from .motor import Motor, load_motor
from .motor.catalogue import is_name
from .reading import read_json

FORMAT = "stepramp.axes/1"
MODES = ("time", "line")
NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,31}$")
_KEYS = {"format", "mode", "device", "axes"}
_AXIS_KEYS = {"name", "motor", "table", "pulses"}

Mode = Literal["time", "line"]


@dataclass(frozen=True)
class AxesEntry:
    """A device's entry in axes files: how many axes it takes, and the most pulses of one
    axis's move (either direction)."""

    most: int
    pulses_max: int


@dataclass(frozen=True)
class Axis:
    """One axis: its name (file stem and C prefix), signed pulses, and motor or table."""

    name: str
    pulses: int
    motor: Motor | None = None
    motor_path: Path | None = None
    table_path: Path | None = None

    @property
    def distance(self) -> int:
        return abs(self.pulses)

    @property
    def ccw(self) -> bool:
        return self.pulses < 0


@dataclass(frozen=True)
class AxesFile:
    mode: Mode
    device: str
    axes: tuple[Axis, ...]
    path: Path | None = None

    def to_json(self) -> dict[str, Any]:
        def axis(a: Axis) -> dict[str, Any]:
            out: dict[str, Any] = {"name": a.name}
            if a.motor_path is not None:
                out["motor"] = str(a.motor_path)
            if a.table_path is not None:
                out["table"] = str(a.table_path)
            out["pulses"] = a.pulses
            return out
        return {"format": FORMAT, "mode": self.mode, "device": self.device,
                "axes": [axis(a) for a in self.axes]}


def axes_from_json(obj: Any, devices: Mapping[str, AxesEntry], base: Path | None = None, *,
                   load_motors: bool = True) -> AxesFile:
    """An axes file's JSON object; relative paths resolve against `base` (the file's folder).
    `devices`: the devices it may name and their entries, the first the default."""
    if not isinstance(obj, dict):
        raise FormatError("an axes file holds one JSON object")
    if obj.get("format") != FORMAT:
        raise FormatError(f"format: expected {echo(FORMAT)}, got {echo(obj.get('format'))}")
    unknown = set(obj) - _KEYS
    if unknown:
        raise FormatError(f"unknown key(s) in axes file: {', '.join(sorted(unknown))}")
    mode = obj.get("mode", "time")
    if mode not in MODES:
        raise FormatError(f"mode: expected one of {', '.join(MODES)}, got {echo(mode)}")
    device = obj.get("device", next(iter(devices)))
    if not isinstance(device, str) or device not in devices:
        raise FormatError(f"device: expected one of {', '.join(devices)}, got {echo(device)}")
    entry = devices[device]
    items = obj.get("axes")
    if not isinstance(items, list) or not items:
        raise FormatError("axes: expected a non-empty list of axis objects")
    if len(items) > entry.most:
        raise FieldRangeError(f"axes (number of axes for {device})", len(items), 1, entry.most)
    axes = []
    seen: set[str] = set()
    for i, item in enumerate(items):
        axis = _axis(item, i, entry.pulses_max, base, load_motors)
        if axis.name.lower() in seen:
            raise FormatError(f"axes[{i}].name: {echo(axis.name)} is used twice (names are file "
                              "names and C prefixes: they must differ, ignoring case)")
        seen.add(axis.name.lower())
        axes.append(axis)
    return AxesFile(mode, device, tuple(axes), None)


def _axis(item: Any, i: int, hi: int, base: Path | None, load_motors: bool) -> Axis:
    where = f"axes[{i}]"
    if not isinstance(item, dict):
        raise FormatError(f"{where}: expected an object with name, motor (or table) and pulses")
    unknown = set(item) - _AXIS_KEYS
    if unknown:
        raise FormatError(f"{where}: unknown key(s) {', '.join(sorted(unknown))}")
    name = item.get("name")
    if not isinstance(name, str) or not NAME_RE.match(name):
        raise FormatError(f"{where}.name: {echo(name)} is not a name of 1-32 letters, digits or _ "
                          "starting with a letter or _ (it names files and C symbols)")
    label = f"{where}.pulses (signed, 0 excluded)"
    pulses = require_int(label, item.get("pulses"), -hi, hi)
    if pulses == 0:
        raise FieldRangeError(label, pulses, -hi, hi)
    has_motor, has_table = "motor" in item, "table" in item
    if has_motor == has_table:
        raise FormatError(f"{where}: give exactly one of motor (to plan) or table (to simulate)")
    key = "motor" if has_motor else "table"
    value = item[key]
    if not isinstance(value, str) or not value:
        raise FormatError(f"{where}.{key}: expected a file path")
    named = has_motor and is_name(value, base)  # a catalogue motor (`stepramp motor list`)
    path = Path(value)
    if base is not None and not path.is_absolute() and not named:
        path = base / path
    if has_table:
        return Axis(name, pulses, None, None, path)
    motor = None
    if load_motors:
        try:
            motor = load_motor(value if named else path)
        except FormatError as e:  # name the axis: a one-line error that says where
            raise FormatError(f"{where}.motor: {e}") from None
        except FieldRangeError as e:
            raise FormatError(f"{where}.motor {path}: {e}") from None
    return Axis(name, pulses, motor, path, None)


def load_axes(path: str | Path, devices: Mapping[str, AxesEntry], *,
              load_motors: bool = True) -> AxesFile:
    """Read an axes file; motor (and table) paths are relative to the file's folder.
    `devices` as for `axes_from_json` (`verify.devices.load_axes` gives the registry's)."""
    p = Path(path)
    obj = read_json(p)
    try:
        out = axes_from_json(obj, devices, p.parent, load_motors=load_motors)
    except FormatError as e:
        raise FormatError(f"{p}: {e}") from None
    except FieldRangeError as e:
        raise FormatError(f"{p}: {e}") from None
    return AxesFile(out.mode, out.device, out.axes, p)
