"""`stepramp check` for A-Link settings files and command lists: the file's CRC-32
(`alink-corrupted` / `alink-unchecked`), pair codes that change from command to command,
the settings the unit would silently correct (`profiles.alink.unit_applies`), and what the
unit answers to each command from power on (`profiles.alink.unit.run_commands`: every Nak
rule of §11–12, and what it does without one); in sync's report, each axis's settings
against the rule the planner plans by."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any

from profiles.errors import CorruptedError, StepRampError
from profiles.findings import Finding, Severity, dedupe, integrity_findings
from profiles.verdict import DEFAULT_SAMPLES

from .common import device_result

if TYPE_CHECKING:
    from profiles.alink import AlinkSettings, Command
    from profiles.alink.homing import HomingSettings
    from profiles.alink.planner import SettingsJudge
    from profiles.alink.ramp import AlinkRamp
    from profiles.alink.unit import Answer, Issue
    from profiles.motor import Motor
    from profiles.progress import Progress
    from profiles.verdict import LoadAngle, SafetyVerdict

    from ..check_options import CheckOptions
    from ..report import FileResult

TITLE = "A-Link settings"


def check(raw: bytes, path: str, options: CheckOptions) -> FileResult:
    """`stepramp check`'s verdict on one of the device's files: its own check, then the
    device's rules (a file whose own check fails has that one finding: its content
    cannot be trusted for more); with a motor, the one safety verdict
    (`verify.safety.judge_safety`, `judge_ramp` below) on the unit's ramp for the
    settings the file leaves (its JSON in `details["safety"]`, as a PPMC-312 table's)."""
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
    from profiles.alink.homing import HomingSettings
    from profiles.alink.model import MODE_DEFAULT, MODE_S_CURVE, MODE_TRIANGLE_AVOID
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


def settings_judge(motor: Motor, *, aim_deg: float) -> SettingsJudge:
    """The one verdict (`judge_safety`) as the A-Link planner's judge
    (`profiles.alink.planner.tighten_settings`): within the aim or not, the worst angle,
    and the lever it blames — the start speed when the worst is a short move, an early
    decel stop or the start itself (its speed in the lowest 30 % of the ramp), else the
    ramp."""
    from profiles.alink.planner import Judgement
    from profiles.alink.ramp import ramp_of

    def judged(settings: AlinkSettings) -> Judgement:
        ramp = ramp_of(settings)
        v = judge_ramp(ramp, motor, samples=0, aim_deg=aim_deg)
        rules = {f.rule for f in v.criterion}
        worst, speed, what = _worst_speed(ramp, v)
        near_start = speed <= ramp.start_pps + START_SHARE * (ramp.high_pps - ramp.start_pps)
        # a command family past the aim at its use from L (a stop at once, a limit run)
        from_start = any(not c.within_aim and name in ("stop", "limit")
                         for name, c in v.commands)
        start = "stall-start-speed" in rules or from_start or (not rules and near_start)
        return Judgement(v.within_aim and v.safe, worst, "start" if start else "ramp", what)

    return judged


def sync_judge_for(motor: Motor) -> SettingsJudge:
    """The judge sync's time planner tightens each A-Link axis on
    (`profiles.alink.sync.plan_sync`): `settings_judge` at the 75° aim."""
    from profiles.motor.angles import AIM_DEG

    return settings_judge(motor, aim_deg=AIM_DEG)


START_SHARE = 0.3   # a worst angle peaking below L + this × (H − L) is the start speed's


def _worst_speed(ramp: AlinkRamp, v: SafetyVerdict) -> tuple[float, float, str]:
    """(the worst angle over the moves and the decel stops, the speed its motion peaks at,
    a phrase naming it)."""
    import numpy as np

    from profiles.alink.ramp import parts

    la = v.load_angle
    best = (-1.0, float(ramp.start_pps), "nothing judged")
    if la is not None:
        up = int(parts(ramp, "move", np.array([la.worst_pulses])).up[0])
        best = (la.worst_deg, _speed_at(ramp, up), f"a move of {la.worst_pulses} pulses")
    for name, c in v.commands:
        deg = float(c.to_json()["worst_load_angle_deg"])
        if name == "decel-stop" and deg > best[0]:
            x = int(c.to_json()["worst_at"])
            best = (deg, _speed_at(ramp, x), f"a decel stop from pulse {x} of the ramp")
    return best


def _speed_at(ramp: AlinkRamp, pulse: int) -> float:
    """The speed of the ramp's stage holding pulse `pulse` (H past the ramp)."""
    import numpy as np

    ends = np.cumsum(ramp.pulses)
    k = int(np.searchsorted(ends, pulse, side="left"))
    return float(ramp.speeds_pps[k]) if k < len(ends) else float(ramp.high_pps)


def axis_verdict(axis: Any) -> tuple[bool, dict[str, Any]]:
    """Whether one axis of a synchronised move is safe, and what sync's report says of it:
    its settings against the rule the planner plans by
    (`profiles.alink.sync.is_stall_safe`) and the one safety verdict on the unit's ramp
    (`judge_safety`, every move length: its JSON as a PPMC-312 axis's `safety`)."""
    from profiles.alink.ramp import ramp_of
    from profiles.alink.sync import is_stall_safe

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


# --- the unit's safety verdict (the registry's `safety` entry of the A-Link) -----------

def judge_ramp(ramp: AlinkRamp, motor: Motor, *, pulses: Iterable[int] | None = None,
               samples: int = DEFAULT_SAMPLES, seed: int = 0, aim_deg: float | None = None,
               strict: bool = False, load_angle: bool = True,
               commands: Iterable[str] | None = None, progress: Progress | None = None,
               homing: HomingSettings | None = None) -> SafetyVerdict:
    """`judge_safety` on the A-Link unit's ramp (verify.alink_safety; the registry's
    `safety` entry of the A-Link): the unit's criterion, every move length on the load
    angle over the box, and as its command families the decel stops (STOP 31) from every
    pulse of the ramp and, with `homing`, the homing legs (OL/OH, O_UPTIME, the stop at
    once at the origin); `commands` names the unit's commands (`stepramp alink
    command`) whose families are judged. `progress` is not reported: the unit's verdict
    is one batch."""
    from profiles.motor.tolerance import corners, worst_case_motor
    from profiles.verdict import LoadAngle, SafetyVerdict, require_aim

    from .. import alink_safety as al

    if aim_deg is None:  # the motor's landmarks load numpy: read on use
        from profiles.motor.angles import AIM_DEG

        aim_deg = AIM_DEG
    require_aim(aim_deg)

    families = al.alink_families(commands)  # an unknown command is refused before any work

    moves = None if pulses is None else tuple(sorted({int(n) for n in pulses}))
    criterion = al.ramp_criterion(ramp, worst_case_motor(motor) if motor.tolerances
                                  else motor, homing)
    if motor.tolerances:
        criterion = [f.with_message(f.message + " (at the tolerance box's worst case)")
                     for f in criterion]
    resonance = tuple(al.ramp_resonance(ramp, motor, strict=strict))
    if not load_angle:
        return SafetyVerdict(moves, aim_deg, tuple(criterion), None, None, resonance)
    box_corners = corners(motor) if motor.tolerances else []
    ways = al.ways_of(motor)
    rot = al.box_rotors([c.motor for c in box_corners] or [motor], ways)
    found = al.motion_angles(ramp, "move", rot, moves)
    deg, row, e = found.worst()
    where = box_corners[row // len(ways)].describe() if box_corners else "nominal"
    la = LoadAngle(deg, int(found.x[e]), int(rot.direction[row]), where,
                   found.first_unstable(), bool(found.slipped.any()), found.deg.size)
    box = _ramp_box(ramp, motor, found, la, len(box_corners), len(ways), samples, seed) \
        if box_corners else None
    if box is not None:
        la = LoadAngle(box.worst_angle_deg, box.worst_pulses, box.worst_direction,
                       box.worst_where, box.first_unstable_pulses, box.slips,
                       box.executions, box.sample_failures)
    return SafetyVerdict(moves, aim_deg, tuple(criterion), la, box, resonance,
                         tuple(al.family_verdicts(ramp, homing, rot, aim_deg, families)))


def _ramp_box(ramp: AlinkRamp, motor: Motor, found: Any, corner: LoadAngle, n_corners: int,
              n_ways: int, samples: int, seed: int) -> Any:
    """The tolerance box's verdict on the unit's moves: the corners (rows of `found`), the
    Monte Carlo samples on the moves worst at some corner."""
    import numpy as np

    from profiles.alink.ramp import RAMP_HZ
    from profiles.motor.angles import PEAK_DEG
    from profiles.motor.batch_angle import batch_sample_peaks
    from profiles.motor.tolerance import clopper_pearson_upper
    from profiles.verdict import CONFIDENCE, BoxVerdict

    from .. import alink_safety as al

    per_corner = found.deg.reshape(n_corners, n_ways, -1).max(axis=1)
    sampled = tuple(sorted({int(found.x[k]) for k in np.argmax(per_corner, axis=1)}))
    worst = (corner.worst_deg, corner.worst_at, corner.worst_pulses, corner.worst_direction)
    sample_worst, failures, unstable = -1.0, 0, corner.first_unstable_pulses
    if samples:
        peaks, which, way = batch_sample_peaks(al.batch(ramp, "move", np.asarray(sampled)),
                                               RAMP_HZ, motor, samples, seed)
        failures = int(np.sum(peaks >= PEAK_DEG))
        i = int(np.argmax(peaks))
        sample_worst = float(peaks[i])
        if sample_worst > worst[0]:
            worst = (sample_worst, f"sample {i}", sampled[int(which[i])], int(way[i]))
        if failures:
            first = min(sampled[int(k)] for k in which[peaks >= PEAK_DEG])
            unstable = first if unstable is None else min(unstable, first)
    bound = clopper_pearson_upper(failures, samples, CONFIDENCE) if samples else 1.0
    return BoxVerdict(worst[0], worst[1], worst[2], worst[3], n_corners, corner.worst_deg,
                      samples, seed, sample_worst, failures, sampled, bound, unstable,
                      corner.slips, corner.executions + samples * len(sampled))
