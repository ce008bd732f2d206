"""The verdicts of the motion commands that run a table from places no move of 82 reaches
(issue 31 item 4), beside the moves' in the table's safety verdict (`safety.judge_table`).

`FAMILIES` names each family judged and its judge; `judge_safety(commands=…)` narrows
them (`stepramp check --commands 82,81`). Each family is judged as moves are: the
criterion on its speed changes (at the tolerance box's worst case), the load angle over
every execution (every corner of the box, then seeded Monte Carlo samples on the
executions worst at some corner), findings past the 90° peak (errors) and past the aim
(warnings).

- **decel-stop** (81; the /FHL /BHL stop of 05 and 11's decel walk down alike): a decel
  stop at every pulse of the ramp under every reading the manual leaves open
  (profiles/ppmc312/stops.py: (a) at once, same stage; (b) finish the stage; (c) at
  once, one stage down; LOW). The verdict is the worst reading, named.
- **constant**, **origin-search**, **origin-return**, **stop** (80, /FL, /BL),
  **change-speed**, **set-speed**: each a safe use the table leaves and the envelope the
  user needs (profiles/ppmc312/command_families.py).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from profiles.errors import FormatError, echo
from profiles.findings import Finding
from profiles.motor import Motor
from profiles.motor.angles import PEAK_DEG
from profiles.ppmc312.table import FreeCurveTable
from profiles.progress import Progress
from profiles.verdict import CommandVerdict

from .command_families import CODES as ENVELOPE_FAMILIES
from .command_families import family_judge

DECEL_STOP = "decel-stop"
ACCEL = "accel"   # the move (82): always judged, the table's own verdict


@dataclass(frozen=True)
class StopVerdict:
    """The decel stop's verdict over every pulse of the ramp and every reading."""

    aim_deg: float
    worst_deg: float | None          # None: the load angle not judged
    stage: int | None                # the accel stage (fastest-first) of the worst stop
    pulses_into_stage: int | None    # None: reading (b) alone (anywhere in the stage)
    ramp_pulse: int | None           # the pulse of the ramp from rest where it comes
    dwell_pulses: int | None         # pulses at the stage's rate once the stop comes
    # the readings that run it, each with its pulses into the stage (None: (b) anywhere
    # in it): ("a", 1), ("b", None), ("c", 3), ("LOW", 2); the first is the one named
    readings: tuple[tuple[str, int | None], ...]
    direction: int
    worst_at: str                    # "nominal", or the corner or sample of the box
    # the stop past 90° earliest on the ramp: (stage, its first reading, pulses into it)
    first_unstable: tuple[int, str, int | None] | None
    slips: bool
    executions: int
    sample_failures: int
    criterion: tuple[Finding, ...]

    @property
    def stable(self) -> bool:
        return self.worst_deg is None or (self.worst_deg < PEAK_DEG and not self.sample_failures)

    @property
    def safe(self) -> bool:
        return self.stable and not any(f.severity == "error" for f in self.criterion)

    @property
    def within_aim(self) -> bool:
        return self.worst_deg is not None and self.worst_deg <= self.aim_deg

    def where(self) -> str:
        """'37 pulses into stage 12 (pulse 1234 of the ramp; reading (a): …)', and the
        other readings that run the same stop."""
        from profiles.ppmc312.stops import describe_readings

        into = ("anywhere in" if self.pulses_into_stage is None
                else f"{_pulses(self.pulses_into_stage)} into")
        ramp = "" if self.ramp_pulse is None else f"pulse {self.ramp_pulse} of the ramp; "
        also = [f"reading ({r}) " + ("anywhere in it" if p is None else f"{_pulses(p)} into it")
                for r, p in self.readings[1:]]
        return (f"{into} stage {self.stage} ({ramp}{describe_readings(self.readings[:1])}"
                + ("; the same stop as " + " and ".join(also) if also else "") + ")")

    def describe(self) -> str:
        if self.worst_deg is None:
            return "decel stops (81): the load angle not judged"
        if self.stage is None:
            return "decel stops (81): none, the moves judged run no ramp"
        way = "forward" if self.direction > 0 else "backward"
        box = "" if self.worst_at == "nominal" else f" at {self.worst_at}"
        text = (f"a decel stop (81) {self.where()} drives the rotor to {self.worst_deg:.1f}° "
                f"electrical ({way}{box}), the worst decel stop judged (every pulse of the "
                f"ramp, every reading); margin {self.aim_deg - self.worst_deg:+.1f}° to the "
                f"{self.aim_deg:g}° aim, {PEAK_DEG - self.worst_deg:+.1f}° to the 90° peak")
        if self.first_unstable is not None:
            stage, reading, into = self.first_unstable
            at = "anywhere in it" if into is None else f"{_pulses(into)} into it"
            text += (f"; the rotor leaves the stable side from a stop in stage {stage} "
                     f"(reading ({reading}), {at})" + (" and slips a pole" if self.slips
                                                       else ""))
        if self.sample_failures:
            text += f"; {self.sample_failures} Monte Carlo samples past the peak"
        return text

    def findings(self) -> list[Finding]:
        out = list(self.criterion)
        if self.worst_deg is None:
            return out
        if not self.stable:
            out.append(Finding("error", "decel-stop-load-angle", self.describe() + (
                ": past the 90° peak, the rotor leaves the stable side (lengthen the stages "
                "before that one, or plan the table again: `stepramp plan` tightens where a "
                "stop rings)")))
        elif not self.within_aim:
            out.append(Finding("warning", "decel-stop-load-angle-margin", self.describe()
                               + f" (stepramp plan aims at ≤ {self.aim_deg:g}°)"))
        return out

    def to_json(self) -> dict[str, Any]:
        w = self.worst_deg
        judged = w is not None
        return {
            "command": "decel-stop", "code": "81", "safe": self.safe,
            "within_aim": self.within_aim,
            "worst_load_angle_deg": w,
            "margin_to_aim_deg": None if w is None else self.aim_deg - w,
            "margin_deg": None if w is None else PEAK_DEG - w,
            "reading": self.readings[0][0] if self.readings else None,
            "readings": [{"reading": r, "pulses_into_stage": p} for r, p in self.readings],
            "stage": self.stage,
            "pulses_into_stage": self.pulses_into_stage, "ramp_pulse": self.ramp_pulse,
            "dwell_pulses": self.dwell_pulses,
            "worst_direction": None if not judged else (
                "forward" if self.direction > 0 else "backward"),
            "worst_at": self.worst_at if judged else None,
            "first_unstable": None if self.first_unstable is None else dict(zip(
                ("stage", "reading", "pulses_into_stage"), self.first_unstable, strict=True)),
            "slips": self.slips, "executions": self.executions,
            "sample_failures": self.sample_failures,
            "criterion_findings": [f.to_json() for f in self.criterion],
        }


def _pulses(n: int) -> str:
    return f"{n} pulse" + ("" if n == 1 else "s")


def judge_decel_stops(table: FreeCurveTable, motor: Motor, *, aim_deg: float,
                      load_angle: bool, samples: int, seed: int,
                      moves: tuple[int, ...] | None = None,
                      progress: Progress | None = None) -> StopVerdict:
    """The decel stop's verdict: the criterion on every stop's speed changes (those the
    moves' verdict names already, over `moves`, None: every length, left to it), and the
    load angle over every stop on the motor, or every corner of its box and `samples`
    Monte Carlo samples of it."""
    from profiles.motor.tolerance import worst_case_motor
    from profiles.ppmc312.criterion import length_problems
    from profiles.ppmc312.stops import ramp_reach, stop_problems

    judged = worst_case_motor(motor) if motor.tolerances else motor
    # the stops of the ramp the moves judged run (every move: all of it)
    limit = None if moves is None else ramp_reach(table, moves)
    groups: dict[tuple[str, float, float], list[int]] = {}
    # every step of a stop is one its trapezoid takes (profiles.ppmc312.stops.stop_problems;
    # tests/profiles/ppmc312/test_stops.py holds it on random tables): with every length judged, the
    # moves' findings say them all, and the stops' criterion has nothing to add
    if moves is not None:
        known = {(p.rule, p.v_from_pps, p.v_to_pps) for p in length_problems(table, judged,
                                                                              moves)}
        for stage, p in stop_problems(table, judged, limit):
            key = (p.rule, p.v_from_pps, p.v_to_pps)
            if key not in known:  # the same step in many stops is one finding
                groups.setdefault(key, []).append(stage)
    criterion = tuple(_criterion_finding(stages, key) for key, stages in groups.items())
    if not load_angle:
        return StopVerdict(aim_deg, None, None, None, None, None, (), 1, "nominal", None,
                           False, 0, 0, criterion)
    return _stop_angles(table, motor, aim_deg, samples, seed, limit, criterion)


def _criterion_finding(stages: list[int], key: tuple[str, float, float]) -> Finding:
    """One step the stops in `stages` take and the moves judged do not."""
    rule, v_from, v_to = key
    what = {"start-speed": "ends at", "top-speed": "runs"}.get(rule, "steps from")
    speeds = (f"{v_from:.6g} pps" if rule in ("start-speed", "top-speed")
              else f"{v_from:.6g} to {v_to:.6g} pps")
    where = (f"stage {stages[0]}" if len(stages) == 1
             else f"stages {min(stages)}–{max(stages)}")
    return Finding("error", "decel-stop-criterion",
                   f"a decel stop (81) in {where} {what} {speeds}, which breaks the criterion "
                   f"({rule}) and no move judged runs (judge every move length to see the "
                   "finding with its fix)", stage=max(stages))


def _stop_angles(table: FreeCurveTable, motor: Motor, aim_deg: float, samples: int, seed: int,
                 limit: int | None, criterion: tuple[Finding, ...]) -> StopVerdict:
    from profiles.motor.tolerance import corners
    from profiles.ppmc312.stops import ramp_pulse, readings_of, stop_angles

    box = corners(motor) if motor.tolerances else []
    found = stop_angles(table, [c.motor for c in box] if box else [motor], ramp_limit=limit)
    per = [found.worst(m) for m in range(max(len(box), 1))]
    if per[0] is None:
        return StopVerdict(aim_deg, 0.0, None, None, None, None, (), 1, "nominal", None,
                           False, 0, 0, criterion)
    k = int(np.argmax([w.worst_angle_deg for w in per if w is not None]))
    w = per[k]
    assert w is not None
    stage, dwell, deg, way = w.stage, w.dwell, w.worst_angle_deg, w.direction
    at = box[k].describe() if box else "nominal"
    failures = sampled = 0
    if box and samples:
        from .tolerance_box import stop_sample_peaks

        pairs = sorted({(x.stage, x.dwell) for x in per if x is not None})
        sampled = samples * len(pairs)
        peaks, where, ways = stop_sample_peaks(table, motor, pairs, samples, seed)
        failures = int(np.sum(peaks >= PEAK_DEG))
        i = int(np.argmax(peaks))
        if peaks[i] > deg:
            (stage, dwell), deg, way, at = pairs[int(where[i])], float(peaks[i]), int(ways[i]), \
                f"sample {i}"
    readings = readings_of(table, stage, dwell)
    p = next((q for _, q in readings if q is not None), None)
    unstable = [x.first_unstable for x in per if x is not None and x.first_unstable]
    first = None
    if unstable:  # the earliest on the ramp: the slowest stage, the shortest dwell there
        at_stage, at_dwell = min(unstable, key=lambda sd: (-sd[0], sd[1]))
        reading, into = readings_of(table, at_stage, at_dwell)[0]
        first = (at_stage, reading, into)
    judged = [x for x in per if x is not None]
    return StopVerdict(aim_deg, deg, stage, p, None if p is None else ramp_pulse(table, stage, p),
                       dwell, tuple(readings), way, at, first, any(x.slipped for x in judged),
                       sum(x.executions for x in judged) + sampled, failures, criterion)


# --- which commands a verdict judges --------------------------------------------------

Judge = Callable[..., CommandVerdict]
FAMILIES: dict[str, Judge] = {DECEL_STOP: judge_decel_stops,
                              **{name: family_judge(name) for name in ENVELOPE_FAMILIES}}


def command_names(items: Iterable[str] | None) -> tuple[str, ...]:
    """The command names of `items` (names of `motion.COMMANDS` or their codes in hex,
    "82", "0x81"), in registry order; None: every command. Unknown ones are refused,
    naming them."""
    from profiles.ppmc312.motion import BY_CODE, COMMANDS

    if items is None:
        return tuple(COMMANDS)
    names = set()
    for item in items:
        text = str(item).strip().lower()
        if text in COMMANDS:
            names.add(text)
            continue
        try:
            code = int(text, 16)
        except ValueError:
            code = -1
        if code not in BY_CODE:
            known = ", ".join(f"{c.code:02X} {n}" for n, c in COMMANDS.items())
            raise FormatError(f"commands: {echo(item)} is neither a motion command's name nor "
                              f"its code ({known})")
        names.add(BY_CODE[code].name)
    return tuple(n for n in COMMANDS if n in names)


def judged_families(commands: Iterable[str] | None) -> tuple[str, ...]:
    """The command families with a verdict of their own among `commands` (None: all)."""
    names = command_names(commands)
    return tuple(f for f in FAMILIES if f in names)
