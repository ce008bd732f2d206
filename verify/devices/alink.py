"""`stepramp check` for A-Link settings files and command lists: the file's CRC-32
(`alink-corrupted` / `alink-unchecked`), pair codes that change from command to command,
the settings the unit would silently correct (`profiles.alink.unit_applies`), and what the
unit answers to each command from power on (`profiles.alink.unit.run_commands`: every Nak
rule of §11–12, and what it does without one); in sync's report, each axis's settings
against the rule the planner plans by."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from profiles.errors import CorruptedError, StepRampError
from profiles.findings import Finding, Severity, dedupe, integrity_findings

from .common import device_result

if TYPE_CHECKING:
    from profiles.alink import Command
    from profiles.alink.planner import SettingsJudge
    from profiles.alink.unit import Answer, Issue
    from profiles.motor import Motor

    from ..check_options import CheckOptions
    from ..report import FileResult

TITLE = "A-Link settings"


def check(raw: bytes, path: str, options: CheckOptions) -> FileResult:
    """`stepramp check`'s verdict on one of the device's files: its own check, then the
    device's rules (a file whose own check fails has that one finding: its content
    cannot be trusted for more); with a motor, the one safety verdict
    (`verify.safety.judge_safety`, `profiles.alink.verdict.judge_ramp`) on the unit's
    ramp for the settings the file leaves (its JSON in `details["safety"]`, as a PPMC-312
    table's)."""
    from profiles.alink.formats import parse

    from ..report import FileResult

    try:
        parsed = parse(raw, path)
    except CorruptedError as e:
        return device_result(path, [Finding("error", "alink-corrupted", str(e))], TITLE,
                             options)
    found = (integrity_findings("alink", parsed.format, parsed.integrity, parsed.detail)
             + command_findings(parsed.items))
    if options.motor is None:
        return device_result(path, found, TITLE, options)
    notes = [f"{TITLE} file"]
    details: dict[str, object] = {}
    found += safety_findings(parsed.items, options, notes, details)
    found = dedupe(found)
    return FileResult(path=path, ok=not any(f.severity == "error" for f in found),
                      findings=found, notes=notes, details=details)


def ramp_of_commands(commands: Sequence[Command]) -> tuple[Any, Any, str | None]:
    """The unit's ramp for the settings `commands` leave (the last of each, as the unit
    applies them: `unit_applies`) and their homing speeds (None when the list sets none of
    OL_SPEED, OH_SPEED, O_UPTIME); or why there is none (a line)."""
    from profiles.alink import FUNC_ACCEL_PARA, Cmd, unit_applies
    from profiles.alink.model import MODE_DEFAULT, MODE_S_CURVE, MODE_TRIANGLE_AVOID
    from profiles.alink.planner.homing import HomingSettings
    from profiles.alink.ramp import build_ramp

    last: dict[int, Command] = {}
    for c in commands:
        last[c.cmd] = c
    need = [Cmd(k).name for k in (Cmd.H_SPEED, Cmd.L_SPEED, Cmd.UP_TIME) if k not in last]
    if need:
        return None, None, (f"--motor: the file sets no {', '.join(need)}: no ramp to judge "
                            "(the unit keeps what it holds)")
    if last[Cmd.UP_TIME].func != FUNC_ACCEL_PARA:
        return None, None, ("--motor: UP_TIME func 1 (the legacy rate) has no documented "
                            "acceleration: the ramp is not judged")
    try:
        run = unit_applies(last[Cmd.L_SPEED].para, last[Cmd.H_SPEED].para,
                           last[Cmd.UP_TIME].para,
                           max_pps=last[Cmd.MAX_SPEED].para if Cmd.MAX_SPEED in last else 0)
    except StepRampError as e:
        return None, None, f"--motor: the settings run no ramp ({e})"
    if run.nak is not None or run.accel_pps2 is None:
        return None, None, f"--motor: the unit refuses to drive ({run.nak}): no ramp to judge"
    mode = last[Cmd.MODE].para if Cmd.MODE in last else MODE_DEFAULT
    ramp = build_ramp(run.start_pps, run.high_pps, run.accel_pps2, run.multiplier,
                      "s_curve" if mode & MODE_S_CURVE else "linear",
                      triangle_avoidance=bool(mode & MODE_TRIANGLE_AVOID),
                      max_pps=last[Cmd.MAX_SPEED].para if Cmd.MAX_SPEED in last else 0)
    homing = None
    if {Cmd.OL_SPEED, Cmd.OH_SPEED, Cmd.O_UPTIME} <= set(last) and \
            last[Cmd.O_UPTIME].func == FUNC_ACCEL_PARA and \
            0 < last[Cmd.OL_SPEED].para <= last[Cmd.OH_SPEED].para and \
            last[Cmd.O_UPTIME].para > 0:
        homing = HomingSettings(last[Cmd.OL_SPEED].para, last[Cmd.OH_SPEED].para,
                                last[Cmd.O_UPTIME].para)
    return ramp, homing, None


def safety_findings(commands: Sequence[Command], options: CheckOptions, notes: list[str],
                    details: dict[str, object]) -> list[Finding]:
    """The safety verdict's findings for the ramp the commands leave; its summaries go to
    `notes`, its JSON to `details["safety"]`."""
    from profiles.alink.verdict import judge_ramp  # the unit's own verdict (loads numpy)

    assert options.motor is not None
    ramp, homing, why = ramp_of_commands(commands)
    if ramp is None:
        notes.append(str(why))
        return []
    verdict = judge_ramp(ramp, options.motor, pulses=options.pulses,
                         samples=options.samples, seed=options.seed, strict=options.strict,
                         load_angle=options.physics, homing=homing,
                         progress=options.progress, commands=options.commands)
    details["safety"] = verdict.to_json()
    notes.append(f"the unit's ramp: {ramp.describe()}")
    if options.commands is not None:
        notes.append("--commands: the unit's command families judged: " + (", ".join(
            name for name, _ in verdict.commands) or "the moves alone"))
    notes.extend(verdict.notes())
    return verdict.findings()


def sync_judge_for(motor: Motor) -> SettingsJudge:
    """The judge sync's time planner tightens each A-Link axis on
    (`profiles.alink.sync.plan_sync`): `settings_judge` at the 75° aim."""
    from profiles.alink.verdict import settings_judge
    from profiles.motor.angles import AIM_DEG

    return settings_judge(motor, aim_deg=AIM_DEG)


def axis_verdict(axis: Any) -> tuple[bool, dict[str, Any]]:
    """Whether one axis of a synchronised move is safe, and what sync's report says of it:
    its settings against the rule the planner plans by
    (`profiles.alink.sync.is_stall_safe`) and the one safety verdict on the unit's ramp
    (`judge_safety`, every move length: its JSON as a PPMC-312 axis's `safety`)."""
    from profiles.alink.ramp import ramp_of
    from profiles.alink.sync import is_stall_safe
    from profiles.alink.verdict import judge_ramp

    rule = is_stall_safe(axis.settings, axis.motor)
    verdict = judge_ramp(ramp_of(axis.settings), axis.motor)
    return rule and verdict.safe, {"stall_safe": rule, "safety": verdict.to_json()}


def findings(raw: bytes, path: str) -> list[Finding]:
    from profiles.alink.formats import parse

    try:
        parsed = parse(raw, path)
    except CorruptedError as e:
        return [Finding("error", "alink-corrupted", str(e))]
    out = integrity_findings("alink", parsed.format, parsed.integrity, parsed.detail)
    return out + command_findings(parsed.items)


def command_findings(commands: Sequence[Command]) -> list[Finding]:
    """The unit's rules on a list of `Command`s: pair codes, the settings they leave, then
    what the unit answers to each command from power on (`profiles.alink.unit`)."""
    from profiles.alink.unit import run_commands

    run = run_commands(commands)
    return (_pair_findings(commands) + _settings_findings(commands, run.end)
            + answer_findings(run.answers))


# What each of the unit model's kinds is in check's report: (severity, rule).
RULES: dict[str, tuple[Severity, str]] = {
    "value": ("error", "alink-range"), "busy": ("error", "alink-busy"),
    "origin": ("error", "alink-origin"), "soft-limit": ("error", "alink-soft-limit"),
    "speeds": ("error", "alink-nak"), "change-speed": ("error", "alink-change-speed"),
    "capped": ("warning", "alink-corrected"), "idle": ("warning", "alink-change-speed-idle"),
    "stale-limits": ("warning", "alink-soft-limit-stale"),
    "factory": ("warning", "alink-factory"), "clear-el": ("warning", "alink-clear-el")}


def answer_findings(answers: Sequence[Answer]) -> list[Finding]:
    """The unit model's Naks and notes as findings; a settings command's value is judged
    by the settings rules (`alink-range`, `alink-mode`, `alink-func`) instead."""
    from profiles.alink import SETTINGS_CMDS

    out = []
    for a in answers:
        for issue in (*a.naks, *a.notes):
            if issue.kind == "value" and a.command.cmd in SETTINGS_CMDS:
                continue
            severity, rule = RULES[issue.kind]
            out.append(Finding(severity, rule, issue.message))
    return out


def _pair_findings(commands: Sequence[Command]) -> list[Finding]:
    out: list[Finding] = []
    previous = None
    for k, c in enumerate(commands):
        if c.pair == 0:
            out.append(Finding("error", "alink-pair-code",
                               f"command {k} ({c.name}): pair code 0 is the no-op: the unit "
                               "does not run it"))
        elif c.pair == previous:
            out.append(Finding("error", "alink-pair-code",
                               f"command {k} ({c.name}): pair code {c.pair} again: the sender "
                               "must change it for every command (manual 10-4 (3)); the unit "
                               "cannot tell this one from the one before"))
        previous = c.pair
    return out


def _settings_findings(commands: Sequence[Command], end: Sequence[Issue]) -> list[Finding]:
    """The five settings commands the list leaves (the last of each), and `end`: the Nak
    they bring to a drive or homing command when the list has none."""
    from profiles.alink import FUNC_ACCEL_PARA, FUNC_SPEED_PPS, Cmd

    naks = [Finding("error", "alink-nak", issue.message) for issue in end]
    last: dict[int, Command] = {}
    for c in commands:
        last[c.cmd] = c
    settings = (Cmd.MAX_SPEED, Cmd.MODE, Cmd.H_SPEED, Cmd.L_SPEED, Cmd.UP_TIME)
    present = [Cmd(k).name for k in settings if k in last]
    if not present:
        return naks
    out: list[Finding] = []
    missing = [Cmd(k).name for k in settings if k not in last]
    if missing:
        out.append(Finding("warning", "alink-incomplete",
                           f"the file sets {', '.join(present)} but not {', '.join(missing)}: "
                           "the unit keeps what it holds, which the file cannot show"))
    for k in (Cmd.MAX_SPEED, Cmd.H_SPEED, Cmd.L_SPEED):
        if k in last and last[k].func != FUNC_SPEED_PPS:
            out.append(Finding("warning", "alink-func",
                               f"{Cmd(k).name} func {last[k].func}: stepramp models func "
                               f"{FUNC_SPEED_PPS} only (×1 pps)"))
    if Cmd.MODE in last:
        mode = last[Cmd.MODE].para
        if mode & 0x5 != 0x5:
            out.append(Finding("error", "alink-mode",
                               f"MODE 0x{mode:X}: D0 and D2 are fixed at 1 (manual 11-2 (2))"))
    if Cmd.UP_TIME in last and last[Cmd.UP_TIME].func == 1:
        out.append(Finding("warning", "alink-func",
                           "UP_TIME func 1: the legacy axis-chip rate, whose conversion to "
                           "pps/s the manual lacks (stepramp writes func 2, 0.01 ms per 1000 "
                           "pps)"))
    if Cmd.UP_TIME in last and last[Cmd.UP_TIME].func not in (1, FUNC_ACCEL_PARA):
        out.append(Finding("error", "alink-range",
                           f"UP_TIME func {last[Cmd.UP_TIME].func}: nn is 1 (rate) or 2 (0.01 "
                           "ms per 1000 pps)"))
        return out + naks
    out += naks
    if {Cmd.L_SPEED, Cmd.H_SPEED, Cmd.UP_TIME} <= set(last):
        out += _unit_findings(last)
    return out


def _unit_findings(last: dict[int, Command]) -> list[Finding]:
    """What the unit makes of the speeds and ramp: range, silent corrections."""
    from profiles.alink import Cmd, unit_applies

    max_pps = last[Cmd.MAX_SPEED].para if Cmd.MAX_SPEED in last else 0
    try:
        run = unit_applies(last[Cmd.L_SPEED].para, last[Cmd.H_SPEED].para,
                           last[Cmd.UP_TIME].para, max_pps=max_pps,
                           nn=last[Cmd.UP_TIME].func)
    except StepRampError as e:
        return [Finding("error", "alink-range", f"the unit answers Nak (parameter value not "
                                                f"valid): {e}")]
    # run.nak (start > high, high > MAX_SPEED) is the unit model's `speeds` rule, judged
    # at the list's drive commands or at its end (`_settings_findings`)
    return [Finding("warning", "alink-corrected", f"the unit silently changes it: {note}")
            for note in run.corrections]
