"""Where a planned file came from (issue 32 item 4): the `"provenance"` object `stepramp
plan` writes into every table (and `alink settings --motor` into its settings), so CI can
tell which motor to judge a file with and `check` can say when it judges with another.

    {"motor": {"name": "…", "sha256": "…"},   the motor planned for, and its content hash
     "pulses": [3200] | null,                  the move lengths planned for (null: the
                                               reference move); a mix file: "moves_file"
     "moves_file": {"name": "…", "sha256": "…"},
     "aim_deg": 75 | null,                     the load-angle aim (null: criterion only)
     "safety_factor": 0.6,                     the motor's share of its pull-out torque
     "cruise_reserve": "2x,10%" | "off",       the torque reserve at the top speed
     "commands": ["decel-stop", "accel"],      the motion commands the machine runs (plan
                                               --commands; absent: every command)
     "stepramp": "0.1.0", "date": "2025-01-31T12:00:00Z"}

The motor's hash is the SHA-256 of its canonical JSON (`content_sha256`: keys sorted, no
spaces, as the loader reads the file), so re-indenting a motor file or a byte-order mark
does not make it another motor, while any changed value does. Only "motor", "stepramp" and
"date" are required; a key this version does not know is refused (one line naming it), as
every other key of a stepramp file is.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Any

from .errors import FormatError, echo, is_number

TEXT_MAX_CHARS = 500      # a name or version longer than this is no name (and bloats the file)
PULSES_LISTED_MAX = 1000  # a longer mix of lengths is named by its file instead
REQUIRED = ("motor", "stepramp", "date")
OPTIONAL = ("pulses", "moves_file", "aim_deg", "safety_factor", "cruise_reserve", "commands")
COMMANDS_MAX = 64         # more names than any device has commands is no list of them


def content_sha256(obj: Any) -> str:
    """The SHA-256 (hex) of `obj` as canonical JSON: keys sorted, compact, UTF-8."""
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


@dataclass(frozen=True)
class FileRef:
    """A file named with the hash of its content (a motor, a move mix)."""

    name: str
    sha256: str

    def to_json(self) -> dict[str, str]:
        return {"name": self.name, "sha256": self.sha256}

    @property
    def short(self) -> str:
        """The name and the hash's first 12 hex digits, as a message shows them."""
        return f"{self.name or '(unnamed)'} (sha256 {self.sha256[:12]})"


@dataclass(frozen=True)
class PlanProvenance:
    motor: FileRef
    stepramp: str
    date: str
    pulses: tuple[int, ...] | None = None
    moves_file: FileRef | None = None
    aim_deg: float | None = None
    safety_factor: float | None = None
    cruise_reserve: str | None = None
    # the motion commands plan judged (their names, as --commands gave them, the device's
    # registry order); None: every command. `check --motor` judges these by default.
    commands: tuple[str, ...] | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"motor": self.motor.to_json(),
                               "pulses": None if self.pulses is None else list(self.pulses)}
        if self.moves_file is not None:
            out["moves_file"] = self.moves_file.to_json()
        out.update(aim_deg=self.aim_deg, safety_factor=self.safety_factor)
        if self.cruise_reserve is not None:
            out["cruise_reserve"] = self.cruise_reserve
        if self.commands is not None:
            out["commands"] = list(self.commands)
        out.update(stepramp=self.stepramp, date=self.date)
        return out

    @classmethod
    def from_json(cls, obj: Any) -> PlanProvenance:
        """A provenance object as a file holds it; anything else is one line naming the key."""
        if not isinstance(obj, dict):
            raise FormatError(f"provenance: expected an object, got {type(obj).__name__}")
        unknown = sorted(set(obj) - set(REQUIRED) - set(OPTIONAL))
        if unknown:
            raise FormatError(f"provenance: unknown key(s) {', '.join(map(echo, unknown))} "
                              f"(allowed: {', '.join(REQUIRED + OPTIONAL)})")
        missing = [k for k in REQUIRED if k not in obj]
        if missing:
            raise FormatError(f"provenance: missing key(s) {', '.join(missing)}")
        pulses = obj.get("pulses")
        if pulses is not None and not (isinstance(pulses, list) and all(
                is_number(p, integral=True) and 0 < p <= 0xFFFFFFFF for p in pulses)):
            raise FormatError(f"provenance.pulses: expected null or a list of move lengths "
                              f"1..{0xFFFFFFFF}, got {echo(pulses)}")
        return cls(_file_ref(obj["motor"], "motor"), _text(obj, "stepramp"), _text(obj, "date"),
                   None if pulses is None else tuple(int(p) for p in pulses),
                   None if obj.get("moves_file") is None
                   else _file_ref(obj["moves_file"], "moves_file"),
                   _number(obj, "aim_deg", 0.0, 90.0), _number(obj, "safety_factor", 0.0, 1.0),
                   None if obj.get("cruise_reserve") is None else _text(obj, "cruise_reserve"),
                   _commands(obj.get("commands")))

    def describe(self) -> str:
        """One line: the motor and the move it was planned for, by what and when."""
        if self.pulses is not None and len(self.pulses) == 1:
            move = f"a move of {self.pulses[0]} pulses"
        elif self.pulses is not None:
            move = f"a mix of {len(self.pulses)} move lengths"
        elif self.moves_file is not None:
            move = f"the moves of {self.moves_file.short}"
        else:
            move = "the motor's reference move"
        parts = [f"planned for motor {self.motor.short}, {move}"]
        if self.aim_deg is not None:
            parts.append(f"aim {self.aim_deg:g}°")
        if self.safety_factor is not None:
            parts.append(f"safety factor {self.safety_factor:g}")
        if self.cruise_reserve is not None:
            parts.append(f"cruise reserve {self.cruise_reserve}")
        if self.commands is not None:
            parts.append(f"commands {','.join(self.commands)}")
        return ", ".join(parts) + f"; stepramp {self.stepramp}, {self.date}"


def _text(obj: dict[str, Any], key: str, where: str = "provenance") -> str:
    value = obj.get(key)
    if not isinstance(value, str) or len(value) > TEXT_MAX_CHARS:
        raise FormatError(f"{where}.{key}: expected a text of at most {TEXT_MAX_CHARS} "
                          f"characters, got {echo(value)}")
    return value


def _commands(value: Any) -> tuple[str, ...] | None:
    """The recorded command names (which ones a device knows is its judge's to say)."""
    if value is None:
        return None
    if not (isinstance(value, list) and 0 < len(value) <= COMMANDS_MAX and all(
            isinstance(v, str) and 0 < len(v) <= TEXT_MAX_CHARS for v in value)):
        raise FormatError(f"provenance.commands: expected null or a list of 1..{COMMANDS_MAX} "
                          f"command names, got {echo(value)}")
    return tuple(value)


def _number(obj: dict[str, Any], key: str, lo: float, hi: float) -> float | None:
    value = obj.get(key)
    if value is None:
        return None
    if not (is_number(value, finite=True) and lo <= value <= hi):
        raise FormatError(f"provenance.{key}: expected null or a number {lo:g}..{hi:g}, got "
                          f"{echo(value)}")
    return float(value)


def _file_ref(obj: Any, key: str) -> FileRef:
    where = f"provenance.{key}"
    if not isinstance(obj, dict) or set(obj) != {"name", "sha256"}:
        raise FormatError(f'{where}: expected {{"name": text, "sha256": 64 hex digits}}, got '
                          f"{echo(obj)}")
    digest = _text(obj, "sha256", where)
    if len(digest) != 64 or any(c not in "0123456789abcdef" for c in digest):
        raise FormatError(f"{where}.sha256: expected 64 lowercase hex digits, got {echo(digest)}")
    return FileRef(_text(obj, "name", where), digest)
