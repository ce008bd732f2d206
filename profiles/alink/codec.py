"""A-Link ALUM command words, responses and the memory map, each frame described once.

Facts: the manual (`seeds/alink-alum-manual-ja.txt`, §9, §11, §12). Command words
(`form`, `CommandWriter`, `settings_commands`) and responses (`decode_response`)
are `fields.Frame`s: one description serves encode and decode.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, Literal

from ..errors import FieldRangeError, FormatError, UnknownCommandError, echo, is_number, require_int
from ..fields import Bit, Bits, Frame
from .model import (
    MODE_DEFAULT,
    MODE_S_CURVE,
    MODE_TRIANGLE_AVOID,
    SPEED_MAX_PPS,
    AlinkSettings,
)

# --- command codes (manual 12-4 table 12-4-1, 11-2 … 11-9) ------------------------------------

class Cmd(IntEnum):
    LOGIC = 0x1C
    MODE = 0x1D
    L_SPEED = 0x12
    H_SPEED = 0x13
    UP_TIME = 0x14
    MAX_SPEED = 0x15
    SETTING = 0x17
    OL_SPEED = 0x18
    OH_SPEED = 0x19
    O_UPTIME = 0x1A
    MODE_SIG = 0x1E
    MOVE_R = 0x21
    MOVE_A = 0x22
    STOP = 0x2F
    HOME = 0x31
    P_SEARCH = 0x3C
    M_SEARCH = 0x3D
    P_ORG = 0x3E
    M_ORG = 0x3F
    READ_STAT = 0x45
    READ = 0x46
    OUT_M = 0x4C
    OUT_B = 0x4D
    OUT_S = 0x4E
    OUT_G = 0x4F
    CHANGE_SPD = 0x51
    LIMIT = 0x52
    DELAY = 0x58
    OFFSET = 0x5A
    RESET_POS = 0x5B
    CLEAR_EL = 0x5C
    # read-backs (11-9): 0x86 and 0x8B do not exist
    L_SPEED_R = 0x82
    H_SPEED_R = 0x83
    UP_TIME_R = 0x84
    MAX_SPEED_R = 0x85
    SETTING_R = 0x87
    OL_SPEED_R = 0x88
    OH_SPEED_R = 0x89
    O_UPTIME_R = 0x8A
    LOGIC_R = 0x8C
    MODE_R = 0x8D
    MODE_SIG_R = 0x8E


READ_BACKS = frozenset(c for c in Cmd if c >= 0x80)
# func (nn) values of the commands stepramp sends (settings_commands, verify.sync)
FUNC_SPEED_PPS = 1       # L_SPEED/H_SPEED/MAX_SPEED: ×1 pps
FUNC_ACCEL_PARA = 2      # UP_TIME nn = 2: para × 0.01 ms/kpps
FUNC_MOVE = 28           # MOVE_R/MOVE_A: para = pulses

PARA_MIN = -(1 << 27)
PARA_MAX = (1 << 27) - 1
FUNC_MAX = 31

COMMAND_FRAME = Frame("alink.command", (
    Bits("cmd_word", 2, (Bit("pair0", 14, 2), Bit("func", 8, 5), Bit("cmd", 0, 8)),
         order="little"),
    Bits("param1", 2, (Bit("pair1", 14, 2), Bit("para_hi", 0, 14)), order="little"),
    Bits("param2", 2, (Bit("pair2", 14, 2), Bit("para_lo", 0, 14)), order="little"),
))


def command_name(cmd: int) -> str:
    try:
        return Cmd(cmd).name
    except ValueError:
        raise UnknownCommandError(f"cmd: 0x{cmd:02X} is not an A-Link ALUM command "
                                  "(see profiles.alink.Cmd)") from None


def form(cmd: int, func: int, para: int) -> tuple[int, int, int]:
    """(CMD, PARAM1, PARAM2) without pair code: CMD = ((func << 8) & 0x1FFF) + cmd,
    para as 28-bit two's complement split 14 + 14."""
    return _form_words(cmd, func, para, 0)


def _form_words(cmd: int, func: int, para: int, pair: int) -> tuple[int, int, int]:
    if not is_number(cmd, integral=True):
        raise UnknownCommandError(f"cmd: {echo(cmd)} is not an A-Link ALUM command code")
    command_name(cmd)
    require_int("func", func, 0, FUNC_MAX)
    require_int("para", para, PARA_MIN, PARA_MAX)
    raw = para & 0x0FFF_FFFF
    data = COMMAND_FRAME.encode(pair0=pair, pair1=pair, pair2=pair, func=func, cmd=int(cmd),
                                para_hi=raw >> 14, para_lo=raw & 0x3FFF)
    return words_of(data)


def parse_command(w0: int, w1: int, w2: int) -> tuple[int, int, int, int]:
    """Inverse of the command words: (cmd, func, para, pair); refuses unknown codes,
    a set reserved bit 13 and unequal pair codes."""
    d = COMMAND_FRAME.decode(pack_words((w0, w1, w2)))
    command_name(d["cmd"])
    pairs = (d["pair0"], d["pair1"], d["pair2"])
    if len(set(pairs)) != 1:
        raise FormatError(f"pair codes differ across the three words: {pairs}")
    return d["cmd"], d["func"], signed28((d["para_hi"] << 14) | d["para_lo"]), pairs[0]


class PairCode(IntEnum):
    """Bits 15–14 of every command word (bits 3–2 of the status word)."""

    NOOP = 0
    ONE = 1
    TWO = 2
    THREE = 3

    def next(self) -> PairCode:
        return PairCode(next_pair(self))


def next_pair(pair: int) -> int:
    """Pair code after `pair`: 1 → 2 → 3 → 1 (0, the no-op, is never produced)."""
    require_int("pair", pair, 0, 3)
    return pair % 3 + 1


@dataclass(frozen=True)
class Command:
    name: str
    cmd: int
    func: int
    para: int
    words: tuple[int, int, int]  # pair code applied
    pair: int
    address: int | None = None   # D0 byte offset of the CMD word, when known


class CommandWriter:
    """putcmd: gives each command the next pair code (first one 1) on all three words."""

    def __init__(self, *, address: int | None = None) -> None:
        self.pair = 0  # last pair code sent (PairOld); 0 before the first command
        self.address = address

    def put(self, cmd: int, func: int, para: int) -> Command:
        pair = next_pair(self.pair)
        words = _form_words(cmd, func, para, pair)
        self.pair = pair
        return Command(command_name(cmd), int(cmd), func, para, words, pair, self.address)

    def stream(self, commands: Iterable[tuple[int, int, int]]) -> Iterator[tuple[int, int, int]]:
        """Yield the words of each (cmd, func, para) with pair codes applied."""
        for cmd, func, para in commands:
            yield self.put(cmd, func, para).words


def settings_commands(settings: AlinkSettings, *, slave_address: int | None = None,
                      axis: int = 0, duplex: Duplex = "full",
                      writer: CommandWriter | None = None) -> list[Command]:
    """The commands that program `settings`: MAX_SPEED, MODE, H_SPEED, L_SPEED, UP_TIME.

    MAX_SPEED and H_SPEED come first since the multiplier depends on them; the
    unit checks start ≤ high ≤ MAX_SPEED only at drive time (Nak), not per setting.
    """
    if writer is None:
        address = (None if slave_address is None
                   else command_address(slave_address, axis, duplex))
        writer = CommandWriter(address=address)
    seq = ((Cmd.MAX_SPEED, FUNC_SPEED_PPS, settings.max_pps),
           (Cmd.MODE, 0, settings.mode_word),
           (Cmd.H_SPEED, FUNC_SPEED_PPS, settings.high_pps),
           (Cmd.L_SPEED, FUNC_SPEED_PPS, settings.start_pps),
           (Cmd.UP_TIME, FUNC_ACCEL_PARA, settings.accel_para))
    return [writer.put(c, f, p) for c, f, p in seq]


SETTINGS_CMDS = (Cmd.MAX_SPEED, Cmd.MODE, Cmd.H_SPEED, Cmd.L_SPEED, Cmd.UP_TIME)
_SETTING_FUNC = {Cmd.MAX_SPEED: FUNC_SPEED_PPS, Cmd.MODE: 0, Cmd.H_SPEED: FUNC_SPEED_PPS,
                 Cmd.L_SPEED: FUNC_SPEED_PPS, Cmd.UP_TIME: FUNC_ACCEL_PARA}
_MODE_KNOWN = MODE_DEFAULT | MODE_S_CURVE | MODE_TRIANGLE_AVOID


def settings_from_commands(commands: Iterable[Command | tuple[int, int, int]]
                           ) -> AlinkSettings:
    """The settings that `commands` program: the inverse of `settings_commands`.

    `commands` are `Command`s or (cmd, func, para) triples; each of MAX_SPEED, MODE,
    H_SPEED, L_SPEED and UP_TIME must appear exactly once, with the func
    `settings_commands` gives it (×1 pps speeds, UP_TIME nn = 2), and no other
    command. The MODE word must have D0 and D2 set and no bit stepramp does not know;
    the values must make settings the unit runs unchanged (`AlinkSettings`).
    """
    values: dict[int, int] = {}
    for c in commands:
        cmd, func, para = (c.cmd, c.func, c.para) if isinstance(c, Command) else c
        name = command_name(cmd)
        if cmd not in _SETTING_FUNC:
            raise FormatError(f"{name}: not a settings command (settings are "
                              f"{', '.join(Cmd(k).name for k in SETTINGS_CMDS)})")
        if cmd in values:
            raise FormatError(f"{name} is given twice")
        if func != _SETTING_FUNC[Cmd(cmd)]:
            raise FormatError(f"{name}: func {func}, stepramp's settings use func "
                              f"{_SETTING_FUNC[Cmd(cmd)]}")
        values[cmd] = para
    missing = [Cmd(k).name for k in SETTINGS_CMDS if k not in values]
    if missing:
        raise FormatError(f"the settings lack {', '.join(missing)}")
    mode = values[Cmd.MODE]
    if mode & MODE_DEFAULT != MODE_DEFAULT or mode & ~_MODE_KNOWN:
        raise FormatError(f"MODE: 0x{mode:X} is not 0x{MODE_DEFAULT:X} (D0 = D2 = 1) with "
                          f"D4 (S-curve) and D5 (triangle avoidance) only")
    if values[Cmd.MAX_SPEED] < 0:
        raise FieldRangeError("max_pps", values[Cmd.MAX_SPEED], 0, SPEED_MAX_PPS)
    return AlinkSettings(values[Cmd.L_SPEED], values[Cmd.H_SPEED], values[Cmd.UP_TIME],
                         values[Cmd.MAX_SPEED], bool(mode & MODE_S_CURVE),
                         bool(mode & MODE_TRIANGLE_AVOID))


def settings_document(settings: AlinkSettings, commands: Iterable[Command], *,
                      summary: dict[str, Any] | None = None,
                      warnings: Iterable[str] = ()) -> dict[str, Any]:
    """`settings` and the `commands` that program them as a JSON-ready dict (what
    `stepramp alink settings --format json` prints); `summary` adds planner numbers."""
    return {"multiplier": settings.multiplier, "start_pps": settings.start_pps,
            "high_pps": settings.high_pps, "up_time_para": settings.accel_para,
            "accel_ms_per_kpps": settings.accel_ms_per_kpps,
            "accel_pps2": settings.accel_pps2, "max_pps": settings.max_pps,
            "s_curve": settings.s_curve, **(summary or {}), "warnings": list(warnings),
            "commands": command_rows(commands)}


def command_rows(commands: Iterable[Command]) -> list[dict[str, Any]]:
    """The commands as `settings_document` lists them (JSON-ready)."""
    return [{"name": c.name, "cmd": c.cmd, "func": c.func, "para": c.para,
             "words": [f"0x{w:04X}" for w in c.words],
             **({"address": f"0x{c.address:03X}"} if c.address is not None else {})}
            for c in commands]


# --- memory map (manual 9-2, 9-3) --------------------------------------------------------------

Duplex = Literal["full", "half"]
D0_BASE = 0x080  # commands
DI_BASE = 0x100  # status
AXES = 2
_SLAVE_MAX = {"full": 53, "half": 58}  # last address of the 2-axis unit must stay ≤ 63


def _address(base: int, slave_address: int, axis: int, duplex: str, word: int) -> int:
    if duplex not in _SLAVE_MAX:
        raise FormatError(f"duplex: {echo(duplex)} is not 'full' or 'half'")
    require_int("slave_address", slave_address, 1, _SLAVE_MAX[duplex])
    require_int("axis", axis, 0, AXES - 1)
    require_int("word", word, 0, 2)
    step = 2 if duplex == "full" else 1
    return base + 2 * (slave_address + step * (3 * axis + word))


def command_address(slave_address: int, axis: int = 0, duplex: Duplex = "full",
                    word: int = 0) -> int:
    """Byte offset in the master's memory of command word `word` (0 CMD, 1 PARAM1,
    2 PARAM2) of `axis` (0 or 1) of the unit at `slave_address`."""
    return _address(D0_BASE, slave_address, axis, duplex, word)


def status_address(slave_address: int, axis: int = 0, duplex: Duplex = "full",
                   word: int = 0) -> int:
    """Byte offset of response word `word` (0 status, 1 DATA1, 2 DATA2)."""
    return _address(DI_BASE, slave_address, axis, duplex, word)


# --- responses (manual 11-1, 11-8, 11-9 (12)) ---------------------------------------------------

_DATA_WORDS = (
    Bits("data1", 2, (Bit("pair1", 14, 2), Bit("value_hi", 0, 14)), order="little"),
    Bits("data2", 2, (Bit("pair2", 14, 2), Bit("value_lo", 0, 14)), order="little"),
)
STATUS_BITS = (Bit("ack", 0), Bit("eeprom_error", 1), Bit("pair0", 2, 2), Bit("extended", 4),
               Bit("driving", 5), Bit("inhibit", 6), Bit("origin_set", 8),
               Bit("origin_detecting", 9), Bit("plus_limit", 10), Bit("minus_limit", 11),
               Bit("limit_latched", 12), Bit("abnormal_stop", 15))
RESPONSE_FRAME = Frame("alink.response", (
    Bits("status", 2, STATUS_BITS, order="little", strict=False), *_DATA_WORDS))
# Read-back status: bits 3–2 carry the pair code (answith checks them for every answer;
# the table's "パラメータ0" label there is read as an erratum), bits 9–6 echo the
# sub-command, bits 15–11 hold parameter 0 (unit / method flag of PARAM1/2).
READBACK_STATUS_BITS = (Bit("ack", 0), Bit("pair0", 2, 2), Bit("extended", 4),
                        Bit("subcommand", 6, 4), Bit("param0", 11, 5))
READBACK_FRAME = Frame("alink.readback", (
    Bits("status", 2, READBACK_STATUS_BITS, order="little", strict=False), *_DATA_WORDS))
_FLAGS = ("eeprom_error", "extended", "driving", "inhibit", "origin_set", "origin_detecting",
          "plus_limit", "minus_limit", "limit_latched", "abnormal_stop")


@dataclass(frozen=True)
class AlinkResponse:
    ack: bool
    pair_codes: tuple[int, int, int]  # status, DATA1, DATA2
    value: int                        # DATA1:DATA2 as 28-bit signed
    valid: bool                       # all pair codes equal (and equal the one sent)
    mismatch: str | None = None       # which pair code disagrees, when not valid
    read_back: bool = False
    eeprom_error: bool = False
    extended: bool = False
    driving: bool = False
    inhibit: bool = False
    origin_set: bool = False
    origin_detecting: bool = False
    plus_limit: bool = False
    minus_limit: bool = False
    limit_latched: bool = False
    abnormal_stop: bool = False
    subcommand: int | None = None     # read-backs only: low nibble of the command echoed
    param0: int | None = None         # read-backs only

    def words(self) -> tuple[int, int, int]:
        """Re-encode (the inverse of decode_response for the bits the layout names)."""
        raw = self.value & 0x0FFF_FFFF
        vals: dict[str, Any] = {"ack": self.ack, "pair0": self.pair_codes[0],
                                "pair1": self.pair_codes[1], "pair2": self.pair_codes[2],
                                "value_hi": raw >> 14, "value_lo": raw & 0x3FFF}
        if self.read_back:
            vals.update(extended=self.extended, subcommand=self.subcommand or 0,
                        param0=self.param0 or 0)
            return words_of(READBACK_FRAME.encode(vals))
        vals.update({k: getattr(self, k) for k in _FLAGS})
        return words_of(RESPONSE_FRAME.encode(vals))


_WORD_NAMES = ("status", "DATA1", "DATA2")


def decode_response(w0: int, w1: int, w2: int, *, expected_pair: int | None = None,
                    read_back: bool = False, expected_cmd: int | None = None) -> AlinkResponse:
    """Decode status, DATA1, DATA2. Not `valid` (with `mismatch` saying which word
    disagrees) while the pair codes differ or differ from `expected_pair`: the host
    polls again. For read-backs, `expected_cmd` checks the echoed sub-command."""
    if expected_pair is not None:
        require_int("expected_pair", expected_pair, 0, 3)
    frame = READBACK_FRAME if read_back else RESPONSE_FRAME
    d = frame.decode(pack_words((w0, w1, w2)))
    pairs = (d["pair0"], d["pair1"], d["pair2"])
    mismatch = None
    ref = pairs[0] if expected_pair is None else expected_pair
    for name, p in zip(_WORD_NAMES, pairs, strict=True):
        if p != ref:
            mismatch = (f"{name} pair code {p} ≠ {ref}" +
                        (" (sent)" if expected_pair is not None else " (status word's)"))
            break
    if mismatch is None and read_back and expected_cmd is not None:
        command_name(expected_cmd)
        if d["subcommand"] != expected_cmd & 0xF:
            mismatch = (f"status sub-command {d['subcommand']} ≠ {expected_cmd & 0xF} "
                        f"({command_name(expected_cmd)})")
    value = signed28((d["value_hi"] << 14) | d["value_lo"])
    common: dict[str, Any] = dict(ack=bool(d["ack"]), pair_codes=pairs, value=value,
                                  valid=mismatch is None, mismatch=mismatch, read_back=read_back)
    if read_back:
        return AlinkResponse(**common, extended=bool(d["extended"]),
                             subcommand=d["subcommand"], param0=d["param0"])
    flags: dict[str, Any] = {k: bool(d[k]) for k in _FLAGS}
    return AlinkResponse(**common, **flags)


NAK_CAUSES = ("motor type differs", "parameter value not valid",
              "refused: driving (D5) or inhibit (D6)", "self-start speed > high speed",
              "origin not set")


def decode_nak_cause(param2: int) -> list[str]:
    """READ_STAT type 7 (Nak cause) PARAM2 bits D0–D4, as text."""
    require_int("param2", param2, 0, 0x3FFF)
    return [text for bit, text in enumerate(NAK_CAUSES) if param2 >> bit & 1]


# --- word packing ------------------------------------------------------------------------------

def words_of(data: bytes) -> tuple[int, int, int]:
    """Three little-endian 16-bit words of a 6-byte frame."""
    return (int.from_bytes(data[0:2], "little"), int.from_bytes(data[2:4], "little"),
            int.from_bytes(data[4:6], "little"))


def pack_words(words: tuple[int, int, int]) -> bytes:
    """The 6 bytes of three 16-bit words (each checked), little-endian."""
    for name, w in zip(_WORD_NAMES, words, strict=True):
        require_int(f"{name} word", w, 0, 0xFFFF)
    return b"".join(w.to_bytes(2, "little") for w in words)


def signed28(raw: int) -> int:
    """A 28-bit two's complement para as a signed integer."""
    return raw - (1 << 28) if raw & (1 << 27) else raw

