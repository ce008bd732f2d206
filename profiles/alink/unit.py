"""What the A-Link ALUM unit answers to a list of commands: Ack, or Nak and why (§11, §12-1).

A documented model, not the firmware. The list is what the host sends, in order, each
command after the answer to the one before (§10-3), judged **from power on** (§12-1 (2): the
unit forgets its origin at power on, so a list that counts on an origin set before it fails
after a power cycle). The unit answers Nak when (the cause bits of READ_STAT type 7):

- `value`: an nn or a para §11 does not give the command (HOME nn 1–4, OUT 0/1, a soft
  limit of 0, reserved bits, …: "parameter value not valid");
- `busy`: a command it refuses while D5 (driving) or D6 (inhibit: DELAY) is set, sent with no
  status read (READ_STAT or READ) after the command that set it — the file cannot hold the
  host's polling loop, so a status read stands for "waited until D5 and D6 are off"
  (§11-3 注意 2, §11-8 注意 5, §12-1 (1)); STOP, outputs and status reads are taken at any
  time, CHANGE_SPD while D5 is set;
- `origin`: MOVE_A, OFFSET or a coordinate change (SETTING 29) before an origin command
  (HOME, P_ORG, M_ORG, RESET_POS; each assumed to succeed);
- `soft-limit`: after the origin, a MOVE_A or MOVE_R whose target passes a soft limit
  (where the list knows the position);
- `speeds`: at a drive command, high speed > MAX_SPEED or < the self-start speed; at a homing
  command, origin high speed < origin low speed or > MAX_SPEED (§11-2 (6) (9), §11-3);
- `change-speed`: CHANGE_SPD in an S-curve drive, or to a speed at or below the self-start
  speed (§11-7 (1)).

What the unit does without a Nak is noted: `capped` (a CHANGE_SPD above MAX_SPEED, or
above 2× the high speed without it, runs at that cap), `idle` (CHANGE_SPD with no move
running), `stale-limits` (soft limits set before a coordinate change or an origin offset:
the manual asks to set them again), `factory` (factory-inspection features), `clear-el`
(a move after a limit move with no CLEAR_EL: D12 stays set, §11-7 (3)).

Settings commands take effect when taken; the speed rules are judged with the values the
list has set before each drive or homing command (a value the list never sets is whatever
the unit holds: not judged). `UnitRun.end` holds the Naks the settings the list leaves
would bring to the first drive or homing command, when the list has none.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from .codec import PARA_MAX, PARA_MIN, Cmd, Command
from .commands import command_of, factory_use
from .model import MODE_S_CURVE

NAK_KINDS = ("value", "busy", "origin", "soft-limit", "speeds", "change-speed")
NOTE_KINDS = ("capped", "idle", "stale-limits", "factory", "clear-el")
# Taken while D5 (driving) is set; while D6 (inhibit) only STOP, outputs and status reads.
_WHILE_D6 = frozenset({"stop", "output", "status"})
_WHILE_D5 = _WHILE_D6 | {"change-speed"}
_NEEDS_ORIGIN = frozenset({Cmd.MOVE_A, Cmd.OFFSET})
_SETS_ORIGIN = frozenset({Cmd.HOME, Cmd.P_ORG, Cmd.M_ORG, Cmd.RESET_POS})
_REMEMBERED = frozenset({Cmd.L_SPEED, Cmd.H_SPEED, Cmd.MAX_SPEED, Cmd.OL_SPEED, Cmd.OH_SPEED,
                         Cmd.MODE})


@dataclass(frozen=True)
class Issue:
    kind: str      # one of NAK_KINDS or NOTE_KINDS
    message: str


@dataclass(frozen=True)
class Answer:
    """The unit's answer to command `index` of the list: Nak when `naks` is not empty."""

    index: int
    command: Command
    naks: tuple[Issue, ...]
    notes: tuple[Issue, ...]

    @property
    def ack(self) -> bool:
        return not self.naks


@dataclass(frozen=True)
class UnitRun:
    answers: tuple[Answer, ...]
    end: tuple[Issue, ...]


@dataclass
class _State:
    busy: str | None = None           # "D5 (driving)" or "D6 (inhibit)"
    busy_by: str = ""
    moving: bool = False
    origin: bool = False
    position: int | None = None
    plus: int = PARA_MAX              # the soft limits (factory: the counter's ends, §12-3)
    minus: int = PARA_MIN
    limits_set: bool = False
    limits_stale: bool = False
    latched: bool = False             # a limit move ran, no CLEAR_EL since
    values: dict[int, int] = field(default_factory=dict)
    drive_judged: bool = False
    homing_judged: bool = False


def run_commands(commands: Sequence[Command]) -> UnitRun:
    """The unit's answer to every command of `commands`, from power on (module doc)."""
    state = _State()
    answers = []
    for k, c in enumerate(commands):
        naks, notes = _judge(k, c, state)
        if not naks:
            notes += _apply(c, state)
        answers.append(Answer(k, c, tuple(naks), tuple(notes)))
    end = [] if state.drive_judged else _drive_speeds(state, "a drive command")
    end += [] if state.homing_judged else _homing_speeds(state, "a homing command")
    return UnitRun(tuple(answers), tuple(end))


def _judge(k: int, c: Command, state: _State) -> tuple[list[Issue], list[Issue]]:
    entry = command_of(c.cmd)
    form = entry.forms.get(c.func)
    naks: list[Issue] = []
    notes: list[Issue] = []
    where = f"command {k} ({c.name})"
    if form is None:
        naks.append(Issue("value", f"{where}: nn {c.func} is not one §11 gives it ("
                                   + ", ".join(str(n) for n in entry.forms) + ")"))
    else:
        problem = (form.value.problem(c.para) if form.value.takes
                   else None if c.para == 0 else f"para {c.para}: it takes none (0)")
        if problem is not None:
            naks.append(Issue("value", f"{where}: {problem}"))
    factory = factory_use(c.cmd, c.func, c.para)
    if factory is not None:
        notes.append(Issue("factory", f"{where}: {factory}"))
    kind = "change-speed" if c.cmd == Cmd.CHANGE_SPD else entry.kind
    if state.busy is not None and kind not in (_WHILE_D5 if state.busy.startswith("D5")
                                               else _WHILE_D6):
        naks.append(Issue("busy", f"{where}: refused while {state.busy} is set by {state.busy_by}"
                                  ": read the status (READ_STAT) until it is off first"))
    if (c.cmd in _NEEDS_ORIGIN or (c.cmd == Cmd.SETTING and c.func == 29)) and not state.origin:
        naks.append(Issue("origin", f"{where}: the origin is not set (no HOME, P_ORG, M_ORG "
                                    "or RESET_POS before it since power on)"))
    if entry.kind == "drive":
        naks += _drive_speeds(state, where)
        naks += _soft_limit(c, state, where)
        state.drive_judged = True
        if state.latched and not state.busy:
            notes.append(Issue("clear-el", f"{where}: after the limit move, status D12 (limit "
                                           "detected) stays set until CLEAR_EL"))
    elif entry.kind == "homing":
        naks += _homing_speeds(state, where)
        state.homing_judged = True
    elif c.cmd == Cmd.CHANGE_SPD:
        more_naks, more_notes = _change_speed(c, state, where)
        naks += more_naks
        notes += more_notes
    return naks, notes


def _apply(c: Command, state: _State) -> list[Issue]:
    """What a command the unit took changes; the notes that go with it."""
    entry = command_of(c.cmd)
    notes: list[Issue] = []
    if c.cmd in _REMEMBERED:
        state.values[c.cmd] = c.para
    if entry.kind == "status":  # the host's wait: D5 and D6 read off
        state.busy, state.moving = None, False
    elif entry.kind in ("drive", "homing"):
        state.busy, state.busy_by, state.moving = "D5 (driving)", c.name, True
    elif c.cmd == Cmd.DELAY and c.para > 0:
        state.busy, state.busy_by = "D6 (inhibit)", f"DELAY {c.para} ms"
    elif c.cmd == Cmd.STOP:  # the axis stops where it is; D5 until read off
        state.moving, state.position = False, None
    if c.cmd == Cmd.SETTING and c.func == 30:
        if c.para > 0:
            state.plus = c.para
        else:
            state.minus = c.para
        state.limits_set, state.limits_stale = True, False
    elif c.cmd in (Cmd.OFFSET, Cmd.SETTING):
        if state.limits_set and not state.limits_stale:
            notes.append(Issue("stale-limits", f"{c.name}: the soft limits were set before "
                                               "this origin change: set them again (§11-2 "
                                               "(12) 注意 2)"))
            state.limits_stale = True
        state.position = (0 if c.cmd == Cmd.OFFSET else
                          None if state.position is None else state.position - c.para)
    state.position = _moved(c, state.position)
    if c.cmd in _SETS_ORIGIN:
        state.origin, state.position = True, 0
    if c.cmd == Cmd.LIMIT:
        state.latched = True
    elif c.cmd == Cmd.CLEAR_EL or entry.kind == "drive":
        state.latched = False
    return notes


def _moved(c: Command, position: int | None) -> int | None:
    if c.cmd == Cmd.MOVE_A:
        return c.para
    if c.cmd == Cmd.MOVE_R:
        return None if position is None else position + c.para
    if c.cmd in (Cmd.LIMIT, Cmd.P_SEARCH, Cmd.M_SEARCH):
        return None
    return position


def _drive_speeds(state: _State, where: str) -> list[Issue]:
    v = state.values
    high, start, top = v.get(Cmd.H_SPEED), v.get(Cmd.L_SPEED), v.get(Cmd.MAX_SPEED)
    if high is not None and top and high > top:
        why = f"high speed {high} pps > MAX_SPEED {top} pps"
    elif high is not None and start is not None and high < start:
        why = f"high speed {high} pps < self-start speed {start} pps"
    else:
        return []
    return [Issue("speeds", f"the unit answers {where} with Nak: {why}")]


def _homing_speeds(state: _State, where: str) -> list[Issue]:
    v = state.values
    oh, ol, top = v.get(Cmd.OH_SPEED), v.get(Cmd.OL_SPEED), v.get(Cmd.MAX_SPEED)
    if oh is not None and ol is not None and oh < ol:
        why = f"origin high speed {oh} pps < origin low speed {ol} pps"
    elif oh is not None and top and oh > top:
        why = f"origin high speed {oh} pps > MAX_SPEED {top} pps"
    else:
        return []
    return [Issue("speeds", f"the unit answers {where} with Nak: {why}")]


def _soft_limit(c: Command, state: _State, where: str) -> list[Issue]:
    if c.cmd not in (Cmd.MOVE_A, Cmd.MOVE_R) or not state.origin or state.limits_stale:
        return []
    target = _moved(c, state.position)
    if target is None or state.minus <= target <= state.plus:
        return []
    side, limit = ("+", state.plus) if target > state.plus else ("-", state.minus)
    return [Issue("soft-limit", f"{where}: its target {target} passes the {side} soft limit "
                                f"{limit}")]


def _change_speed(c: Command, state: _State, where: str) -> tuple[list[Issue], list[Issue]]:
    v = state.values
    naks: list[Issue] = []
    notes: list[Issue] = []
    if not state.moving:
        notes.append(Issue("idle", f"{where}: no move is running: it changes a running move's "
                                   "speed only"))
    mode = v.get(Cmd.MODE)
    if mode is not None and mode & MODE_S_CURVE:
        naks.append(Issue("change-speed", f"{where}: the unit does not change speed in an "
                                          "S-curve drive (MODE D4 set; §11-7 (1) 注意 3)"))
    high, start, top = v.get(Cmd.H_SPEED), v.get(Cmd.L_SPEED), v.get(Cmd.MAX_SPEED)
    speed = c.para if c.func == 1 else None if high is None else high * c.para / 100
    if speed is None:
        return naks, notes
    if start is not None and speed <= start:
        naks.append(Issue("change-speed", f"{where}: {speed:g} pps is at or below the "
                                          f"self-start speed {start} pps"))
    cap = top if top else None if top is None or high is None else 2 * high
    if cap is not None and speed > cap:
        notes.append(Issue("capped", f"{where}: {speed:g} pps runs at "
                                     + (f"MAX_SPEED {cap} pps" if top else
                                        f"{cap} pps, 2× the high speed (MAX_SPEED 0)")))
    return naks, notes
