"""What the designer computes, whichever view shows it: `design_steps(motor, settings)`.

Sliders set the move, the load and the aim (`Settings`: move length, load inertia,
load torque, friction, safety factor, load-angle aim, clock, stage budget; their ranges
`control_specs`); every change replans the table (`plan_free_curve`) and gives a
`Design`: the staircase the chip runs, the exact continuous optimum, the stall margin of
every stage, the rotor's load angle (`verify.load_angle.trace_load_angle`) and the
verdict over every move the table can run (`verify.safety.judge_safety`, read by
`verdict`); `design_files` gives the table and its upload files.

A change is shown in three steps (`design_steps`): first the plain stall criterion's
table (`first_design`: the plan the tightening starts from anyway, with its margins and
the exact optimum; no load angle judged), marked as being tightened (`Design.final`
False, the verdict "tightening") and never offered; then the final table, tightened to
the load-angle aim (the same table `stepramp plan` gives for those inputs) and judged
for moves and decel stops (the tightening's verdicts, remembered); then its verdict over
every motion command (`judged_in_full`, what `design` returns; `Design.complete`: only
such a design is written or downloaded). bench/bench_designer.py times the steps
against the budget (first ≤ 50 ms, final ≤ 150 ms, issue #32 item 9). Lengths and speeds
are also given in mm and mm/s (rev, rpm on a rotary axis): `profiles.motor.travel`.

The load torque slider sets the motor's `load_torque_nm` (signed: > 0 opposes
forward motion); the load angle is followed in the direction the load opposes
(forward when it is zero).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from profiles.errors import FieldRangeError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.motor.angles import AIM_DEG, PEAK_DEG
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import Execution, simulate_move
from profiles.ppmc312.planner import Plan, plan_free_curve

AUTO_CLOCK = "auto"
PULSES_RANGE = (10, 1_000_000)
OPENING_PULSES = 10_000       # the move a designer (notebook or web page) opens with
PULSES_SLIDER_MAX = 200_000
AIM_RANGE_DEG = (10.0, PEAK_DEG)
SLOW_REFERENCES = ("toppra", "ruckig", "casadi")
UPLOAD_FORMATS = ("hex", "ihex", "c", "json", "bin", "bus")
TIGHTENING = "TIGHTENING…"    # how a first table (not final, not judged) is marked everywhere
# the commands the tightening plans for (a move, 82, and a decel stop, 81): the final table
# is shown judged for these before the other commands' verdicts come
PLANNED_COMMANDS = ("82", "81")
JUDGING = "the other motion commands: judging…"


@dataclass(frozen=True)
class Settings:
    """What the sliders set. `load_inertia_kgm2` adds to the motor's inertia;
    `load_torque_nm` and `friction_torque_nm` replace the motor's (None: the motor
    file's own). `load_angle_aim_deg` is the aim the verdict holds the load angle to;
    with `plan_to_aim` (the default) the planner tightens the table where the rotor rings
    until it is met, as `stepramp plan` does (a few plans instead of one); without it the
    plain criterion's table is shown, and the verdict says how far past the aim it is."""

    pulses: int = OPENING_PULSES
    safety_factor: float = 0.6
    load_inertia_kgm2: float = 0.0
    load_torque_nm: float | None = None
    clock: str = AUTO_CLOCK
    max_stages: int = 127
    friction_torque_nm: float | None = None
    load_angle_aim_deg: float = AIM_DEG
    plan_to_aim: bool = True
    # the torque reserve at the top speed, as `plan --cruise-reserve` takes it (no slider)
    cruise_reserve: str = "2x,10%"


@dataclass(frozen=True)
class ControlSpec:
    """One slider of the designer, whichever view draws it: label, range, step, start
    value, readout (a printf-style spec without the %) and the group it sits in."""

    label: str
    lo: float
    hi: float
    step: float
    value: float
    fmt: str = ".3f"
    group: str = "move"

    @property
    def integer(self) -> bool:
        return self.fmt == "d"


# The sliders a motor switch resets to the new motor's own values.
MOTOR_SPECIFIC = ("safety_factor", "load_inertia_kgm2", "load_torque_nm", "friction_torque_nm")


def control_specs(motor: Motor, pulses: int = OPENING_PULSES) -> dict[str, ControlSpec]:
    """The designer's sliders for `motor`, by `Settings` field: the move, the load
    (inertia up to 10× the rotor's, load torque and friction up to half the usable
    standstill torque), the aim (safety factor, load-angle aim) and the stage budget."""
    lo, hi = PULSES_RANGE
    if not lo <= pulses <= hi:
        raise FieldRangeError("pulses", pulses, lo, hi)
    span = _torque_span(motor)

    def within(value: float, a: float, b: float) -> float:
        return min(max(value, a), b)

    return {
        "pulses": ControlSpec("move [pulses]", lo, max(PULSES_SLIDER_MAX, pulses), 10, pulses,
                              "d", "move"),
        "load_inertia_kgm2": ControlSpec("load inertia [kg·m²]", 0.0, 10 * motor.inertia_kgm2,
                                         motor.inertia_kgm2 / 20, 0.0, ".2e", "load"),
        "load_torque_nm": ControlSpec("load torque [N·m]", -span, span, span / 100,
                                      within(motor.load_torque_nm, -span, span), ".3f", "load"),
        "friction_torque_nm": ControlSpec("friction [N·m]", 0.0, span, span / 100,
                                          within(motor.friction_torque_nm, 0.0, span), ".3f",
                                          "load"),
        "safety_factor": ControlSpec("safety factor", 0.1, 1.0, 0.01, motor.safety_factor,
                                     ".2f", "aim"),
        "load_angle_aim_deg": ControlSpec("load-angle aim [° el.]", *AIM_RANGE_DEG, 1.0,
                                          AIM_DEG, ".0f", "aim"),
        "max_stages": ControlSpec("stage budget", 2, 127, 1, 127, "d", "table"),
    }


def settings_from(values: dict[str, Any]) -> Settings:
    """`Settings` from the controls' values by field name (missing: the default)."""
    kinds = {f.name: f.type for f in dataclasses.fields(Settings)}
    out: dict[str, Any] = {}
    for key, value in values.items():
        kind = str(kinds[key])
        out[key] = (int(value) if kind == "int" else bool(value) if kind == "bool"
                    else str(value) if kind == "str" else float(value))
    return Settings(**out)


@dataclass
class Design:
    """One recomputation: the plan, its execution, the exact optimum, the stall margins,
    the load angle, and how long each part took (`timings_ms`)."""

    settings: Settings
    motor: Motor
    plan: Plan
    execution: Execution
    exact: Any                     # verify.references.Reference
    margins: dict[str, Any]
    physics: Any                   # verify.load_angle.LoadAngleTrace or None
    verdict: Any = None            # verify.safety.SafetyVerdict over every move, or None
    timings_ms: dict[str, float] = field(default_factory=dict)
    # False: a first table (the plain criterion's), shown while the final one is planned
    final: bool = True
    # the commands `verdict` judged: PLANNED_COMMANDS (the moves and decel stops the
    # tightening judged, while the others are judged) or None (every command)
    judged: tuple[str, ...] | None = None

    @property
    def complete(self) -> bool:
        """The final table with its whole verdict (what may be written or downloaded)."""
        return self.final and (self.verdict is None or self.judged is None)

    @property
    def units(self) -> Any:
        """The axis's real units (`profiles.motor.travel.AxisUnits`): mm where the motor
        file states its travel per revolution, else rev and rpm."""
        from profiles.motor.travel import axis_units

        return axis_units(self.motor)

    @property
    def ratio(self) -> float:
        return float(self.execution.duration_s / self.exact.duration_s)

    def summary(self) -> str:
        from verify.plot import pps

        table = self.plan.table
        lines = [] if self.final else [
            f"{TIGHTENING} a first table (the stall criterion alone, not judged for the "
            "load angle): not safe to use; the final table follows"]
        u = self.units
        top = float(self.execution.edges()[2].max())  # the move's top speed [pps]
        lines += [
            f"{self.motor.name or 'motor'}: {self.settings.pulses} pulses "
            f"({u.distance_text(self.settings.pulses)}), {len(table.rates)} stages, clock "
            f"{table.clock.name}, LE={int(table.separate)}",
            f"top speed {pps(top, u)}; {u.describe()}",
            f"move {self.execution.duration_s * 1e3:.3f} ms; exact optimum "
            f"{self.exact.duration_s * 1e3:.3f} ms; ratio {self.ratio:.4f}",
            f"smallest stall margin {self.margins['min']:.3f} (≥ 1 is stall-safe)",
        ]
        if self.physics is not None:
            lines.append(f"this move's load angle: worst {self.physics.worst_angle_deg:+.1f}° "
                         f"electrical (peak 90°, pole slip 180°): {physics_verdict(self.physics)}")
        lines.append(f"verdict: {verdict(self).text}")
        total = sum(self.timings_ms.values())
        lines.append(f"recomputed in {total:.0f} ms ("
                     + ", ".join(f"{k} {v:.0f}" for k, v in self.timings_ms.items()) + ")")
        return "\n".join(lines)


@dataclass(frozen=True)
class DesignVerdict:
    """What the designer says of one design: `level` "safe", "past-aim" (stable, but the
    load angle is past the aim) or "unsafe"; `text` one line saying why."""

    level: str     # "safe", "past-aim", "unsafe" or "tightening" (a first table)
    text: str

    @property
    def safe(self) -> bool:
        return self.level in ("safe", "past-aim")


def verdict(result: Design) -> DesignVerdict:
    """The verdict on `result`: the one safety verdict (`verify.safety.judge_safety`) over
    every move the table can run, as `stepramp check --motor` gives it. Every view shows
    this one function's answer."""
    v = result.verdict
    if result.final and not result.complete:
        said = verdict(dataclasses.replace(result, judged=None))
        return DesignVerdict(said.level, f"{said.text}; {JUDGING}")
    if not result.final:
        return DesignVerdict("tightening", f"{TIGHTENING} a first table by the stall criterion "
                                     "alone, not yet judged for the load angle: wait for the "
                                     "final table")
    if v is None:
        if result.margins["min"] < 1:
            return DesignVerdict("unsafe", f"UNSAFE: stall margin {result.margins['min']:.3f} < 1")
        return DesignVerdict("safe", "safe by the stall criterion (load angle not judged)")
    la = v.load_angle
    worst = "" if la is None else (f"worst load angle {la.worst_deg:.1f}° el. on a move of "
                                   f"{la.worst_pulses} pulses")
    if not v.safe:
        return DesignVerdict("unsafe", f"UNSAFE ({', '.join(v.failed)}): {worst} "
                                 f"(peak {PEAK_DEG:g}°)".replace(":  (", ": ("))
    if not v.within_aim:
        return DesignVerdict("past-aim", f"PAST THE AIM: {worst} > aim {v.aim_deg:g}° "
                                   f"(stable below {PEAK_DEG:g}°)")
    return DesignVerdict("safe", f"SAFE over every move: {worst} ≤ aim {v.aim_deg:g}°")


def loaded_motor(motor: Motor, settings: Settings) -> Motor:
    """`motor` with the settings' safety factor, extra inertia, load torque and friction."""
    if not 0 <= settings.load_inertia_kgm2 <= 1e3:
        raise FieldRangeError("load_inertia_kgm2", settings.load_inertia_kgm2, 0, 1e3)
    load = motor.load_torque_nm if settings.load_torque_nm is None else settings.load_torque_nm
    friction = (motor.friction_torque_nm if settings.friction_torque_nm is None
                else settings.friction_torque_nm)
    # a slider sets its value exactly: the file's range for it (`motor new` writes one for
    # assumed friction) no longer applies, and would refuse a value outside it
    slid = {name for name, value in (("load_torque_nm", settings.load_torque_nm),
                                     ("friction_torque_nm", settings.friction_torque_nm))
            if value is not None}
    return dataclasses.replace(
        motor, safety_factor=settings.safety_factor,
        inertia_kgm2=motor.inertia_kgm2 + settings.load_inertia_kgm2, load_torque_nm=load,
        friction_torque_nm=friction,
        tolerances=tuple(t for t in motor.tolerances if t[0] not in slid))


def design(motor: Motor, settings: Settings, *, load_angle: bool = True) -> Design:
    """Plan and judge one setting: the final table of a change (tightened to the aim when
    `settings.plan_to_aim`, as `stepramp plan` plans it) and its verdict."""
    return _designed(motor, settings, tighten=settings.plan_to_aim, judge=load_angle)


def first_design(motor: Motor, settings: Settings) -> Design:
    """The first table a change shows: the plain stall criterion's plan (the one the
    tightening starts from, so the final design finds it remembered), its execution,
    margins and exact optimum; not tightened, the load angle not judged: `final` False."""
    return _designed(motor, settings, tighten=False, judge=False, final=False)


def design_steps(motor: Motor, settings: Settings, *, load_angle: bool = True
                 ) -> Iterator[Design]:
    """What one change shows, in order: the first table (`first_design`, marked as being
    tightened); the final table judged for the moves and decel stops the tightening
    planned for (remembered: a few milliseconds), its verdict saying the other commands
    are being judged; the same table with the verdict over every command (`design`'s).
    Steps that would add nothing are left out (no aim and no load angle: one step)."""
    if not (settings.plan_to_aim or load_angle):
        yield design(motor, settings, load_angle=False)
        return
    yield first_design(motor, settings)
    if not load_angle:
        yield design(motor, settings, load_angle=False)
        return
    final = _designed(motor, settings, tighten=settings.plan_to_aim, judge=True,
                      commands=PLANNED_COMMANDS)
    yield final
    yield judged_in_full(final)


def judged_in_full(result: Design) -> Design:
    """`result` (a final table) with the verdict over every motion command."""
    from profiles.motor.reserve import parse_cruise_reserve
    from verify.safety import judge_safety

    t0 = time.perf_counter()
    settings = result.settings
    planned = parse_cruise_reserve(settings.cruise_reserve).applied(result.motor)
    every = judge_safety(result.plan.table, planned, aim_deg=settings.load_angle_aim_deg)
    timings = {**result.timings_ms, "commands": (time.perf_counter() - t0) * 1e3}
    return dataclasses.replace(result, verdict=every, judged=None, timings_ms=timings)


def _designed(motor: Motor, settings: Settings, *, tighten: bool, judge: bool,
              final: bool = True, commands: tuple[str, ...] | None = None) -> Design:
    from profiles.motor.reserve import parse_cruise_reserve
    from verify.criterion import stall_margins
    from verify.references import exact_optimum

    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    loaded = loaded_motor(motor, settings)
    reserve = parse_cruise_reserve(settings.cruise_reserve)
    clock = None if settings.clock == AUTO_CLOCK else Clock.internal(settings.clock)
    lo, hi = AIM_RANGE_DEG
    if not lo <= settings.load_angle_aim_deg <= hi:
        raise FieldRangeError("load_angle_aim_deg", settings.load_angle_aim_deg, lo, hi)
    # planned to the reserve's top speed (the load sliders move it)
    planned = reserve.applied(loaded)
    plan = plan_free_curve(planned, clock=clock, max_stages=settings.max_stages,
                           pulses=settings.pulses, load_angle_deg=(
                               settings.load_angle_aim_deg if tighten else None))
    execution = simulate_move(plan.table, settings.pulses)
    t1 = time.perf_counter()
    exact = exact_optimum(loaded, settings.pulses)
    t2 = time.perf_counter()
    margins = stall_margins(plan.table, loaded)
    t3 = time.perf_counter()
    physics = verdict = None
    if judge:
        from verify.load_angle import trace_load_angle
        from verify.safety import judge_safety

        # T_L > 0 opposes forward motion: follow the direction the load hinders.
        physics = trace_load_angle(execution, loaded,
                                   direction=-1 if loaded.load_torque_nm < 0 else 1)
        # judged on the motor as planned: its top speed capped for the reserve is all that
        # differs from the loaded motor (no judge reads it but the criterion's top-speed
        # rule, which a table planned under the cap passes either way), and the moves and
        # decel stops the tightening judged are remembered under it
        verdict = judge_safety(plan.table, planned, aim_deg=settings.load_angle_aim_deg,
                               commands=commands)
    t4 = time.perf_counter()
    timings.update(plan=(t1 - t0) * 1e3, exact=(t2 - t1) * 1e3, margins=(t3 - t2) * 1e3,
                   load_angle=(t4 - t3) * 1e3)
    return Design(settings, loaded, plan, execution, exact, margins, physics, verdict, timings,
                  final, commands if judge else None)


def design_files(result: Design, stem: str,
                 upload_formats: Sequence[str] = ("hex", "bin", "c")) -> list[tuple[str, bytes]]:
    """The table (`stepramp.table/1` JSON) and its upload files, as (file name, bytes):
    what the notebook writes and the web page offers for download."""
    from profiles.ppmc312 import encode_table
    from profiles.ppmc312.formats import FORMATS, render
    from profiles.ppmc312.table import dump_table

    blocks = encode_table(result.plan.table)
    files = [(f"{stem}.table.json", dump_table(result.plan.table).encode())]
    for fmt in upload_formats:
        suffix = FORMATS.get(fmt).extensions[0]
        files.append((f"{stem}.upload{suffix}", render(blocks, fmt)))
    return files


def design_stem(motor_name: str, result: Design) -> str:
    """The file-name stem of a design: `design-<motor>-<pulses>`."""
    return f"design-{_slug(motor_name)}-{result.settings.pulses}"


def write_design(result: Design, out_dir: str | Path, stem: str) -> list[Path]:
    """The table (JSON) and its upload files (hex, bin, C header): all written, or none."""
    from verify.output import write_outputs

    files = [(Path(out_dir) / name, data) for name, data in design_files(result, stem)]
    write_outputs([(str(path), data) for path, data in files])
    return [path for path, _ in files]


def bundled_motors() -> dict[str, Motor]:
    """The shipped motors by file stem (the picker's choices)."""
    return {path.stem.removeprefix("motor-"): load_motor(path) for path in bundled_motor_paths()}


def _torque_span(motor: Motor) -> float:
    """Load torque slider range: up to half the usable torque at standstill."""
    return float(0.5 * motor.safety_factor * motor.torque_nm(0.0))


def physics_verdict(physics: Any) -> str:
    """One word on a traced move's load angle (`verify.load_angle.LoadAngleTrace`)."""
    if physics.slipped:
        return "SLIPS A POLE"
    return "stable" if physics.stable else "UNSTABLE (past the 90° peak)"


def _slug(name: str) -> str:
    """A file-name-safe form of a motor's name."""
    import re

    return re.sub(r"[^A-Za-z0-9.]+", "-", name).strip("-") or "motor"


