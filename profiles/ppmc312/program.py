"""Program files (`stepramp.program/1`): what a machine does with one table, as the list
of motion commands it issues and the inputs it meets (issue 31 item 2).

    {"format": "stepramp.program/1", "table": "x.table.json",
     "commands": [{"command": "accel", "pulses": 20000, "high_rate": 900},
                  {"command": "change-speed", "rate": 400, "at": 10000},
                  {"signal": "FL", "at": 15000}]}

- "table": a table file (free curve or init), relative to the program file's folder;
- each command names a `motion.COMMANDS` entry and takes its parameters there: "rate"
  (82's "high_rate"; 0 the table's high rate where the manual allows it), "pulses",
  "ccw", "index"; a command issued during a motion (80, 81, 87, 88) and a signal
  ("FL", "BL", "FHL", "BHL", §7-6) give "at", the pulses of the running motion output
  when it takes effect (an override position, an event, a limit found there); 10 and 11
  give "at" too: where /ORG is found. The override's position and event (`override_at`,
  `on`) are how the chip is told, not what it runs: a program says where.
- optional "description": for people.

`load_program` refuses in one line naming the key (`commands[2].rate: …`): a duplicate
key, an unknown command or key, a parameter the command does not take, a rate outside
the table's range (the chip's parameter error 0x20), an `at` past the motion's end or a
command the chip would not take where it stands. JSON Schema: profiles/data/
program.schema.json. What the chip runs: `profiles.ppmc312.command_runs`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import (
    FieldRangeError,
    FormatError,
    MoveParameterError,
    StepRampError,
    echo,
    require_int,
)
from .command_runs import (
    AT_REST,
    DURING,
    FINDS_ORIGIN,
    READINGS,
    SIGNALS,
    STARTS,
    ProgramCommand,
    ProgramRun,
    Stairs,
    run_program,
)
from .move_batch import CHIP_BAD_PULSE_COUNT, CHIP_RATE_OUT_OF_RANGE, MOVE_PULSES_MAX
from .table import FreeCurveTable, InitTable

FORMAT = "stepramp.program/1"
KEYS = frozenset({"format", "table", "commands", "description"})
COMMANDS_MAX = 10_000
POSITION_MAX = 0xFFFFFFFF


@dataclass(frozen=True)
class Program:
    """A program: its table, where it was read from, its commands."""

    table: FreeCurveTable | InitTable
    table_path: str
    commands: tuple[ProgramCommand, ...]
    description: str | None = None

    def run(self, reading: str = "a") -> ProgramRun:
        """What the chip runs (`command_runs.run_program`), one reading of decel stops."""
        return run_program(self.table, self.commands, reading=reading)

    def runs(self) -> list[ProgramRun]:
        """Every reading that runs something different (decel stops from mid-ramp)."""
        out: list[ProgramRun] = []
        for reading in READINGS:
            run = self.run(reading)
            if not any(r.motions == run.motions for r in out):
                out.append(run)
        return out

    def names(self) -> list[str]:
        return [c.name if not c.signal else f"/{c.name}" for c in self.commands]


def load_program(path: str | Path, *, raw: bytes | None = None) -> Program:
    """Read a program file (`-`: stdin, its table relative to the working folder); every
    problem is one line naming the file and the key."""
    from ..reading import STDIN, display_path, parse_json, read_bytes

    name = display_path(path)
    data = read_bytes(path) if raw is None else raw
    base = None if str(path) == STDIN else Path(path).parent
    try:
        return program_from_json(parse_json(data, path), base)
    except StepRampError as e:
        if not str(e).startswith(name):
            e.args = (f"{name}: {e}",)
        raise


def program_from_json(obj: Any, base: Path | None = None) -> Program:
    """A program from its parsed JSON; "table" resolves against `base`."""
    from .table import load_table

    if not isinstance(obj, dict):
        raise FormatError("a program file holds one JSON object")
    if obj.get("format") != FORMAT:
        raise FormatError(f"format: expected {echo(FORMAT)}, got {echo(obj.get('format'))}")
    unknown = sorted(set(obj) - KEYS)
    if unknown:
        raise FormatError(f"{echo(unknown[0])}: not a key of a program file (it has "
                          f"{', '.join(sorted(KEYS))})")
    where = obj.get("table")
    if not isinstance(where, str) or not where:
        raise FormatError("table: expected the path of a table file")
    description = obj.get("description")
    if description is not None and not isinstance(description, str):
        raise FormatError("description: expected a string")
    items = obj.get("commands")
    if not isinstance(items, list) or not items:
        raise FormatError("commands: expected a non-empty list of commands")
    if len(items) > COMMANDS_MAX:
        raise FieldRangeError("commands (how many)", len(items), 1, COMMANDS_MAX)
    table_path = Path(where) if base is None or Path(where).is_absolute() else base / where
    try:
        table = load_table(table_path)
    except StepRampError as e:
        raise FormatError(f"table: {e}") from None
    stairs = Stairs(table)
    commands = tuple(command_from_json(item, i, stairs) for i, item in enumerate(items))
    program = Program(table, str(table_path), commands, description)
    program.runs()  # what the chip would not take where it stands is refused here
    return program


def command_from_json(item: Any, i: int, stairs: Stairs) -> ProgramCommand:
    """Entry i of "commands": one motion command or signal with its parameters."""
    from .motion import COMMANDS

    where = f"commands[{i}]"
    if not isinstance(item, dict):
        raise FormatError(f"{where}: expected an object with \"command\" (or \"signal\")")
    if ("command" in item) == ("signal" in item):
        raise FormatError(f"{where}: give one of \"command\" (one of {', '.join(COMMANDS)}) "
                          f"or \"signal\" ({', '.join(SIGNALS)})")
    if "signal" in item:
        _only(item, where, {"signal", "at"}, f"/{item['signal']}")
        if item["signal"] not in SIGNALS:
            raise FormatError(f"{where}.signal: {echo(item['signal'])} is not one of "
                              f"{', '.join(SIGNALS)}")
        return ProgramCommand(item["signal"], at=_at(item, where, True))
    name = item["command"]
    if not isinstance(name, str) or name not in COMMANDS:
        raise FormatError(f"{where}.command: {echo(name)} is not one of {', '.join(COMMANDS)}")
    command = COMMANDS[name]
    keys = {"command", *(command.rate_field if p == "rate" else p
                         for p in command.takes & {"rate", "pulses", "ccw", "index"})}
    timed = name in DURING or name in FINDS_ORIGIN
    _only(item, where, keys | ({"at"} if timed else set()), command.label)
    for flag in ("ccw", "index"):
        if flag in item and not isinstance(item[flag], bool):
            raise FormatError(f"{where}.{flag}: expected true or false, got {echo(item[flag])}")
    pulses = 0
    if "pulses" in command.takes:
        if "pulses" not in item:
            raise FormatError(f"{where}: {command.label} needs pulses")
        pulses = _int(item["pulses"], f"{where}.pulses", 1, MOVE_PULSES_MAX, CHIP_BAD_PULSE_COUNT)
    rate = _rate(item, where, name, stairs) if command.rate is not None else 0
    assert name in STARTS | DURING | AT_REST
    return ProgramCommand(name, rate, pulses, bool(item.get("ccw", False)),
                          _at(item, where, timed))


def _only(item: dict[str, Any], where: str, keys: set[str], label: str) -> None:
    unknown = sorted(set(item) - keys)
    if unknown:
        takes = sorted(keys - {"command", "signal"})
        raise FormatError(f"{where}.{unknown[0]}: {label} takes no {echo(unknown[0])} (it "
                          f"takes {', '.join(takes) or 'nothing'})")


def _int(value: Any, field: str, lo: int, hi: int, code: int) -> int:
    try:
        return require_int(field, value, lo, hi)
    except FieldRangeError:
        raise MoveParameterError(field, value, lo, hi, code) from None


def _at(item: dict[str, Any], where: str, timed: bool) -> int | None:
    if not timed:
        return None
    if "at" not in item:
        raise FormatError(f"{where}: needs \"at\" (the pulses of the running motion output "
                          "when it takes effect)")
    return require_int(f"{where}.at", item["at"], 1, POSITION_MAX)


def _rate(item: dict[str, Any], where: str, name: str, stairs: Stairs) -> int:
    """The command's rate: within its figure's range, then the table's (0x20, §8)."""
    from .motion import COMMANDS, RATE_MAX

    command = COMMANDS[name]
    spec = command.rate
    assert spec is not None
    key = command.rate_field
    field = f"{where}.{key}"
    if key not in item:
        if not spec.zero:
            raise FormatError(f"{where}: {command.label} needs {key}")
        return 0
    value = item[key]
    if isinstance(value, bool) or not isinstance(value, int):
        raise spec.error(field, value)
    if not spec.allows(value):
        raise MoveParameterError(field, value, spec.lo, RATE_MAX, CHIP_RATE_OUT_OF_RANGE)
    if value == 0 or not spec.table:
        return value
    hi = min(stairs.start_rate, stairs.stop_rate) if name == "origin-search" else stairs.hi
    if not stairs.lo <= value <= hi:
        within = spec.table if name == "origin-search" else "within the table's rates"
        raise MoveParameterError(f"{field} ({within})", value,
                                 stairs.lo, min(hi, RATE_MAX), CHIP_RATE_OUT_OF_RANGE)
    return value
