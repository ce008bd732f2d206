"""PPMC-312 acceleration tables and their JSON file format (`stepramp.table/1`).

Two kinds, as the chip has two ways to get a table:
- `FreeCurveTable`: every stage given (free-curve command 01). `rates` and
  the pulse counts are listed fastest (smallest rate) first, as uploaded.
- `InitTable`: the init command (00) parameters; the chip builds the stages.

Loading refuses what cannot even be represented on the wire (a value that does
not fit its byte field, a negative count, an unknown key: `StepRampError`).
What fits the wire but breaks a chip rule (rate 1, 200 stages, a stage of
1 pulse …) loads fine and is reported by `profiles.ppmc312.chip_rules`, with the chip's code.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from ..errors import FieldRangeError, FormatError, StepRampError, echo, is_number
from ..provenance import PlanProvenance
from ..reading import display_path, read_json
from .clock import Clock

if TYPE_CHECKING:
    import numpy as np

FORMAT = "stepramp.table/1"
DEVICE = "ppmc312"

# Wire widths (SPEC §1.3–1.4): what a field can carry at all.
RATE_FIELD_MAX = 0xFFFF          # 2-byte rate entries
PULSES_FIELD_MAX = 0xFFFFFF      # 3-byte pulse counts
STAGE_COUNT_FIELD_MAX = 0xFF     # 1-byte stage counts

InitShape = Literal["linear", "s_curve"]


@dataclass(frozen=True)
class FreeCurveTable:
    clock: Clock
    rates: tuple[int, ...]
    accel_pulses: tuple[int, ...]
    decel_pulses: tuple[int, ...] | None = None
    # where a planned table came from (profiles/provenance.py): informative, so two tables
    # with the same stages are the same table whatever planned them
    provenance: PlanProvenance | None = field(default=None, compare=False, repr=False)

    kind = "free_curve"

    def __post_init__(self) -> None:
        object.__setattr__(self, "rates", _ints("rates", self.rates, RATE_FIELD_MAX))
        object.__setattr__(self, "accel_pulses",
                           _ints("accel_pulses", self.accel_pulses, PULSES_FIELD_MAX))
        if self.decel_pulses is not None:
            object.__setattr__(self, "decel_pulses",
                               _ints("decel_pulses", self.decel_pulses, PULSES_FIELD_MAX))
        for name, seq in self._lists():
            if len(seq) > STAGE_COUNT_FIELD_MAX:
                raise FieldRangeError(f"{name} (stage count)", len(seq), 0, STAGE_COUNT_FIELD_MAX)
        # Shared-rate reading (docs/manual-notes.md): there is one rate entry per
        # stage of the longer side; each side uses the fastest stages it counts.
        longest = max(len(self.accel_pulses), len(self.decel_pulses or ()))
        if len(self.rates) != longest:
            raise FormatError(f"rates: {len(self.rates)} entries, but the longer pulse list has "
                              f"{longest} stages; give one rate per stage of the longer side")

    @classmethod
    def from_wire(cls, clock: Clock, rates: tuple[int, ...], accel_pulses: tuple[int, ...],
                  decel_pulses: tuple[int, ...] | None) -> FreeCurveTable:
        """A table from decoded upload fields, not validated again: the decoder's frames
        have already refused every value wider than its field (2-byte rates, 3-byte
        counts, 1-byte stage counts) and give one rate per stage of the longer side."""
        table = object.__new__(cls)
        for name, value in (("clock", clock), ("rates", rates),
                            ("accel_pulses", accel_pulses), ("decel_pulses", decel_pulses)):
            object.__setattr__(table, name, value)
        return table

    def _lists(self) -> list[tuple[str, tuple[int, ...]]]:
        out = [("rates", self.rates), ("accel_pulses", self.accel_pulses)]
        if self.decel_pulses is not None:
            out.append(("decel_pulses", self.decel_pulses))
        return out

    @property
    def separate(self) -> bool:
        """LE bit: separate accel/decel pulse counts."""
        return self.decel_pulses is not None

    @property
    def decel(self) -> tuple[int, ...]:
        """Decel pulse counts as the chip runs them (the accel counts when LE=0)."""
        return self.accel_pulses if self.decel_pulses is None else self.decel_pulses

    @property
    def accel_total(self) -> int:
        return sum(self.accel_pulses)

    @property
    def decel_total(self) -> int:
        return sum(self.decel)

    def speeds_pps(self) -> np.ndarray:
        """Stage speeds, fastest first (same order as `rates`)."""
        import numpy as np  # here: reading and checking a table never needs numpy

        return self.clock.hz / np.asarray(self.rates, dtype=float)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"format": FORMAT, "device": DEVICE, "kind": self.kind,
                               "clock": self.clock.to_json(), "rates": list(self.rates),
                               "accel_pulses": list(self.accel_pulses)}
        if self.decel_pulses is not None:
            out["decel_pulses"] = list(self.decel_pulses)
        if self.provenance is not None:
            out["provenance"] = self.provenance.to_json()
        return out


@dataclass(frozen=True)
class InitTable:
    clock: Clock
    shape: InitShape
    start_rate: int
    high_rate: int
    accel_pulses: int
    stop_rate: int | None = None
    decel_pulses: int | None = None
    provenance: PlanProvenance | None = field(default=None, compare=False, repr=False)

    kind = "init"

    def __post_init__(self) -> None:
        if self.shape not in ("linear", "s_curve"):
            raise FormatError(f"shape: {echo(self.shape)} is not 'linear' or 's_curve'")
        if (self.stop_rate is None) != (self.decel_pulses is None):
            raise FormatError("stop_rate and decel_pulses go together (both give LE=1)")
        for name, hi in (("start_rate", RATE_FIELD_MAX), ("high_rate", RATE_FIELD_MAX),
                         ("accel_pulses", PULSES_FIELD_MAX), ("stop_rate", RATE_FIELD_MAX),
                         ("decel_pulses", PULSES_FIELD_MAX)):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _int_field(name, value, hi))

    @property
    def separate(self) -> bool:
        return self.stop_rate is not None

    @property
    def effective_stop_rate(self) -> int:
        return self.start_rate if self.stop_rate is None else self.stop_rate

    @property
    def effective_decel_pulses(self) -> int:
        return self.accel_pulses if self.decel_pulses is None else self.decel_pulses

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"format": FORMAT, "device": DEVICE, "kind": self.kind,
                               "clock": self.clock.to_json(), "shape": self.shape,
                               "start_rate": self.start_rate, "high_rate": self.high_rate,
                               "accel_pulses": self.accel_pulses}
        if self.stop_rate is not None:
            out["stop_rate"] = self.stop_rate
            out["decel_pulses"] = self.decel_pulses
        if self.provenance is not None:
            out["provenance"] = self.provenance.to_json()
        return out


Table = FreeCurveTable | InitTable

_COMMON = {"format", "device", "kind", "clock"}
_KEYS = {
    "free_curve": (_COMMON | {"rates", "accel_pulses"}, {"decel_pulses", "provenance"}),
    "init": (_COMMON | {"shape", "start_rate", "high_rate", "accel_pulses"},
             {"stop_rate", "decel_pulses", "provenance"}),
}


def table_from_json(obj: Any) -> Table:
    """Build a table from a parsed `stepramp.table/1` object, refusing anything else."""
    if not isinstance(obj, dict):
        raise FormatError("a table file holds one JSON object")
    if obj.get("format") != FORMAT:
        # another tool's JSON has no "format": say what it holds instead of "got None"
        got = (echo(obj["format"]) if "format" in obj else
               "no \"format\" key (JSON from another tool? its keys: "
               f"{echo(', '.join(map(str, list(obj)[:6])) or 'none')})")
        raise FormatError(f"format: expected {echo(FORMAT)}, got {got}")
    if obj.get("device") != DEVICE:
        raise FormatError(f"device: expected {echo(DEVICE)}, got {echo(obj.get('device'))}")
    kind = obj.get("kind")
    if not isinstance(kind, str) or kind not in _KEYS:
        raise FormatError(f"kind: expected 'free_curve' or 'init', got {echo(kind)}")
    required, optional = _KEYS[kind]
    unknown = set(obj) - required - optional
    if unknown:
        raise FormatError(f"unknown key(s) for a {kind} table: {', '.join(sorted(unknown))} "
                          f"(allowed: {', '.join(sorted(required | optional))})")
    missing = required - set(obj)
    if missing:
        raise FormatError(f"missing key(s) for a {kind} table: {', '.join(sorted(missing))}")
    clock = Clock.from_json(obj["clock"])
    provenance = None if "provenance" not in obj else PlanProvenance.from_json(obj["provenance"])
    if kind == "free_curve":
        decel = obj.get("decel_pulses")
        return FreeCurveTable(clock, tuple(_list(obj, "rates")), tuple(_list(obj, "accel_pulses")),
                              None if decel is None else tuple(_list(obj, "decel_pulses")),
                              provenance)
    if ("stop_rate" in obj) != ("decel_pulses" in obj):
        raise FormatError("stop_rate and decel_pulses go together (both give LE=1)")
    return InitTable(clock, obj["shape"], _int(obj, "start_rate"), _int(obj, "high_rate"),
                     _int(obj, "accel_pulses"),
                     _int(obj, "stop_rate") if "stop_rate" in obj else None,
                     _int(obj, "decel_pulses") if "decel_pulses" in obj else None, provenance)


def load_table(path: str | Path) -> Table:
    """Read a table file; every problem is a one-line `StepRampError` naming the file."""
    obj = read_json(path)
    try:
        return table_from_json(obj)
    except StepRampError as e:
        name = display_path(path)
        if not str(e).startswith(name):  # show and export said "format: …" of no file
            e.args = (f"{name}: {e}",)
        raise


def dump_table(table: Table) -> str:
    return json.dumps(table.to_json(), indent=1) + "\n"


def _list(obj: dict[str, Any], key: str) -> list[int]:
    value = obj[key]
    if not isinstance(value, list):
        raise FormatError(f"{key}: expected a list of integers, got {type(value).__name__}")
    for i, v in enumerate(value):
        if not is_number(v, integral=True):
            raise FormatError(f"{key}[{i}]: expected an integer, got {echo(v)}")
    return value


def _int(obj: dict[str, Any], key: str) -> int:
    v = obj[key]
    if not is_number(v, integral=True):
        raise FormatError(f"{key}: expected an integer, got {echo(v)}")
    return v


_INT_ONLY = frozenset((int,))


def _int_field(label: str, v: Any, hi: int) -> int:
    if not is_number(v, integral=True):
        raise FormatError(f"{label}: expected an integer, got {echo(v)}")
    if not 0 <= v <= hi:
        raise FieldRangeError(label, int(v), 0, hi)
    return int(v)


def _ints(name: str, values: Any, hi: int) -> tuple[int, ...]:
    # Fast path for the common case (plain ints in range); anything else is looked at
    # one value at a time, for the error naming the first bad entry.
    if isinstance(values, tuple | list) and _INT_ONLY.issuperset(map(type, values)) and (
            not values or (min(values) >= 0 and max(values) <= hi)):
        return tuple(values)
    return tuple(_int_field(f"{name}[{i}]", v, hi) for i, v in enumerate(values))
