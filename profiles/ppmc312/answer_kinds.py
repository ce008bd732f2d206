"""Every answer the PPMC-312 gives on the parallel bus, each described once (manual §5-7,
§7–§11): a `Kind` is one answer's `Frame`, header first as the manual draws it, and
what its values mean.

The header is `0 0 CMR RESP(2) 0 PAL NEXT` (§5-7.1). Each kind fixes CMR (0: the
answer to a command, 1: a report the chip raises itself), PAL and NEXT as its figure
draws them; RESP says where the command came from (00 the bus, 01 an event, 11 an
override; 10 cannot occur) and is left free but for F8 and F9, whose figures fix it.

The frames of frames.py that the emulator and the table reader already write and read
(init, free curve, F1, F4, F6, table read) are reused here with the general header in
place of their bus-only `03`, never written twice. F0 is the one that differs: its
tail is 「命令とパラメータ」, the refused command and any number of its parameters,
where frames.PARAM_ERROR fixes it to the command code (what the emulator sends, a
valid F0 of tail 1).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from ..fields import Array, Bit, Bits, Const, Frame, SInt, UInt
from .frames import (
    ALARM,
    CODE_FREE_CURVE,
    CODE_INIT,
    CODE_TABLE_READ,
    FC_DONE,
    FC_PROGRESS,
    INIT_DONE,
    MAX_READ_LENGTH,
    PARAM_ERROR,
    PARAM_ERRORS,
    READ_ACCEL,
    READ_DECEL,
    READ_RATES,
    RESP_PARAM_ERROR,
    RESP_SIZE_ERROR,
    RESP_STATE_ERROR,
    SIZE_ERROR,
    STATE_ERROR,
    TABLE_READ_FIRST,
)

# §5-7.1 RESP: where the command the answer belongs to came from; 10 is 「あり得ません」.
SOURCES: dict[int, str] = {0: "bus", 1: "event", 3: "override"}
SOURCE_CODES = {name: code for code, name in SOURCES.items()}
IMPOSSIBLE_RESP = 2

# The parallel command codes (§7–§10), for naming the command an answer speaks of.
COMMAND_NAMES: dict[int, str] = {
    0x00: "init", 0x01: "free curve", 0x02: "in-position setting", 0x03: "encoder setting",
    0x04: "interlock position setting", 0x05: "high-speed limit setting",
    0x06: "END terminal setting",
    0x80: "immediate stop", 0x81: "decelerate stop", 0x82: "accel/decel move",
    0x83: "constant-speed move", 0x84: "single step", 0x85: "continuous high speed",
    0x86: "continuous constant speed", 0x87: "speed change by acceleration",
    0x88: "immediate speed change", 0x10: "constant-speed origin search",
    0x11: "high-speed origin return",
    0x20: "excitation on", 0x21: "excitation off", 0x22: "counter clear", 0x23: "zero clamp",
    0x24: "alarm clear", 0x25: "general input", 0x26: "general output",
    0x27: "control terminal read", 0x28: "mask setting",
    0x40: "version read", 0x41: "table read", 0x42: "position read", 0x43: "position set",
    0x44: "interlock", 0x45: "synchronous operation monitor", 0x47: "event read",
    0x49: "event setting", 0x4D: "status read", 0xFF: "reset",
}
# Fields holding a command code: described by the command's name.
CODE_FIELDS = frozenset(("command", "codes"))


@dataclass(frozen=True)
class Flag:
    """A named bit range of a flags byte: `on` is what a 1 means, `off` what a 0 means
    when the manual says (then both are shown); a `width` > 1 is a count."""

    name: str
    shift: int
    on: str
    off: str | None = None
    width: int = 1


@dataclass(frozen=True)
class Kind:
    """One answer: its frame and what its values mean (`choices`: the documented values
    of a field, any other is refused; `flags`: a byte's named bits)."""

    key: str
    name: str
    section: str
    frame: Frame | None  # None: a serial reply that carries no data
    code: int | None
    choices: Mapping[str, Mapping[int, str]] = field(default_factory=dict)
    flags: Mapping[str, tuple[Flag, ...]] = field(default_factory=dict)
    labels: Mapping[str, str] = field(default_factory=dict)

    @property
    def block(self) -> Frame:
        """The frame of a parallel answer (every one has bytes)."""
        assert self.frame is not None, self.key
        return self.frame

    def fixed_bit(self, name: str) -> int | None:
        """The header bit's value this kind's figure fixes, or None when it is free."""
        header = self.block.fields[0]
        assert isinstance(header, Bits)
        return next((p.const for p in header.parts if p.name == name), None)

    @property
    def field_names(self) -> tuple[str, ...]:
        """The fields an answer of this kind carries (not the header, length or code)."""
        if self.frame is None:
            return ()
        return tuple(f.name for f in self.frame.fields
                     if isinstance(f, UInt | SInt | Array) and f.name != "length")


def answer_header(cmr: int, *, pal: int = 1, last: int | None = 1,
                  resp: int | None = None) -> Bits:
    """`0 0 CMR RESP 0 PAL NEXT`: the bits a figure draws fixed; RESP free unless given."""
    return Bits("header", 1, (
        Bit("cmr", 5, const=cmr),
        Bit("resp", 3, 2, const=resp),
        Bit("pal", 1, const=pal),
        Bit("next", 0) if last is None else Bit("next", 0, const=last),
    ))


def _headed(name: str, frame: Frame, header: Bits) -> Frame:
    # An existing frame's fields after its header, under the general header.
    return Frame(name, (header, *frame.fields[1:]))


def _frame(name: str, code: int, cmr: int, *params: UInt | Array,
           resp: int | None = None) -> Frame:
    size = 1 + sum(p.size for p in params if isinstance(p, UInt))
    return Frame(name, (answer_header(cmr, resp=resp), Const("length", bytes([size])),
                        Const("code", bytes([code])), *params))


def _byte(name: str) -> UInt:
    return UInt(name, 1)


# --- the texts of the manual's tables -----------------------------------------------------
STARTED_OR_HELD = {0x00: "pulse output started", 0x01: "pulse output held (waiting for RUN)"}
MOVE_STATUS = {  # §8-3: the shape the chip runs, and whether RUN holds it
    0x00: "trapezoid, pulse output started", 0x01: "trapezoid, held (waiting for RUN)",
    0x10: "triangle, pulse output started", 0x11: "triangle, held (waiting for RUN)",
    0x20: "straight triangle (decel), pulse output started",
    0x21: "straight triangle (decel), held (waiting for RUN)",
    0x40: "straight triangle (accel), pulse output started",
    0x41: "straight triangle (accel), held (waiting for RUN)",
}
FC_STATUS = {0x00: "rate stages still to send", 0x01: "accel stages still to send",
             0x02: "decel stages still to send"}
ABORT_STATUS = {  # §11-11, §11-12
    0x00: "parameter error", 0x01: "state error (the command cannot be issued in this state)",
    0x02: "a limit signal is input: cannot move", 0x05: "an undefined command code",
    0x06: "a length byte of 0x20 or more",
}
STATE_STATUS = {  # §11-7
    0x00: "state error: the command cannot be issued in this state",
    0x01: "wrong header: data came when a command was due",
    0x02: "wrong header: a command came when data was due",
}
ALARM_STATUS = {  # §11-9
    0x00: "the alarm input (/ALM)",
    0x01: "a command written twice: the host did not read the answer to the first",
    0x02: "a report raised twice: the host did not read a report other than a command's "
          "answer",
    0x03: "pulse output stopped twice: the host did not read the first stop report (E0)",
}
EVENT_STATUS = {  # §10-7
    0x00: "registered", 0x01: "not registered: the trigger is used by an override",
    0x02: "not registered: every buffer is in use", 0x03: "deleted",
    0x04: "deleted: the buffer is now empty", 0x05: "nothing registered to delete",
}
RANGE = {0x00: "inside the range", 0x01: "outside the range"}

STOP_CAUSES = (  # §11-1, bit 7 first
    Flag("ALS", 7, "stopped by the alarm signal"),
    Flag("NOS", 6, "normal end at the output stop position"),
    Flag("ORG", 5, "stopped by the origin input"),
    Flag("LOW", 4, "stopped at once: at the start of deceleration the pulse rate was "
                   "below the stop rate"),
    Flag("DEC", 3, "stopped by the decelerate-stop command"),
    Flag("STP", 2, "stopped by the immediate-stop command"),
    Flag("DEL", 1, "decelerated to a stop by a limit"),
    Flag("STL", 0, "stopped at once by a limit"),
)
STATES = (  # §2-1.8, §10-9, §11-7 (the figures print INT, the tables INI)
    Flag("RUN", 5, "waiting for RUN"), Flag("ALM", 4, "alarm state"),
    Flag("FIX", 3, "pulse output at a constant speed"),
    Flag("ACC", 2, "accelerating or decelerating"), Flag("NOR", 1, "normal state"),
    Flag("INI", 0, "initial state"),
)
INPUTS = tuple(Flag(f"AUXI{k}", k, "1") for k in range(7, -1, -1))
PINS = tuple(Flag(name, shift, "High", "Low") for name, shift in (
    ("/ALM", 7), ("/END", 6), ("/INDEX", 5), ("/ORG", 4), ("/FHL", 3), ("/BHL", 2),
    ("/FL", 1), ("/BL", 0)))
EVENT_PINS = tuple(Flag(name, shift, "High", "Low") for name, shift in (
    ("EVT1", 7), ("EVT0", 6), ("RUN", 5)))
OPERATION = (  # §10-9 動作ステータス
    Flag("CWS", 7, "RUN ignored at pulse start", "RUN monitored at pulse start"),
    Flag("ILS", 6, "interlock in progress", "normal"),
    Flag("ENC", 4, "encoder monitoring on", "encoder monitoring off"),
    Flag("INP", 3, "in-position monitoring on", "in-position monitoring off"),
    Flag("END", 2, "END signal monitored", "END signal not monitored"),
    Flag("EST", 1, "outside the encoder range", "inside the encoder range"),
    Flag("IST", 0, "outside the in-position range", "inside the in-position range"),
)
BUFFERS = (  # §10-9 バッファステータス
    Flag("EV1E", 7, "an event command in event buffer 1"),
    Flag("EV0E", 6, "an event command in event buffer 0"),
    Flag("EV1O", 5, "an override command on event buffer 1"),
    Flag("EV0O", 4, "an override command on event buffer 0"),
    Flag("CBCNT", 0, "override commands in the command buffer", width=4),
)


# --- the kinds ------------------------------------------------------------------------------
def _command_kinds() -> list[Kind]:
    """The answers to the commands of §7–§10 (CMR 0), but the table read's."""
    out = [
        Kind("00", "init answer (00)", "§7-1", _headed("init answer (00)", INIT_DONE,
                                                        answer_header(0)), CODE_INIT),
        Kind("01 progress", "free-curve answer, in progress (01)", "§7-2",
             _headed("free-curve answer, in progress (01)", FC_PROGRESS, answer_header(0)),
             CODE_FREE_CURVE, {"status": FC_STATUS}, labels={"remaining": "stages to send"}),
        Kind("01 done", "free-curve answer, done (01)", "§7-2",
             _headed("free-curve answer, done (01)", FC_DONE, answer_header(0)),
             CODE_FREE_CURVE),
    ]
    bare = {0x02: "§7-3", 0x03: "§7-4", 0x04: "§7-5", 0x05: "§7-6", 0x80: "§8-1",
            0x81: "§8-2", 0x84: "§8-5", 0x87: "§8-8", 0x88: "§8-9", 0x20: "§9-1",
            0x21: "§9-2", 0x22: "§9-3", 0x23: "§9-4", 0x24: "§9-5", 0x26: "§9-7",
            0x28: "§9-9", 0x43: "§10-3", 0xFF: "§10-10"}
    for code, section in bare.items():
        name = f"{COMMAND_NAMES[code]} answer ({code:02X})"
        out.append(Kind(f"{code:02X}", name, section, _frame(name, code, 0), code))
    one_byte: dict[int, tuple[str, str, Mapping[int, str] | None]] = {
        0x06: ("§7-7", "monitor", {0x00: "not monitored", 0x01: "monitored"}),
        0x82: ("§8-3", "status", MOVE_STATUS), 0x83: ("§8-4", "status", STARTED_OR_HELD),
        0x85: ("§8-6", "status", STARTED_OR_HELD), 0x86: ("§8-7", "status", STARTED_OR_HELD),
        0x10: ("§8-10", "status", STARTED_OR_HELD), 0x11: ("§8-11", "status", STARTED_OR_HELD),
        0x25: ("§9-6", "inputs", None), 0x40: ("§10-5", "version", None),
        0x44: ("§10-4", "interlock", {0x00: "control stopped", 0x01: "control started"}),
        0x45: ("§10-6", "run_monitor", {0x00: "RUN monitored", 0x01: "RUN not monitored"}),
        0x49: ("§10-7", "status", EVENT_STATUS),
    }
    for code, (section, name_of, texts) in one_byte.items():
        name = f"{COMMAND_NAMES[code]} answer ({code:02X})"
        out.append(Kind(f"{code:02X}", name, section, _frame(name, code, 0, _byte(name_of)),
                        code, {name_of: texts} if texts else {},
                        {"inputs": INPUTS} if code == 0x25 else {}))
    return out


def _read_kinds() -> list[Kind]:
    """The answers that read something back (§9-8, §10-1, §10-2, §10-8, §10-9)."""
    first = "table-read answer, first block (41)"
    items = [Kind(f"41 {what}", f"table-read {what} block (41, PAL=0)", "§10-1",
                  _headed(f"table-read {what} block (41, PAL=0)", frame,
                          answer_header(0, pal=0, last=None)), None,
                  labels={"items": label})
             for what, frame, label in (("rates", READ_RATES, "rates"),
                                        ("accel", READ_ACCEL, "accel pulses"),
                                        ("decel", READ_DECEL, "decel pulses"))]
    event_read = "event read answer (47)"
    return [
        Kind("27", "control terminal read answer (27)", "§9-8",
             _frame("control terminal read answer (27)", 0x27, 0, _byte("pins"),
                    _byte("signals")), 0x27, flags={"pins": PINS, "signals": EVENT_PINS}),
        Kind("41", first, "§10-1", _headed(first, TABLE_READ_FIRST, answer_header(0, last=0)),
             CODE_TABLE_READ),
        *items,
        Kind("42", "position read answer (42)", "§10-2",
             # "counter", not "source": the header's source is where the command came from
             _frame("position read answer (42)", 0x42, 0, _byte("counter"),
                    UInt("position", 4)), 0x42,
             {"counter": {0x00: "pulse position", 0x01: "encoder position"}}),
        Kind("47", event_read, "§10-8", Frame(event_read, (
            answer_header(0), UInt("length", 1, lo=4, hi=7), Const("code", b"\x47"),
            _byte("registered"), _byte("next_number"),
            Array("codes", UInt("code", 1), min_items=1, max_items=4))), 0x47,
            labels={"next_number": "next to run", "codes": "registered commands"}),
        Kind("4D", "status read answer (4D)", "§10-9",
             _frame("status read answer (4D)", 0x4D, 0, _byte("operation"), _byte("state"),
                    _byte("buffers")), 0x4D,
             flags={"operation": OPERATION, "state": STATES, "buffers": BUFFERS}),
    ]


def _report_kinds() -> list[Kind]:
    """The reports and errors of §7 and §11 (E0–E9, F0–F9)."""
    f0 = "parameter error (F0)"
    out = [
        Kind("E0", "pulse output stopped (E0)", "§11-1",
             _frame("pulse output stopped (E0)", 0xE0, 1, _byte("cause"),
                    UInt("position", 4)), 0xE0, flags={"cause": STOP_CAUSES}),
        Kind("E9", "general input changed (E9)", "§11-13",
             _frame("general input changed (E9)", 0xE9, 1, _byte("overwritten"),
                    _byte("inputs")), 0xE9,
             {"overwritten": {0x00: "no", 0x01: "yes: a later change overwrote the buffer"}},
             {"inputs": INPUTS}),
        Kind("F0", f0, "§11-6", Frame(f0, (
            answer_header(0), UInt("length", 1, lo=3, hi=MAX_READ_LENGTH),
            *PARAM_ERROR.fields[2:], Array("parameters", UInt("parameter", 1)))),
            RESP_PARAM_ERROR, {"error": PARAM_ERRORS}),
        Kind("F1", "state error (F1)", "§11-7",
             _headed("state error (F1)", STATE_ERROR, answer_header(0)), RESP_STATE_ERROR,
             {"status": STATE_STATUS}, {"state": STATES}),
        Kind("F4", "alarm (F4)", "§11-9", _headed("alarm (F4)", ALARM, answer_header(1)), 0xF4,
             {"status": ALARM_STATUS}),
        Kind("F6", "size error (F6)", "§11-5",
             _headed("size error (F6)", SIZE_ERROR, answer_header(0)), RESP_SIZE_ERROR,
             labels={"length_written": "length byte written"}),
    ]
    bare = {0xE1: ("interlock ended (E1)", "§7-5", 1), 0xE2: ("held move started (E2)",
                                                              "§11-2", 1),
            0xE8: ("registered (E8)", "§11-3", 0), 0xF2: ("limit error (F2)", "§11-8", 0)}
    for code, (name, section, cmr) in bare.items():
        out.append(Kind(f"{code:02X}", name, section, _frame(name, code, cmr), code))
    one_byte: dict[int, tuple[str, str, int, str, Mapping[int, str] | None, int | None]] = {
        0xE3: ("encoder range changed (E3)", "§7-4", 1, "encoder", RANGE, None),
        0xE4: ("in-position range changed (E4)", "§7-3", 1, "in_position", RANGE, None),
        0xF5: ("command error (F5)", "§11-10", 0, "command", None, None),
        0xF7: ("registration failed (F7)", "§11-4", 0, "status", {
            0x00: "the command buffer is full",
            0x01: "the /EVT0 or /EVT1 named is in use by an event buffer"}, None),
        0xF8: ("override aborted (F8)", "§11-11", 0, "status", ABORT_STATUS, 3),
        0xF9: ("event aborted (F9)", "§11-12", 0, "status", ABORT_STATUS, 1),
    }
    for code, (name, section, cmr, name_of, texts, resp) in one_byte.items():
        frame = _frame(name, code, cmr, _byte(name_of), resp=resp)
        out.append(Kind(f"{code:02X}", name, section, frame, code,
                        {name_of: texts} if texts else {},
                        labels={"command": "unknown command code"} if code == 0xF5 else {}))
    return out


def _by_code(kinds: tuple[Kind, ...]) -> dict[int, tuple[Kind, ...]]:
    out: dict[int, tuple[Kind, ...]] = {}
    for kind in kinds:
        if kind.code is not None:
            out[kind.code] = (*out.get(kind.code, ()), kind)
    return out


KINDS: tuple[Kind, ...] = (*_command_kinds(), *_read_kinds(), *_report_kinds())
BY_KEY: dict[str, Kind] = {k.key: k for k in KINDS}
BY_CODE = _by_code(KINDS)
ITEM_BLOCKS: dict[int, Kind] = {1: BY_KEY["41 rates"], 2: BY_KEY["41 accel"],
                                3: BY_KEY["41 decel"]}
