"""Every A-Link ALUM command of manual §11, by name: what its nn (func) and para mean.

`COMMANDS` is the one registry: a command's name (the manual's symbol in lower case with
dashes: `move-a`, `home`, `ol-speed`, … and `change-speed` for CHANGE_SPD) gives its code,
the section that describes it, and its forms: one per nn the manual gives it (STOP's 28
immediate and 31 decelerating, HOME's types 1–4, SETTING's 29 coordinates and 30 soft
limit, …), each with what its para holds (`Value`: range, unit, the values or bits it may
take) and its `fields.Frame` — the command word with the code and nn fixed, then the para's
two 14-bit halves, one description for encode and decode. `stepramp alink command`, `alink
decode --command` and `check` (through `profiles.alink.unit`) look commands up here.

`encode_command` refuses what §11 does not give (one line naming the option, the value and
what the command takes); `decode_command` names any command word triple and says what in
it §11 does not give, without refusing it (`Decoded.problems`): `check` reports those as
the unit's Nak. The readings the manual leaves open are in docs/manual-notes.md (H_SPEED's
and UP_TIME's formats, missing from §11-2, are inferred; the soft limits' printed range).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ..errors import FieldRangeError, FormatError, UnknownCommandError, echo, is_number
from ..fields import Bit, Bits, Frame
from .codec import (
    PARA_MAX,
    PARA_MIN,
    Cmd,
    Command,
    pack_words,
    parse_command,
    signed28,
    words_of,
)
from .model import SPEED_MAX_PPS

__all__ = ["COMMANDS", "AlinkCommand", "Decoded", "Form", "Value", "cli_name", "command_of",
           "decode_command", "encode_command", "factory_use", "form_of"]


@dataclass(frozen=True)
class Value:
    """What a form's para holds: `what` (the manual's argument name) in `unit`, any of
    `lo`..`hi` — or only the `choices` (value → meaning) and, from `open_from` up, the
    rest of the range (`open_meaning`); or a bit word (`bits`: bit → meaning) with the
    `fixed` bits set. `refused` values lie in the range but are not taken (why)."""

    what: str
    unit: str = ""
    lo: int = 0
    hi: int = 0
    choices: Mapping[int, str] = field(default_factory=dict)
    open_from: int | None = None
    open_meaning: str = ""
    bits: Mapping[int, str] = field(default_factory=dict)
    fixed: int = 0
    refused: Mapping[int, str] = field(default_factory=dict)

    @property
    def takes(self) -> bool:
        """Whether the command takes a value at all (else its para is 0)."""
        return bool(self.hi or self.lo or self.choices or self.bits)

    @property
    def signed(self) -> bool:
        return self.lo < 0

    @property
    def mask(self) -> int:
        return sum(1 << b for b in self.bits) | self.fixed

    @property
    def shown(self) -> str:
        """What the value may be, for help and messages."""
        unit = f" {self.unit}" if self.unit else ""
        if self.bits:
            named = ", ".join(f"D{b} {m}" for b, m in sorted(self.bits.items()))
            fixed = f", D0/D2 always set (0x{self.fixed:X})" if self.fixed else ""
            return f"a bit word: {named}{fixed}"
        if self.choices:
            listed = ", ".join(f"{_num(v)} ({m})" for v, m in self.choices.items())
            more = ("" if self.open_from is None else
                    f", 0x{self.open_from:X}..0x{self.hi:X} ({self.open_meaning})")
            return f"one of {listed}{more}"
        if not self.takes:
            return "none (para 0)"
        no = "".join(f", not {v} ({why})" for v, why in self.refused.items())
        return f"{self.lo}..{self.hi}{unit}{no}"

    def problem(self, value: int) -> str | None:
        """Why the unit does not take `value` (None: it does)."""
        if self.bits:
            extra = value & ~self.mask if value >= 0 else value
            if extra:
                return (f"0x{value & 0xFFFFFFF:X} sets bits outside the word's (0x"
                        f"{extra & 0xFFFFFFF:X}); it is {self.shown}")
            if value & self.fixed != self.fixed:
                return f"0x{value:X} lacks the bits fixed at 1 (0x{self.fixed:X})"
            return None
        if value in self.refused:
            return f"{value}: {self.refused[value]}"
        if self.choices:
            if value in self.choices:
                return None
            if self.open_from is not None and self.open_from <= value <= self.hi:
                return None
            return f"{_num(value)} is not {self.shown}"
        if not self.lo <= value <= self.hi:
            return f"{value} is outside {self.shown}"
        return None

    def meaning(self, value: int) -> str:
        """The value as the manual reads it ("1000 pulses", "1 (on)", "0x14 (…)")."""
        if self.bits:
            on = [m for b, m in sorted(self.bits.items()) if value >> b & 1]
            return f"0x{value:X} ({', '.join(on) or 'all off'})"
        if value in self.choices:
            return f"{_num(value)} ({self.choices[value]})"
        if self.open_from is not None and value >= self.open_from:
            return f"0x{value:X} ({self.open_meaning})"
        if not self.takes:
            return "no value"
        return f"{value}{' ' + self.unit if self.unit else ''}"


def _num(value: int) -> str:
    """A choice as the manual's tables print it: 0–9 plain, the rest in hex (types 0xA…)."""
    return str(value) if -9 <= value <= 9 else f"0x{value:X}"


@dataclass(frozen=True)
class Form:
    """One nn of a command: what it does (`does`), its para (`value`), its `frame`."""

    nn: int
    does: str
    value: Value
    frame: Frame


@dataclass(frozen=True)
class AlinkCommand:
    """One command of §11: its name, code, section, kind and forms by nn."""

    name: str              # as `stepramp alink command` takes it
    cmd: Cmd
    title: str             # what the manual calls it, in English
    section: str           # §11-x (n)
    kind: str              # setting, drive, homing, output, status, other, read-back
    forms: Mapping[int, Form]

    @property
    def default_nn(self) -> int:
        return next(iter(self.forms))

    @property
    def label(self) -> str:
        return f"{self.name} ({self.cmd.name} 0x{int(self.cmd):02X})"

    def form(self, nn: int | None, label: str = "nn") -> Form:
        """The form of `nn` (None: the first the manual gives), or a one-line refusal."""
        if nn is None:
            return self.forms[self.default_nn]
        if isinstance(nn, bool) or not isinstance(nn, int) or nn not in self.forms:
            raise FormatError(f"{label}: {echo(nn)} is not an nn of {self.name} ("
                              + "; ".join(f"{k}: {f.does}" for k, f in self.forms.items())
                              + ")")
        return self.forms[nn]


def _frame(cmd: Cmd, nn: int) -> Frame:
    """The command word triple with the code and nn fixed (bit 13, the reserved `*`, is
    0: the strict Bits refuse it set), the pair code in bits 15–14 of each word."""
    return Frame(f"alink.{cmd.name}.nn{nn}", (
        Bits("cmd_word", 2, (Bit("pair0", 14, 2), Bit("func", 8, 5, const=nn),
                             Bit("cmd", 0, 8, const=int(cmd))), order="little"),
        Bits("param1", 2, (Bit("pair1", 14, 2), Bit("para_hi", 0, 14)), order="little"),
        Bits("param2", 2, (Bit("pair2", 14, 2), Bit("para_lo", 0, 14)), order="little"),
    ))


# --- the values ---------------------------------------------------------------------------------
NONE = Value("none")
PULSE = Value("pulse", "pulses", PARA_MIN, PARA_MAX)
SPEED = Value("speed", "pps", 1, SPEED_MAX_PPS)
# UP_TIME / O_UPTIME nn = 2: appendix 3's ranges of the multipliers the unit can select
# (×1…×20: 1..160000); which part applies depends on the multiplier (check says so).
ACCEL_PARA = Value("para", "× 0.01 ms/kpps", 1, 160_000)
ACCEL_RATE = Value("para", "(legacy rate)", 4, 39_320)
ON_OFF = Value("out", choices={0: "off", 1: "on"})
_SIGNAL_LOGIC = {2: "EL positive logic", 4: "SD positive logic", 5: "ORG positive logic",
                 13: "STP positive logic (whole unit)"}
_MODE = {4: "S-curve", 5: "triangle avoidance"}
_MODE_SIG = {4: "SD input disabled", 5: "STA (start all axes) enabled",
             6: "STP (stop all axes) enabled (whole unit)", 8: "check (factory inspection)"}
_EDGE = {28: "at the origin's leading edge (OFF→ON)", 30: "at its trailing edge (ON→OFF)"}
_READ_STAT = {0x0: "position", 0x1: "input ports IN0, IN1", 0x2: "output ports OUT0–OUT3",
              0x6: "origin set, offset", 0x7: "Nak cause", 0x8: "watchdog",
              0x9: "stop cause", 0xF: "check result (factory inspection)",
              0x3FFF: "A-Link check (factory inspection)"}
# Factory features the unit takes but stepramp never writes (`encode_command` refuses them,
# check warns: `factory_use`): MODE_SIG D8, READ_STAT 0xF and 0x3FFF.
_FACTORY_STAT = {0xF: "the factory check result: for inspection only",
                 0x3FFF: "the factory A-Link check: the manual says never to use it (the unit "
                         "leaves it only when all three words are 0, or after about 5 s)"}
MODE_SIG_FACTORY_BIT = 8
_READ = {0x0: "position", 0x1: "+ soft limit", 0x2: "- soft limit", 0x3: "reset value",
         0x4: "self-start speed", 0x5: "high speed", 0x6: "acceleration pulse rate",
         0x7: "running speed", 0xA: "stop history number"}
SOFT_LIMIT = Value("pulse", "pulses", PARA_MIN, PARA_MAX,
                   refused={0: "a soft limit is 1..134217727 (+) or -134217728..-1 (-)"})
# CHANGE_SPD nn = 0: a percentage of the high speed; up to 200 % without MAX_SPEED, up to
# MAX_SPEED with it (high 1 pps, MAX 100 kpps: 10 000 000 %): check judges it against the
# settings the list leaves.
PERCENT = Value("speed", "%", 1, 10_000_000)


def _forms(cmd: Cmd, *forms: tuple[int, str, Value]) -> dict[int, Form]:
    return {nn: Form(nn, does, value, _frame(cmd, nn)) for nn, does, value in forms}


def _one(name: str, cmd: Cmd, title: str, section: str, kind: str,
         *forms: tuple[int, str, Value]) -> AlinkCommand:
    return AlinkCommand(name, cmd, title, section, kind, _forms(cmd, *forms))


def _read_back(cmd: Cmd, title: str, n: int, nn: int = 0) -> AlinkCommand:
    return _one(cli_name(cmd), cmd, f"read back {title}", f"§11-9 ({n})", "read-back",
                (nn, f"read the {title} setting", NONE))


def cli_name(cmd: Cmd) -> str:
    """The name `stepramp alink command` takes for `cmd` (CHANGE_SPD: change-speed)."""
    return "change-speed" if cmd is Cmd.CHANGE_SPD else cmd.name.lower().replace("_", "-")


_ALL: tuple[AlinkCommand, ...] = (
    # §11-2 settings
    _one("logic", Cmd.LOGIC, "signal logic", "§11-2 (1)", "setting",
         (0, "set the signal logic", Value("logic", bits=_SIGNAL_LOGIC))),
    _one("mode", Cmd.MODE, "control mode", "§11-2 (2)", "setting",
         (0, "set the control mode", Value("mode", bits=_MODE, fixed=0x5))),
    _one("l-speed", Cmd.L_SPEED, "self-start speed", "§11-2 (3)", "setting",
         (1, "set the self-start speed (×1 pps)", SPEED)),
    _one("h-speed", Cmd.H_SPEED, "high speed", "§11-2 (4), missing: inferred", "setting",
         (1, "set the high speed (×1 pps)", SPEED)),
    _one("up-time", Cmd.UP_TIME, "acceleration", "§11-2 (5), missing: inferred", "setting",
         (2, "set the acceleration pulse rate (para × 0.01 ms per 1000 pps)", ACCEL_PARA),
         (1, "set the legacy acceleration rate (axis chip R3/R4)", ACCEL_RATE)),
    _one("max-speed", Cmd.MAX_SPEED, "upper speed limit", "§11-2 (6)", "setting",
         (1, "set MAX_SPEED (0: not set, a speed change up to 2× the high speed)",
          Value("speed", "pps", 0, SPEED_MAX_PPS))),
    _one("mode-sig", Cmd.MODE_SIG, "signal mode", "§11-2 (7)", "setting",
         (0, "set the signal mode", Value("mode", bits=_MODE_SIG))),
    _one("ol-speed", Cmd.OL_SPEED, "origin low speed", "§11-2 (8)", "setting",
         (1, "set the origin low speed (×1 pps)", SPEED)),
    _one("oh-speed", Cmd.OH_SPEED, "origin high speed", "§11-2 (9)", "setting",
         (1, "set the origin high speed (×1 pps)", SPEED)),
    _one("o-uptime", Cmd.O_UPTIME, "origin acceleration", "§11-2 (10)", "setting",
         (2, "set the homing acceleration pulse rate (para × 0.01 ms per 1000 pps)",
          ACCEL_PARA),
         (1, "set the homing legacy acceleration rate", ACCEL_RATE)),
    _one("setting", Cmd.SETTING, "coordinates and soft limits", "§11-2 (11) (12)", "setting",
         (29, "set the current position's coordinate (after the origin)", PULSE),
         (30, "set a soft limit (> 0: the + limit, < 0: the - limit)", SOFT_LIMIT)),
    # §11-3 drive
    _one("move-r", Cmd.MOVE_R, "relative move", "§11-3 (1)", "drive",
         (28, "move by pulse (relative)", PULSE)),
    _one("move-a", Cmd.MOVE_A, "absolute move", "§11-3 (2)", "drive",
         (28, "move to pulse (absolute; needs the origin)", PULSE)),
    _one("stop", Cmd.STOP, "stop", "§11-3 (3) (4)", "stop",
         (28, "stop at once (the position is not kept)", NONE),
         (31, "decelerate and stop (the position is kept)", NONE)),
    # §11-4 homing
    _one("home", Cmd.HOME, "homing", "§11-4 (1)", "homing",
         (1, "search CW, stop at the origin's CCW edge", NONE),
         (2, "search CCW, stop at the origin's CCW edge", NONE),
         (3, "search CW, stop at the origin's CW edge", NONE),
         (4, "search CCW, stop at the origin's CW edge", NONE)),
    *(_one(cli_name(c), c, title, f"§11-4 ({n})", "homing",
           *((nn, f"{verb} {edge}", NONE) for nn, edge in _EDGE.items()))
      for c, title, n, verb in ((Cmd.P_SEARCH, "CW origin search", 2, "search CW, stop"),
                                (Cmd.M_SEARCH, "CCW origin search", 3, "search CCW, stop"),
                                (Cmd.P_ORG, "CW origin alignment", 4,
                                 "move CW at the origin low speed, set the origin"),
                                (Cmd.M_ORG, "CCW origin alignment", 5,
                                 "move CCW at the origin low speed, set the origin"))),
    # §11-5 outputs
    _one("out-m", Cmd.OUT_M, "motor power (output 1)", "§11-5 (1)", "output",
         (28, "motor power output", ON_OFF)),
    _one("out-b", Cmd.OUT_B, "brake release (output 2)", "§11-5 (2)", "output",
         (28, "brake release output", ON_OFF)),
    _one("out-s", Cmd.OUT_S, "servo on (output 3)", "§11-5 (3)", "output",
         (28, "servo-on output", ON_OFF)),
    _one("out-g", Cmd.OUT_G, "general output 4 and the LED", "§11-5 (4) (5)", "output",
         (28, "general output 4", Value("out", choices={0: "off", 8: "on"})),
         (31, "the LED", ON_OFF)),
    # §11-6 extended status
    _one("read-stat", Cmd.READ_STAT, "axis state", "§11-6 (1)", "status",
         (0, "read an axis state", Value("type", lo=0, hi=0x3FFF, choices=_READ_STAT,
                                         open_from=0x20, open_meaning="error check"))),
    _one("read", Cmd.READ, "values", "§11-6 (2) (3)", "status",
         (0, "read a value", Value("type", lo=0, hi=0xA, choices=_READ)),
         (3, "upload the position continuously (no Ack: any command ends it)", NONE)),
    # §11-7 other commands
    _one("change-speed", Cmd.CHANGE_SPD, "speed change while driving", "§11-7 (1)", "other",
         (1, "change the running speed to speed pps", SPEED),
         (0, "change the running speed to speed % of the high speed", PERCENT)),
    _one("limit", Cmd.LIMIT, "move to a limit", "§11-7 (2)", "drive",
         (0, "move CW to the limit (speed 0: the high speed)",
          Value("speed", "pps", 0, SPEED_MAX_PPS)),
         (3, "move CCW to the limit (speed 0: the high speed)",
          Value("speed", "pps", 0, SPEED_MAX_PPS))),
    _one("clear-el", Cmd.CLEAR_EL, "clear the limit flags", "§11-7 (3)", "other",
         (0, "clear status D12 (limit detected) and D15 (abnormal stop)", NONE)),
    _one("delay", Cmd.DELAY, "delay", "§11-7 (4)", "other",
         (0, "hold D6 (inhibit) for time ms", Value("time", "ms", 0, PARA_MAX))),
    _one("offset", Cmd.OFFSET, "origin offset", "§11-7 (5)", "drive",
         (0, "move to pulse (absolute; needs the origin), then count from 0 there", PULSE)),
    _one("reset-pos", Cmd.RESET_POS, "position reset", "§11-7 (6)", "drive",
         (0, "move by pulse (relative), then count from 0 and take it as the origin", PULSE)),
    # §11-9 read-backs (SETTING_R: §11-9 (11) prints form(SETTING, 29, 0); the code is
    # table 12-4-1's 0x87, the nn the printed 29)
    _read_back(Cmd.LOGIC_R, "signal logic", 1),
    _read_back(Cmd.MODE_R, "control mode", 2),
    _read_back(Cmd.L_SPEED_R, "self-start speed", 3),
    _read_back(Cmd.H_SPEED_R, "high speed", 4),
    _read_back(Cmd.UP_TIME_R, "acceleration", 5),
    _read_back(Cmd.MAX_SPEED_R, "upper speed limit", 6),
    _read_back(Cmd.MODE_SIG_R, "signal mode", 7),
    _read_back(Cmd.OL_SPEED_R, "origin low speed", 8),
    _read_back(Cmd.OH_SPEED_R, "origin high speed", 9),
    _read_back(Cmd.O_UPTIME_R, "origin acceleration", 10),
    _read_back(Cmd.SETTING_R, "coordinate change", 11, nn=29),
)
COMMANDS: dict[str, AlinkCommand] = {c.name: c for c in _ALL}
_BY_CODE: dict[int, AlinkCommand] = {int(c.cmd): c for c in _ALL}


def command_of(cmd: int) -> AlinkCommand:
    """The registry entry of a command code."""
    try:
        return _BY_CODE[int(cmd)]
    except (KeyError, TypeError, ValueError):
        raise UnknownCommandError(f"cmd: {echo(cmd)} is not an A-Link ALUM command") from None


def form_of(cmd: int, nn: int) -> Form | None:
    """The form of (cmd, nn), None when §11 gives the command no such nn."""
    return command_of(cmd).forms.get(nn)


def encode_command(name: str, value: int | None = None, nn: int | None = None, *,
                   pair: int = 1, address: int | None = None,
                   labels: Mapping[str, str] | None = None) -> Command:
    """The words of command `name` (`COMMANDS`) with its para `value` and its `nn` (None:
    the first form), pair code `pair` on all three words; `address`: the memory-map
    offset the file notes. What §11 does not give is refused in one line, naming the
    field as `labels` says (the CLI's `--value`, `--nn`, `--pair`)."""
    names = {"value": "value", "nn": "nn", "pair": "pair", **(labels or {})}
    command = COMMANDS.get(name) if isinstance(name, str) else None
    if command is None:
        raise UnknownCommandError(f"{echo(name)} is not an A-Link command (one of "
                                  f"{', '.join(COMMANDS)})")
    form = command.form(nn, names["nn"])
    if isinstance(pair, bool) or not isinstance(pair, int) or not 1 <= pair <= 3:
        raise FieldRangeError(names["pair"], pair, 1, 3)
    para = _para(command, form, value, names["value"])
    raw = para & 0x0FFF_FFFF
    data = form.frame.encode(pair0=pair, pair1=pair, pair2=pair, para_hi=raw >> 14,
                             para_lo=raw & 0x3FFF)
    return Command(command.cmd.name, int(command.cmd), form.nn, para, words_of(data), pair,
                   address)


def _para(command: AlinkCommand, form: Form, value: Any, label: str) -> int:
    v = form.value
    where = f"{label} ({command.name} nn {form.nn}: {v.what})"
    if not v.takes:
        if value not in (None, 0) or isinstance(value, bool):
            raise FormatError(f"{label}: {command.name} nn {form.nn} takes no value "
                              f"({form.does}: its para is 0)")
        return 0
    if value is None:
        raise FormatError(f"{label}: {command.name} nn {form.nn} needs one: {v.what}, "
                          f"{v.shown}")
    if not is_number(value, integral=True) or isinstance(value, float):
        raise FormatError(f"{where}: {echo(value)} is not an integer")
    if not v.bits and not v.choices and not v.lo <= value <= v.hi:
        raise FieldRangeError(where, value, v.lo, v.hi)
    problem = v.problem(value)
    if problem is None:
        factory = factory_use(int(command.cmd), form.nn, value)
        problem = None if factory is None else f"{factory}: stepramp does not write it"
    if problem is not None:
        raise FormatError(f"{where}: {problem}")
    return int(value)


@dataclass(frozen=True)
class Decoded:
    """A command word triple read back: its registry entry, form (None: an nn §11 does
    not give the command), nn, para as the form reads it, pair code, and what in it the
    unit would not take (`problems`, empty when §11 gives all of it)."""

    command: AlinkCommand
    form: Form | None
    nn: int
    value: int
    pair: int
    problems: tuple[str, ...]

    def describe(self) -> str:
        c = self.command
        head = f"{c.cmd.name} ({c.name}, {c.section} {c.title}) nn {self.nn}"
        what = (f": {self.form.does}; {self.form.value.what} {self.form.value.meaning(self.value)}"
                if self.form is not None and self.form.value.takes else
                f": {self.form.does}" if self.form is not None else f", para {self.value}")
        tail = "".join(f"; NOT TAKEN: {p}" for p in self.problems)
        return f"{head}{what}, pair {self.pair}{tail}"

    def to_json(self) -> dict[str, Any]:
        return {"name": self.command.name, "symbol": self.command.cmd.name,
                "cmd": int(self.command.cmd), "nn": self.nn, "value": self.value,
                "pair": self.pair, "section": self.command.section,
                "does": None if self.form is None else self.form.does,
                "problems": list(self.problems)}


def decode_command(w0: int, w1: int, w2: int) -> Decoded:
    """The command a word triple carries, named, with what §11 does not give in it; raises
    (one line) only for words that are no command (`parse_command`)."""
    cmd, func, raw_para, pair = parse_command(w0, w1, w2)
    command = command_of(cmd)
    form = command.forms.get(func)
    if form is None:
        return Decoded(command, None, func, raw_para, pair,
                       (f"nn {func} is not one §11 gives {command.cmd.name} ("
                        + ", ".join(str(k) for k in command.forms) + ")",))
    d = form.frame.decode(pack_words((w0, w1, w2)))
    raw = (d["para_hi"] << 14) | d["para_lo"]
    value = signed28(raw) if form.value.signed else raw
    problem = form.value.problem(value) if form.value.takes else (
        None if value == 0 else f"para {value}: {form.does} takes none (0)")
    return Decoded(command, form, func, value, pair, () if problem is None else (problem,))


def factory_use(cmd: int, nn: int, value: int) -> str | None:
    """A factory-inspection feature the command uses (MODE_SIG D8, READ_STAT 0xF or
    0x3FFF), or None."""
    if cmd == Cmd.MODE_SIG and value >= 0 and value >> MODE_SIG_FACTORY_BIT & 1:
        return "MODE_SIG D8 (check) is for factory inspection"
    if cmd == Cmd.READ_STAT and nn == 0 and value in _FACTORY_STAT:
        return f"READ_STAT type 0x{value:X}: {_FACTORY_STAT[value]}"
    return None
