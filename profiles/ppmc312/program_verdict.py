"""`stepramp check PROGRAM`: a program file's verdict (issue 31 item 2).

What the chip runs for the program (`profiles.ppmc312.command_runs`, every reading of a
decel stop from mid-ramp that runs something different) is judged as the table's moves
are, through the one verdict's two judges:

- the **criterion** on each motion's speed changes (`criterion.runs_problems`; a motion
  is split where its direction reverses, each leg starting and stopping at rest; over a
  tolerance box at its worst case): `program-criterion`, naming the command and the
  pulse, and §8-8 when a speed change left the chip stopping from a faster speed;
- the **load angle** through each motion (`command_angles.motion_angle`, the motor or
  every corner of its box): `program-load-angle` past the 90° peak (error),
  `program-load-angle-margin` past the aim (warning).

The table's own chip rules are reported too (the program runs it); without a motor the
notes say what each motion runs.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from profiles.findings import Finding
from profiles.motor.angles import AIM_DEG, PEAK_DEG

if TYPE_CHECKING:
    from profiles.motor import Motor
    from profiles.ppmc312.command_runs import Motion, ProgramRun
    from profiles.ppmc312.criterion import StepProblem
    from profiles.ppmc312.program import Program


def program_verdict(program: Program, motor: Motor | None, *, physics: bool = True,
                    aim_deg: float = AIM_DEG) -> tuple[list[Finding], list[str], dict[str, Any]]:
    """(findings, notes, details) of a program: the table's chip rules, and with a motor
    the criterion and (`physics`) the load angle of every motion under every reading."""
    from profiles.ppmc312.chip_rules import check_table
    from profiles.ppmc312.init_model import as_free_curve

    runs = program.runs()
    findings = [Finding(f.severity, f.rule, f"table {program.table_path}: {f.message}",
                        f.chip_code, f.stage) for f in check_table(program.table)]
    notes = [describe_motion(program, m, k) for k, m in enumerate(runs[0].motions)]
    notes += list(runs[0].notes)
    if len(runs) > 1:
        notes.append("a decel stop comes on the ramp: readings "
                     f"{', '.join(r.reading for r in runs)} of it run differently (each judged)")
    details: dict[str, Any] = {"program": {
        "table": program.table_path, "commands": len(program.commands),
        "readings": [r.reading for r in runs],
        "motions": [m.to_json(program.names()) for m in runs[0].motions]}}
    if motor is None or any(f.severity == "error" for f in findings):
        return findings, notes, details
    free = as_free_curve(program.table)
    # one finding per problem, whichever readings run it (their pulses may differ)
    found: dict[tuple[Any, ...], tuple[Finding, list[str]]] = {}
    for run in runs:
        for key, f in _run_findings(program, run, motor, free.rates, physics, aim_deg):
            found.setdefault(key, (f, []))[1].append(run.reading)
    for f, readings in found.values():
        message = f.message
        if len(readings) < len(runs):
            message += f" (decel-stop reading{'s' if len(readings) > 1 else ''} " \
                       f"{', '.join(readings)})"
        findings.append(Finding(f.severity, f.rule, message))
    details["program"]["safe"] = not any(f.severity == "error" for f in findings)
    return findings, notes, details


def describe_motion(program: Program, m: Motion, k: int) -> str:
    """'motion 1: commands[0] (accel 82) CW, 20000 pulses in 1.2 s, ends NOS …'."""
    from profiles.ppmc312.command_runs import CAUSES

    hz = m.clock.hz
    way = "CCW" if m.ccw else "CW"
    back = " and back" if any(p.backward for p in m.pieces) else ""
    text = (f"motion {k + 1}: {program.commands[m.started_by].label(m.started_by)} {way}"
            f"{back}, {m.pulses} pulses in {m.execution().duration_s:.6g} s; ends "
            f"{m.cause} ({CAUSES[m.cause]}) from {hz / m.final_rate:.6g} pps")
    if m.ended_by != m.started_by:
        text += f", by {program.commands[m.ended_by].label(m.ended_by)}"
    if m.changed_at is not None:
        i, at = m.changed_at
        text += (f"; {program.commands[i].label(i)} at pulse {at}: the decel point stays "
                 "where it was (§8-8)" if program.commands[m.started_by].name == "accel"
                 else f"; {program.commands[i].label(i)} at pulse {at}")
    return text


def _run_findings(program: Program, run: ProgramRun, motor: Motor, rates: tuple[int, ...],
                  physics: bool, aim_deg: float) -> list[tuple[tuple[Any, ...], Finding]]:
    """Each finding of one reading's run, keyed by the problem it names (not by where:
    the readings of a decel stop move the pulses after it)."""
    from profiles.motor.tolerance import corners, worst_case_motor
    from profiles.ppmc312.command_angles import motion_angle

    judged = worst_case_motor(motor) if motor.tolerances else motor
    box = [c.motor for c in corners(motor)] if motor.tolerances else [motor]
    out: list[tuple[tuple[Any, ...], Finding]] = []
    for k, m in enumerate(run.motions):
        out += _criterion(program, m, k, judged, rates)
        if not physics:
            continue
        angle = motion_angle(m, box)
        if angle.worst_deg <= aim_deg:
            continue
        where = _where(program, m, angle.piece)
        at = "" if not motor.tolerances else f" at {corners(motor)[angle.motor].describe()}"
        text = (f"motion {k + 1}: {where} drives the rotor to {angle.worst_deg:.1f}° "
                f"electrical{at}; margin {PEAK_DEG - angle.worst_deg:+.1f}° to the 90° peak"
                + (" (it slips a pole)" if angle.slipped else ""))
        if angle.worst_deg >= PEAK_DEG:
            out.append(((k, "angle"), Finding("error", "program-load-angle", text)))
        else:
            out.append(((k, "angle"), Finding("warning", "program-load-angle-margin",
                                              f"{text} (stepramp plan aims at ≤ "
                                              f"{aim_deg:g}°)")))
    return out


def _where(program: Program, m: Motion, piece: int | None) -> str:
    """Where in a motion: the command running piece `piece` and its pulses."""
    if piece is None:
        i = m.ended_by
        return (f"the stop after pulse {m.pulses} ({program.commands[i].label(i)}, "
                f"from {m.clock.hz / m.final_rate:.6g} pps)")
    before = sum(p.pulses for p in m.pieces[:piece])
    p = m.pieces[piece]
    return (f"{program.commands[p.command].label(p.command)} at pulses {before + 1}–"
            f"{before + p.pulses} ({p.phase} at {m.clock.hz / p.rate:.6g} pps"
            f"{', backward' if p.backward else ''})")


def _criterion(program: Program, m: Motion, k: int, motor: Motor, rates: tuple[int, ...]
               ) -> list[tuple[tuple[Any, ...], Finding]]:
    """The criterion on each leg of motion k (split where it reverses)."""
    from profiles.ppmc312.criterion import runs_problems

    out: list[tuple[tuple[Any, ...], Finding]] = []
    before = 0
    for n, leg in enumerate(m.legs()):
        runs = [(p.phase, p.rate, p.pulses) for p in leg]
        pulses = sum(p.pulses for p in leg)
        for p in runs_problems(runs, m.clock.hz, pulses, motor, rates):
            key = (k, n, p.rule, p.kind, p.v_from_pps, p.v_to_pps)
            out.append((key, Finding("error", "program-criterion", f"motion {k + 1}: " +
                                     _problem(program, m, leg, before, p, motor))))
        before += pulses
    return out


def _problem(program: Program, m: Motion, leg: Sequence[Any], before: int, p: StepProblem,
             motor: Motor) -> str:
    """A criterion problem of one leg as a finding's message (module docstring)."""
    hz = m.clock.hz
    speeds = [hz / x.rate for x in leg]
    if p.kind == "start":
        i = 0
    elif p.kind in ("stop", "top"):
        i = len(leg) - 1 if p.kind == "stop" else speeds.index(p.v_from_pps)
    else:
        i = next(j for j in range(len(leg) - 1)
                 if speeds[j] == p.v_from_pps and speeds[j + 1] == p.v_to_pps) + 1
    at = before + sum(x.pulses for x in leg[:i])
    c = leg[i].command
    label = program.commands[c].label(c)
    if p.kind == "start":
        how = "reverses at once to" if leg[0].backward else "starts at once at"
        return (f"{label} {how} {p.v_from_pps:.6g} pps, above the motor's start speed "
                f"{motor.start_pps:.6g} pps")
    if p.kind == "stop":
        end = at + leg[i].pulses
        if m.changed_at is not None and program.commands[m.started_by].name != "constant":
            j, when = m.changed_at
            return (f"the speed change at pulse {when} ({program.commands[j].label(j)}) leaves "
                    f"the chip stopping from {p.v_from_pps:.6g} pps at pulse {end}: the decel "
                    f"point stays where it was (§8-8); above the motor's start speed "
                    f"{motor.start_pps:.6g} pps")
        e = m.ended_by
        return (f"{program.commands[e].label(e)} stops the motion at once from "
                f"{p.v_from_pps:.6g} pps after pulse {end}, above the motor's start speed "
                f"{motor.start_pps:.6g} pps")
    if p.kind == "top":
        return (f"{label} runs {p.v_from_pps:.6g} pps, above the motor's top usable speed "
                f"{motor.top_pps:.6g} pps")
    change = f"from {p.v_from_pps:.6g} to {p.v_to_pps:.6g} pps after pulse {at}"
    if p.rule == "jump" or (p.rule == "switch" and abs(p.jump_pps) > motor.jump_pps):
        return (f"{label} steps {change} at once ({p.jump_pps:+.6g} pps), above the largest "
                f"jump {motor.jump_pps:.6g} pps")
    return (f"{label} steps {change}, which needs {p.need_pps2:.6g} pps² where the motor "
            f"gives {p.cap_pps2:.6g} pps² ({p.rule})")


def timeline(program: Program, run: ProgramRun) -> str:
    """`stepramp simulate PROGRAM`'s text: each motion, then each command's stretch of it
    (time, pulses, phases and speeds), and the run's notes."""
    names = program.names()
    lines = [f"program: {len(program.commands)} commands, table {program.table_path}, "
             f"{len(run.motions)} motion(s); decel stops from mid-ramp: reading {run.reading}"]
    for k, m in enumerate(run.motions):
        lines.append(describe_motion(program, m, k))
        hz, tick, pulse = m.clock.hz, 0, 0
        groups: list[list[Any]] = []
        for p in m.pieces:
            if not groups or (groups[-1][0].command, groups[-1][0].backward) != \
                    (p.command, p.backward):
                groups.append([])
            groups[-1].append(p)
        for g in groups:
            ticks = sum(p.rate * p.pulses for p in g)
            pulses = sum(p.pulses for p in g)
            phases = "/".join(dict.fromkeys(p.phase for p in g))
            rates = list(dict.fromkeys(p.rate for p in g))
            speeds = " → ".join(f"{hz / r:.6g}" for r in (rates if len(rates) < 4 else
                                                           (rates[0], rates[-1]))) + " pps"
            if len(rates) >= 4:
                speeds += f" ({len(rates)} speeds)"
            lines.append(f"  {tick / hz:.6f}–{(tick + ticks) / hz:.6f} s  pulses "
                         f"{pulse + 1}–{pulse + pulses}  commands[{g[0].command}] "
                         f"{names[g[0].command]}: {phases} {speeds}"
                         + (", backward" if g[0].backward else ""))
            tick, pulse = tick + ticks, pulse + pulses
    return "\n".join([*lines, *(f"note: {n}" for n in run.notes)]) + "\n"
