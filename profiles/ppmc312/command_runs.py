"""What the PPMC-312 runs for every motion command and for the inputs that stop it: a
documented model (issue 31), as the accel/decel move's is in `execution`.

A *motion* is what the chip outputs from rest to rest: pieces of (phase, rate, pulses),
each run on behalf of one command of a program (`ProgramCommand`), some of them backward
(the way back of a high-speed origin return). A command issued during a motion takes
effect when `at` pulses of it have been output. Per command (manual section; the
readings where the manual is silent are in docs/manual-notes.md, "Every command that
runs the table"):

- accel (82, §8-3): `execution.simulate_move`; its decel point is where its decel starts;
- constant (83, §8-4): a jump from rest to the rate (0: the table's high rate), its
  pulses, an immediate stop; step (84, §8-5): one pulse at the start rate;
- continuous (85, §8-6): up the accel stages whose rate is at or above the rate (slow
  end first, each whole), then at the rate until something stops it;
- continuous-constant (86, §8-7): a jump from rest to the rate, until something stops it;
- change-speed (87, §8-8): up the accel stages between the current rate and the new one
  (an accel stage under way runs to its end first), or at once down the decel stages
  between them, then at the new rate; set-speed (88, §8-9): a jump to the new rate;
- origin-search (10, §8-10): a constant run at the rate, stopped at once on /ORG (`at`);
- origin-return (11, §8-11): as 85; at /ORG (`at`) a decel stop, then at once back at
  the start rate for as many pulses as the decel ran (back to /ORG), stopped at once;
- stop (80, §8-1) and /FL, /BL (§7-6): an immediate stop;
- decel-stop (81, §8-2), and /FHL, /BHL at or above the speed 05 sets (§7-6; below it
  they are ignored): from an accel stage, each reading of `stops.stop_runs`; from a
  cruise, down the decel stages whose rate is at or above the current one; nothing
  slower to walk down: stopped at once (E0's LOW); ignored while decelerating (§8-2);
- high-speed-limit (05, §7-6): at rest only; the table's high rate until it is given;
- after a speed change (87, 88) a move with a pulse count keeps its decel point (§8-8):
  there an accel/decel move walks down the decel stages from its speed, each whole,
  until its pulses run out, stopping from the speed it has reached when they run out
  first (「停止パルスレートより速いスピードで停止」) and running at the stop rate when they
  outlast the stages; a constant move stops at once after its pulses.

Each motion ends with E0's cause (§11-1): NOS (its pulses done), STP (80), DEC (81),
ORG (10, 11), LOW (a decel stop with nothing slower), DEL (/FHL, /BHL), STL (/FL, /BL).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from ..errors import FieldRangeError, FormatError, MotionRefused
from ..motor.batch import Phase
from .clock import Clock
from .execution import (
    PULSE_TIMES_CSV_MAX,
    Execution,
    Segment,
    pulse_times_csv_chunks,
    simulate_move,
)
from .init_model import as_free_curve
from .table import FreeCurveTable, InitTable

FOREVER = -1   # the pulses of a cruise that runs until something stops it
READINGS = ("a", "b", "c")   # a decel stop from mid-ramp (stops.stop_runs)
# The inputs a program may name besides commands (§7-6): (runs CCW, decelerates)
SIGNALS: dict[str, tuple[bool, bool]] = {"FL": (False, False), "BL": (True, False),
                                         "FHL": (False, True), "BHL": (True, True)}
STARTS = frozenset({"accel", "constant", "step", "continuous", "continuous-constant",
                    "origin-search", "origin-return"})
DURING = frozenset({"stop", "decel-stop", "change-speed", "set-speed", *SIGNALS})
AT_REST = frozenset({"high-speed-limit"})
FINDS_ORIGIN = frozenset({"origin-search", "origin-return"})   # their `at` is /ORG
CAUSES = {"NOS": "its pulses done", "STP": "stopped at once (80)",
          "DEC": "decelerated to a stop (81)", "ORG": "stopped on /ORG",
          "LOW": "stopped at once: nothing slower to decelerate along",
          "DEL": "decelerated to a stop by a high-speed limit",
          "STL": "stopped at once by a limit"}


@dataclass(frozen=True)
class ProgramCommand:
    """One entry of a program: a command of `motion.COMMANDS` or a signal (`SIGNALS`),
    with its parameters; `at`: the pulses of the running motion output when it takes
    effect (for 10 and 11, where /ORG is found)."""

    name: str
    rate: int = 0
    pulses: int = 0
    ccw: bool = False
    at: int | None = None

    @property
    def signal(self) -> bool:
        return self.name in SIGNALS

    @property
    def title(self) -> str:
        """"stop (80)", "/FL": the command (its code) or the input."""
        from .motion import COMMANDS

        return f"/{self.name}" if self.signal else f"{self.name} ({COMMANDS[self.name].code:02X})"

    def label(self, i: int) -> str:
        return f"commands[{i}] {self.title}"


@dataclass(frozen=True)
class Piece:
    """`pulses` at `rate` run on behalf of command `command`; `stage`: the table's stage
    (fastest-first index) an accel piece climbs; `backward`: against the motion's own
    direction."""

    phase: Phase
    rate: int
    pulses: int
    command: int
    stage: int | None = None
    backward: bool = False


@dataclass(frozen=True)
class Motion:
    """What the chip outputs from rest to rest (see the module docstring)."""

    pieces: tuple[Piece, ...]
    ccw: bool
    started_by: int
    ended_by: int
    cause: str                       # E0's cause bit name (CAUSES)
    clock: Clock
    stop_rate: int                   # the table's stop rate
    changed_at: tuple[int, int] | None = None  # (command, pulse) of a speed change (§8-8)

    @property
    def pulses(self) -> int:
        return sum(p.pulses for p in self.pieces)

    @property
    def final_rate(self) -> int:
        return self.pieces[-1].rate

    def runs(self) -> list[tuple[Phase, int, int]]:
        """The pieces as (phase, rate, pulses), as `move_batch.MoveBatch.runs` gives a move."""
        return [(p.phase, p.rate, p.pulses) for p in self.pieces]

    def legs(self) -> list[list[Piece]]:
        """The pieces split where the direction reverses (each leg starts from rest)."""
        out: list[list[Piece]] = []
        for p in self.pieces:
            if not out or out[-1][-1].backward != p.backward:
                out.append([])
            out[-1].append(p)
        return out

    def execution(self) -> Execution:
        """The motion as an `Execution` (its timeline, pulse times and samples; the
        direction is `ccw` and each piece's `backward`)."""
        segments, tick = [], 0
        for p in self.pieces:
            segments.append(Segment(p.phase, p.rate, p.pulses, tick))
            tick += p.rate * p.pulses
        return Execution(shape=self.cause, status=0, segments=segments, pulses=self.pulses,
                         clock=self.clock, high_rate=min(p.rate for p in self.pieces),
                         high_rate_given=False)

    def to_json(self, names: Sequence[str]) -> dict[str, Any]:
        hz, tick, pieces = self.clock.hz, 0, []
        for p in self.pieces:
            pieces.append({"phase": p.phase, "rate": p.rate, "speed_pps": hz / p.rate,
                           "pulses": p.pulses, "ccw": self.ccw != p.backward,
                           "command": p.command, "command_name": names[p.command],
                           "start_s": tick / hz, "end_s": (tick + p.rate * p.pulses) / hz})
            tick += p.rate * p.pulses
        return {"started_by": self.started_by, "ended_by": self.ended_by,
                "cause": self.cause, "cause_text": CAUSES[self.cause], "pulses": self.pulses,
                "duration_s": tick / hz, "stops_from_pps": hz / self.final_rate,
                "speed_change": None if self.changed_at is None else
                {"command": self.changed_at[0], "at": self.changed_at[1]}, "pieces": pieces}


@dataclass(frozen=True)
class ProgramRun:
    """A program as the chip runs it, one reading of the decel stops from mid-ramp."""

    motions: tuple[Motion, ...]
    reading: str
    notes: tuple[str, ...]

    def to_csv(self, names: Sequence[str]) -> str:
        """One line per piece: the motion (from 1), what `execution.to_csv` gives a move's
        segment, its direction and the command that runs it."""
        out = ["motion,phase,rate,speed_pps,pulses,ccw,command,start_tick,end_tick,start_s,"
               "end_s\n"]
        for k, m in enumerate(self.motions, 1):
            hz, tick = m.clock.hz, 0
            for p in m.pieces:
                end = tick + p.rate * p.pulses
                out.append(f"{k},{p.phase},{p.rate},{hz / p.rate!r},{p.pulses},"
                           f"{int(m.ccw != p.backward)},{names[p.command]},{tick},{end},"
                           f"{tick / hz!r},{end / hz!r}\n")
                tick = end
        return "".join(out)

    def pulse_times_chunks(self) -> Iterator[str]:
        """Every pulse's time as CSV `motion,pulse,time_s` (pulses numbered from 1 and
        time from the start of each motion's first pulse period), streamed; at most
        `execution.PULSE_TIMES_CSV_MAX` pulses in all, checked before the first piece."""
        total = sum(m.pulses for m in self.motions)
        if total > PULSE_TIMES_CSV_MAX:
            raise FieldRangeError("pulses (one CSV row per pulse)", total, 1,
                                  PULSE_TIMES_CSV_MAX)
        yield "motion,pulse,time_s\n"
        for k, m in enumerate(self.motions, 1):
            chunks = pulse_times_csv_chunks(m.execution())
            next(chunks)  # its own header
            for chunk in chunks:
                yield "".join(f"{k},{line}\n" for line in chunk.splitlines())


class Stairs:
    """A table's two sides as the commands other than 82 walk them (fastest first)."""

    def __init__(self, table: FreeCurveTable | InitTable) -> None:
        free = as_free_curve(table)
        self.table = free
        rates = free.rates
        self.acc = [(i, rates[i], n) for i, n in enumerate(free.accel_pulses) if n > 0]
        self.dec = [(i, rates[i], n) for i, n in enumerate(free.decel) if n > 0]
        self.top = rates[0]
        self.start_rate = rates[len(free.accel_pulses) - 1]
        self.stop_rate = rates[len(free.decel) - 1]
        self.lo, self.hi = min(rates), max(rates)

    def rate(self, rate: int) -> int:
        """A command's rate: 0 is the table's high rate."""
        return rate or self.top

    def up(self, frm: int | None, to: int, command: int) -> list[Piece]:
        """The accel stages from the slow end whose rate lies in [to, frm) (from rest,
        `frm` None: every one at or above `to`)."""
        return [Piece("accel", r, n, command, stage=i) for i, r, n in reversed(self.acc)
                if r >= to and (frm is None or r < frm)]

    def down(self, frm: int, to: int, command: int, backward: bool = False) -> list[Piece]:
        """The decel stages, fastest first, whose rate lies in (frm, to]."""
        return [Piece("decel", r, n, command, backward=backward) for _, r, n in self.dec
                if frm < r <= to]

    def decel_from(self, rate: int, command: int, backward: bool = False) -> list[Piece]:
        """A decel stop from a cruise at `rate`: the decel stages at or below its speed."""
        return [Piece("decel", r, n, command, backward=backward) for _, r, n in self.dec
                if r >= rate]

    def walk_down(self, rate: int, pulses: int, command: int) -> list[Piece]:
        """A move's decel after a speed change (§8-8): `decel_from(rate)`, each stage
        whole, until `pulses` run out; pulses left over run at the stop rate."""
        out: list[Piece] = []
        for p in self.decel_from(rate, command):
            if pulses <= 0:
                break
            out.append(dataclasses.replace(p, pulses=min(p.pulses, pulses)))
            pulses -= out[-1].pulses
        if pulses > 0:
            out.append(Piece("cruise", self.stop_rate, pulses, command))
        return out

    def stop_from_stage(self, stage: int, into: int, reading: str, command: int,
                        backward: bool) -> list[Piece]:
        """A decel stop `into` pulses into accel stage `stage` (fastest-first index) by
        `reading`: what `stops.stop_runs` runs after those pulses (empty: LOW)."""
        from .stops import stop_runs

        return [Piece("decel", rate, n, command, backward=backward)
                for phase, rate, n in stop_runs(self.table, stage, into, reading)
                if phase == "decel" and n > 0]


def run_program(table: FreeCurveTable | InitTable, commands: Sequence[ProgramCommand], *,
                reading: str = "a") -> ProgramRun:
    """What the chip runs for `commands` with `table` loaded, reading decel stops from
    mid-ramp by `reading` (READINGS). A command the chip would not take where it stands
    (a start while a motion runs, an `at` past the motion's end, …) is a FormatError
    naming it."""
    if reading not in READINGS:
        raise FormatError(f"reading: {reading!r} is not one of {', '.join(READINGS)}")
    run = _Run(Stairs(table), reading)
    for i, c in enumerate(commands):
        try:
            run.take(i, c)
        except _Refused as e:
            raise FormatError(f"commands[{i}]{e.key}: {c.title}: {e}") from None
    run.close()
    return ProgramRun(tuple(run.motions), reading, tuple(run.notes))


class _Refused(Exception):
    def __init__(self, message: str, key: str = "") -> None:
        super().__init__(message)
        self.key = f".{key}" if key else ""


class _Motion:
    """A motion under way: the pieces output so far and the plan of the rest."""

    def __init__(self, command: int, ccw: bool, plan: list[Piece], total: int | None = None,
                 decel_at: int | None = None) -> None:
        self.command, self.ccw = command, ccw
        self.done: list[Piece] = []
        self.plan = plan
        self.pos = 0
        self.total = total          # a move with a pulse count (82, 83, 84)
        self.decel_at = decel_at    # where an accel/decel move decelerates (§8-8)
        self.cause, self.ended_by = "NOS", command
        self.stopping: int | None = None   # the command that stops it
        self.changed: tuple[int, int] | None = None

    def end(self) -> int | None:
        """The pulses the motion outputs if nothing else comes (None: until stopped)."""
        if any(p.pulses == FOREVER for p in self.plan):
            return None
        return self.pos + sum(p.pulses for p in self.plan)

    def advance(self, at: int) -> None:
        """Output the plan up to `at` pulses (the caller has checked it reaches them)."""
        while self.pos < at:
            p = self.plan.pop(0)
            take = at - self.pos if p.pulses == FOREVER else min(p.pulses, at - self.pos)
            if p.pulses == FOREVER or take < p.pulses:
                rest = FOREVER if p.pulses == FOREVER else p.pulses - take
                self.plan.insert(0, dataclasses.replace(p, pulses=rest))
            last = self.done[-1] if self.done else None
            if last is not None and dataclasses.replace(last, pulses=take) == \
                    dataclasses.replace(p, pulses=take):
                self.done[-1] = dataclasses.replace(last, pulses=last.pulses + take)
            else:
                self.done.append(dataclasses.replace(p, pulses=take))
            self.pos += take

    def finish(self, clock: Clock, stop_rate: int) -> Motion:
        pieces: list[Piece] = []
        for p in self.done + self.plan:   # a piece cut where a command came is one again
            if p.pulses <= 0:
                continue
            if pieces and dataclasses.replace(pieces[-1], pulses=0) == \
                    dataclasses.replace(p, pulses=0):
                pieces[-1] = dataclasses.replace(p, pulses=pieces[-1].pulses + p.pulses)
            else:
                pieces.append(p)
        return Motion(tuple(pieces), self.ccw, self.command, self.ended_by, self.cause, clock,
                      stop_rate, self.changed)


class _Run:
    """The program interpreter: the chip at rest or running one motion."""

    def __init__(self, stairs: Stairs, reading: str) -> None:
        self.stairs, self.reading = stairs, reading
        self.limit_rate = stairs.top   # 05 after a table command (§7-6)
        self.motions: list[Motion] = []
        self.notes: list[str] = []
        self.now: _Motion | None = None

    def take(self, i: int, c: ProgramCommand) -> None:
        if c.name in DURING:
            self.during(i, c)
            return
        self.settle(i)
        if c.name in AT_REST:
            self.limit_rate = c.rate
            return
        self.now = self.start(i, c)
        if c.name in FINDS_ORIGIN:
            assert c.at is not None
            self.origin(i, c.at, c.name == "origin-return")

    def settle(self, i: int) -> None:
        """The motion before command i has run to its end (the chip takes a start or a
        setting only at rest: F1 otherwise, §8)."""
        m = self.now
        if m is None:
            return
        if m.end() is None:
            raise _Refused(f"the motion started by commands[{m.command}] is still running "
                           "(a continuous run): stop it first (stop, decel-stop or a limit)")
        self.motions.append(m.finish(self.stairs.table.clock, self.stairs.stop_rate))
        self.now = None

    def close(self) -> None:
        m = self.now
        if m is not None and m.end() is None:
            raise FormatError(f"commands: the program ends while the motion started by "
                              f"commands[{m.command}] still runs (a continuous run): stop it "
                              "(stop, decel-stop or a limit)")
        self.settle(-1)

    def start(self, i: int, c: ProgramCommand) -> _Motion:
        s = self.stairs
        if c.name == "accel":
            return self.accel(i, c)
        if c.name == "step":
            return _Motion(i, c.ccw, [Piece("cruise", s.start_rate, 1, i)], total=1)
        rate = s.rate(c.rate)
        if c.name == "constant":
            return _Motion(i, c.ccw, [Piece("cruise", rate, c.pulses, i)], total=c.pulses)
        ramp = s.up(None, rate, i) if c.name in ("continuous", "origin-return") else []
        return _Motion(i, c.ccw, [*ramp, Piece("cruise", rate, FOREVER, i)])

    def accel(self, i: int, c: ProgramCommand) -> _Motion:
        """82: the execution's segments, each accel one with the stage it climbs."""
        e = simulate_move(self.stairs.table, c.pulses, high_rate=c.rate)
        slow_first = list(reversed(self.stairs.acc))
        plan: list[Piece] = []
        k, decel_at = 0, None
        for seg in e.segments:
            stage = None
            if seg.phase == "accel":
                while k < len(slow_first) - 1 and slow_first[k][1] != seg.rate:
                    k += 1
                stage = slow_first[k][0]
                k += 1
            elif seg.phase == "decel" and decel_at is None:
                decel_at = sum(p.pulses for p in plan)
            plan.append(Piece(seg.phase, seg.rate, seg.pulses, i, stage=stage))
        return _Motion(i, c.ccw, plan, total=c.pulses,
                       decel_at=c.pulses if decel_at is None else decel_at)

    def origin(self, i: int, at: int, back: bool) -> None:
        """/ORG found after `at` pulses: 10 stops at once; 11 decelerates, then runs back
        to it at the start rate and stops at once (§8-10, §8-11)."""
        m = self.now
        assert m is not None
        m.advance(at)
        if not back:
            m.plan, m.cause, m.ended_by, m.stopping = [], "ORG", i, i
            return
        self.decel_stop(i, "ORG")
        ran = sum(p.pulses for p in m.plan)
        if ran:
            m.plan.append(Piece("cruise", self.stairs.start_rate, ran, i, backward=True))
        m.cause = "ORG"

    def during(self, i: int, c: ProgramCommand) -> None:
        m = self.now
        if m is None:
            raise _Refused("no motion is running: it is issued during one (\"at\" pulses "
                           "into it)")
        assert c.at is not None
        if c.at < m.pos:
            raise _Refused(f"{c.at} comes before the command before it ({m.pos} pulses)",
                           "at")
        if m.stopping is not None:
            raise _Refused(f"the motion is already stopping (commands[{m.stopping}]; it ends "
                           f"after pulse {m.end()})", "at")
        end = m.end()
        if end is not None and c.at >= end:
            raise _Refused(f"{c.at} is past the motion's end: it runs {end} pulses", "at")
        m.advance(c.at)
        if c.signal:
            self.signal(i, c)
        elif c.name == "stop":
            m.plan, m.cause, m.ended_by, m.stopping = [], "STP", i, i
        elif c.name == "decel-stop":
            self.decel_stop(i, "DEC")
        else:
            self.change(i, c)

    def signal(self, i: int, c: ProgramCommand) -> None:
        m = self.now
        assert m is not None
        last = m.done[-1]
        ccw, decelerates = SIGNALS[c.name]
        if ccw != (m.ccw != last.backward):
            way = "CCW" if not ccw else "CW"
            raise _Refused(f"the motor runs {way} there: the chip watches only the limit of "
                           "the way it runs (§7-6)", "signal")
        if not decelerates:
            m.plan, m.cause, m.ended_by, m.stopping = [], "STL", i, i
        elif last.rate <= self.limit_rate:
            self.decel_stop(i, "DEL")
        else:
            self.notes.append(f"{c.label(i)} at pulse {c.at}: ignored, slower than the "
                              f"high-speed limit's rate {self.limit_rate} (§7-6)")

    def decel_stop(self, i: int, cause: str) -> None:
        """81, a high-speed limit, or 11 at /ORG: from the current piece (module docstring)."""
        m = self.now
        assert m is not None
        last = m.done[-1]
        if last.phase == "decel" and cause != "ORG":
            self.notes.append(f"commands[{i}]: ignored, the motion is already decelerating "
                              "(§8-2)")
            return
        s = self.stairs
        if last.phase == "accel" and last.stage is not None:
            plan = s.stop_from_stage(last.stage, last.pulses, self.reading, i, last.backward)
        else:
            plan = s.decel_from(last.rate, i, last.backward)
        m.plan, m.ended_by, m.stopping = plan, i, i
        m.cause = cause if plan else "LOW"

    def change(self, i: int, c: ProgramCommand) -> None:
        """87 along the stages, 88 at once, to the new rate; the decel point stays (§8-8)."""
        m = self.now
        assert m is not None and c.at is not None
        last, s = m.done[-1], self.stairs
        if last.phase == "decel":
            raise _Refused("the motion is decelerating there: the manual does not say what a "
                           "speed change does then", "at")
        head: list[Piece] = []
        walk: list[Piece] = []
        if c.name == "change-speed" and c.rate < last.rate:
            if last.phase == "accel" and m.plan and m.plan[0].stage == last.stage:
                head = [m.plan[0]]   # the chip climbs stage by stage: this one ends first
            walk = s.up(last.rate, c.rate, i)
        elif c.name == "change-speed" and c.rate > last.rate:
            walk = s.down(last.rate, c.rate, i, last.backward)
        future = [*head, *walk, Piece("cruise", c.rate, FOREVER, i, backward=last.backward)]
        m.plan = self.keep_decel_point(m, future)
        m.changed = (i, c.at)

    def keep_decel_point(self, m: _Motion, future: list[Piece]) -> list[Piece]:
        """`future` cut where the motion's own pulses end it (§8-8): a constant move stops
        at once; an accel/decel move walks down from its decel point."""
        if m.total is None:
            return future
        until = (m.total if m.decel_at is None else m.decel_at) - m.pos
        out: list[Piece] = []
        for p in future:
            take = until if p.pulses == FOREVER else min(p.pulses, until)
            if take > 0:
                out.append(dataclasses.replace(p, pulses=take))
            until -= take
            if until <= 0:
                break
        if m.decel_at is not None:
            rate = out[-1].rate if out else m.done[-1].rate
            out += self.stairs.walk_down(rate, m.total - m.decel_at, m.command)
        return out


class LiveMotion:
    """One motion as a chip runs it while commands come (the serial emulator,
    `serial_chip.SerialChip`): `start` starts it; `issue` takes a command during it, `at`
    the pulses output by then; `origin` is /ORG found. The same model as `run_program`;
    a command it would refuse raises `MotionRefused`; a limit input (`SIGNALS`) is issued
    as a command. `pieces` ends with a cruise of FOREVER pulses while the motion runs until
    something stops it. `limit_rate`: 05's rate (None: the table's high rate, §7-6)."""

    def __init__(self, table: FreeCurveTable | InitTable, start: ProgramCommand, *,
                 reading: str = "a", limit_rate: int | None = None) -> None:
        if start.name not in STARTS:
            raise FormatError(f"{start.title} does not start a motion")
        self._run = _Run(Stairs(table), reading)
        if limit_rate is not None:
            self._run.limit_rate = limit_rate
        # Started without its /ORG: the caller says when the search finds it (`origin`).
        self._run.now = self._run.start(0, dataclasses.replace(start, at=None))
        self._count = 1
        self.start = start

    @property
    def _motion(self) -> _Motion:
        m = self._run.now
        assert m is not None
        return m

    @property
    def pieces(self) -> tuple[Piece, ...]:
        m = self._motion
        return tuple(p for p in (*m.done, *m.plan) if p.pulses != 0)

    @property
    def stopping(self) -> bool:
        """A stop (80, 81, /ORG) is under way: nothing but its end comes next."""
        return self._motion.stopping is not None

    @property
    def cause(self) -> str:
        """E0's cause (CAUSES) the motion ends with, as things stand."""
        return self._motion.cause

    def issue(self, c: ProgramCommand) -> list[str]:
        """Command `c` (stop, decel-stop, change-speed, set-speed) at `c.at` pulses; the
        notes it leaves (a decel stop ignored while decelerating, §8-2)."""
        seen = len(self._run.notes)
        try:
            self._run.during(self._count, c)
        except _Refused as e:
            raise MotionRefused(str(e)) from None
        self._count += 1
        return self._run.notes[seen:]

    def halt(self, at: int, cause: str = "STP") -> None:
        """An immediate stop (80; /FL, /BL: `cause` STL) at `at` pulses, even while a stop
        is under way: the chip stops pulse output there (§8-1 「即停止します」, §7-6
        「パルスを即停止します」)."""
        m = self._motion
        m.advance(at)
        m.plan, m.cause, m.ended_by, m.stopping = [], cause, self._count, self._count
        self._count += 1

    def origin(self, at: int) -> None:
        """/ORG found after `at` pulses (§8-10: stop at once; §8-11: decel, then back)."""
        self._run.origin(0, at, self.start.name == "origin-return")
