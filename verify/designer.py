"""Interactive free-curve design in a notebook: `designer(motor)`.

Sliders set the move, the load and the aim (move length, load inertia, load
torque, friction, safety factor, load-angle aim, clock, stage budget) and a
picker the motor; every change replans the table (`plan_free_curve`) and
redraws, in one figure, the staircase the chip runs against the exact
continuous optimum, the stall margin of every stage and the rotor's load angle
(`verify.load_angle.trace_load_angle`), with the verdict over every move the table
can run (`verify.safety.judge_safety`, read by `verdict`). The slow
references (toppra, ruckig, casadi) are solved on a button; another button
writes the table and its upload files.

The computation (`design`, `verdict`, `design_files`) and the controls' ranges
(`control_specs`) are separate from the widgets: the notebook widget here and
the web page of `stepramp design` (verify/webdesigner.py) are two views of them,
and a bench times them (bench/bench_designer.py). Widgets (ipywidgets) and
matplotlib are imported only when a designer is built.

A change is shown in three steps (`design_steps`): first the plain stall criterion's
table (`first_design`: the plan the tightening starts from anyway, with its margins and
the exact optimum; no load angle judged), marked as being tightened (`Design.final`
False, the verdict "tightening", TIGHTENING in the figure's title and a mark) and never
offered; then the final table, tightened to the load-angle aim (the same table
`stepramp plan` gives for those inputs) and judged for moves and decel stops (the
tightening's verdicts, remembered); then its verdict over every motion command
(`judged_in_full`, what `design` returns; `Design.complete`: only such a design is
written or downloaded). The figure keeps its axes and draws a design that fits them
over a kept background (`DesignFigure.update`: only the data and the texts), so a step
shows in a few tens of milliseconds; bench/bench_designer.py times the steps against
the budget (first ≤ 50 ms, final ≤ 150 ms, issue #32 item 9). Lengths and speeds are
also given in mm and mm/s (rev, rpm on a rotary axis): `profiles.motor.travel`.

The load torque slider sets the motor's `load_torque_nm` (signed: > 0 opposes
forward motion); the load angle is followed in the direction the load opposes
(forward when it is zero).
"""

from __future__ import annotations

import dataclasses
import io
import math
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from profiles.compiling import announce
from profiles.errors import FieldRangeError, StepRampError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.motor.angles import AIM_DEG, PEAK_DEG
from profiles.ppmc312.clock import INTERNAL_HZ, Clock
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
                         f"electrical (peak 90°, pole slip 180°): {_verdict(self.physics)}")
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


# --- the figure ----------------------------------------------------------------------------
class DesignFigure:
    """One figure kept across changes (its lines are updated, never rebuilt, and the layout
    is fixed: redrawing is what a slider change costs): speed against time (staircase,
    exact, any slow references), stall margin per stage, load angle against time.

    The data lines and the titles are drawn over a kept background (the axes, ticks, grid
    and legend of the last full drawing): a design that fits the axes as they are is
    drawn over it alone (`last_drawing` "over"), in a few milliseconds; one that does not
    gets new limits, rounded up so that the next changes fit, and only the panels whose
    limits moved are drawn again ("panels"); a change of the references shown or of the
    units draws everything ("full"). A first table (`Design.final` False) is drawn dashed
    and marked as being tightened."""

    MAX_POINTS = 1500  # the lag trace is drawn as a min/max envelope of this many bins

    def __init__(self, *, dpi: int = 72) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.dpi = dpi
        self.fig = Figure(figsize=(9.0, 7.5), dpi=dpi)
        self.canvas = FigureCanvasAgg(self.fig)
        # room on the right for the speed's second scale in real units
        self.fig.subplots_adjust(left=0.09, right=0.91, top=0.96, bottom=0.07, hspace=0.55)
        self.ax_v, self.ax_m, self.ax_l = self.fig.subplots(3, 1, height_ratios=[3, 2, 2])
        self.ax_v.set(xlabel="time [ms]", ylabel="speed [pps]")
        self.ax_m.set(xlabel="stage (0 = fastest)", ylabel="stall margin")
        self.ax_m.set_yscale("log")
        from matplotlib.ticker import FuncFormatter, LogLocator, NullLocator

        # Plain numbers (1, 2, 5 …) read better than 10^0 on a margin axis.
        self.ax_m.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        self.ax_m.yaxis.set_minor_locator(NullLocator())
        self.ax_m.yaxis.set_major_formatter(FuncFormatter(lambda y, _pos: f"{y:g}"))
        self.ax_m.axhline(1.0, color="k", lw=1, ls="--", label="stall limit")
        self.ax_l.set(xlabel="time [ms]", ylabel="load angle [° el.]")
        for sign in (1, -1):
            self.ax_l.axhline(90 * sign, color="k", lw=1, ls="--")
        for ax in (self.ax_v, self.ax_m, self.ax_l):
            ax.grid(alpha=0.3)
        self.table_line, = self.ax_v.step([], [], where="post", color="tab:red", lw=1.5)
        self.ref_lines: dict[str, Any] = {}
        self.margin_lines = {
            side: self.ax_m.plot([], [], marker=marker, ls="none", ms=3, color=color,
                                 label=side)[0]
            for side, marker, color in (("accel", "o", "tab:red"),
                                        ("decel", "s", "tab:orange"))}
        self.ax_m.legend(fontsize=7, ncols=3, loc="upper left")
        self.lag_line, = self.ax_l.plot([], [], color="tab:blue", lw=1.0)
        # a first table's mark, over the speed panel
        self.mark = self.ax_v.text(0.99, 0.04, "", transform=self.ax_v.transAxes, ha="right",
                                   va="bottom", fontsize=10, fontweight="bold", color="white",
                                   bbox={"facecolor": "#b36b00", "edgecolor": "none",
                                         "pad": 3})
        for artist in self._live():
            artist.set_animated(True)  # left out of the background, drawn over it
        self.background: Any = None   # the canvas without the live artists, once drawn
        self.drawn_refs: tuple[str, ...] = ()  # the references the legend names
        self.shown: tuple[Any, ...] = ()        # what the last PNG shows
        self.units: Any = None                  # the real units the second scale shows
        self.png = b""
        self.last_drawing = ""        # "full" or "over" (a first table over the background)

    def update(self, result: Design, slow: dict[str, Any] | None = None) -> bytes:
        """Show `result` (and `slow` references); the PNG (the last one again when only the
        verdict differs from what it shows, as when the other commands' verdicts come)."""
        shown = (result.plan, result.physics, result.exact, result.final,
                 *sorted((slow or {}).items()))
        if len(shown) == len(self.shown) and all(a is b for a, b in zip(shown, self.shown,
                                                                         strict=True)):
            return self.png
        self.shown = shown
        self._set_units(result.units)
        self._set_lines(result, slow)
        refs = tuple(self.ref_lines)
        kept = self.background is not None and refs == self.drawn_refs
        if kept and self._fits(result):
            self.canvas.restore_region(self.background)
            self.last_drawing = "over"
        else:
            limits = self._limits(result)
            changed = [ax for ax, lim in limits.items() if lim != (ax.get_xlim(), ax.get_ylim())]
            for ax, (xlim, ylim) in limits.items():
                ax.set_xlim(*xlim)
                ax.set_ylim(*ylim)
            if kept:
                self._redraw(changed)  # only the panels whose limits moved (if any)
                self.last_drawing = "panels" if changed else "over"
            else:
                legend = self.ax_v.legend(loc="upper center", ncols=4, fontsize=7)
                legend.legend_handles[0].set_linestyle("-")  # the table's, dashed or not
                self.drawn_refs = refs
                self.canvas.draw()  # everything but the live artists
                self.last_drawing = "full"
            self.background = self.canvas.copy_from_bbox(self.fig.bbox)
        for artist in self._live():
            self.fig.draw_artist(artist)
        self.png = self._png()
        return self.png

    def _redraw(self, panels: list[Any]) -> None:
        """The kept background with `panels` (axes, ticks, labels, grid) drawn again."""
        from matplotlib.patches import Rectangle
        from matplotlib.transforms import IdentityTransform

        self.canvas.restore_region(self.background)
        renderer = self.canvas.get_renderer()
        for ax in panels:
            box = ax.get_tightbbox(renderer)
            blank = Rectangle((box.x0 - 2, box.y0 - 2), box.width + 4, box.height + 4,
                              transform=IdentityTransform(), facecolor=self.fig.get_facecolor(),
                              edgecolor="none")
            blank.set_figure(self.fig)
            blank.draw(renderer)
            self.fig.draw_artist(ax)

    def _set_units(self, units: Any) -> None:
        """The speed panel's second scale in mm/s (rpm on a rotary axis), set again (and
        the figure drawn in full) when another motor's units come."""
        from verify.plot import real_axis

        if units == self.units:
            return
        for child in list(self.ax_v.child_axes):
            child.remove()
        real_axis(self.ax_v, units, "speed", "right")
        self.units, self.background = units, None

    def _live(self) -> list[Any]:
        """The artists every change draws again (animated: the background leaves them out)."""
        return [self.table_line, *self.ref_lines.values(), *self.margin_lines.values(),
                self.lag_line, self.ax_v.title, self.ax_m.title, self.ax_l.title, self.mark]

    def _set_lines(self, result: Design, slow: dict[str, Any] | None) -> None:
        import numpy as np

        final = result.final
        t, _, v = result.execution.edges()
        self.table_line.set_data(t * 1e3, v)
        self.table_line.set_linestyle("-" if final else "--")
        self.table_line.set_label("table")
        refs = {"exact": result.exact, **(slow or {})}
        for name in list(self.ref_lines):
            if name not in refs:
                self.ref_lines.pop(name).remove()
        for name, ref in refs.items():
            if name not in self.ref_lines:
                self.ref_lines[name], = self.ax_v.plot([], [], animated=True,
                                                       **_reference_style(name))
            line = self.ref_lines[name]
            line.set_data(ref.t_s * 1e3, ref.v_pps)
            line.set_label(name if name == "exact" else
                           f"{name} ({ref.duration_s * 1e3:.2f} ms)")  # drawn in full
        self.ax_v.set_title(("" if final else f"{TIGHTENING} ")
                            + f"{result.settings.pulses} pulses "
                            f"({result.units.distance_text(result.settings.pulses)}): table "
                            f"({len(result.plan.table.rates)} stages) "
                            f"{result.execution.duration_s * 1e3:.2f} ms / exact "
                            f"{result.exact.duration_s * 1e3:.2f} ms = {result.ratio:.3f}",
                            fontsize=10, color="k" if final else "#b36b00")
        self.mark.set_text("" if final else f"{TIGHTENING} first table, not judged: "
                                             "not safe to use")
        self.mark.set_visible(not final)
        for side, line in self.margin_lines.items():
            m = np.asarray(result.margins[side], float)
            line.set_data(np.arange(len(m)), np.where(np.isfinite(m), m, np.nan))
        self.ax_m.set_title(f"stall margin per stage: smallest {result.margins['min']:.3f}",
                            fontsize=10)
        ph = result.physics
        if ph is not None:
            self.lag_line.set_data(*_envelope(ph.lag_t_s * 1e3, ph.angle_deg, self.MAX_POINTS))
            self.ax_l.set_title(f"load angle: worst {ph.worst_angle_deg:+.1f}° (peak ±90°): "
                                f"{_verdict(ph)}", fontsize=10)
        else:
            self.lag_line.set_data([], [])
            self.ax_l.set_title("load angle: judged once tightened …" if not final
                                else "load angle: off", fontsize=10)

    def _targets(self, result: Design) -> dict[str, float]:
        """The extents the data needs: speed panel (time, speed), margins (stages, range),
        load angle (time, angle); after `_set_lines`."""
        import numpy as np

        t, _, v = result.execution.edges()
        top_ms = max(float(t[-1]), float(result.exact.t_s[-1])) * 1e3
        finite = np.concatenate([np.asarray(result.margins[side], float)
                                 for side in self.margin_lines])
        finite = finite[np.isfinite(finite)]
        # the trace as drawn (`_set_lines` set it; empty for a first table)
        lag_t, lag = self.lag_line.get_xdata(), self.lag_line.get_ydata()
        lag_ms = float(lag_t[-1]) if len(lag_t) else 0.0
        angle = float(np.max(np.abs(lag))) if len(lag) else 0.0
        return {"t_ms": 1.02 * top_ms, "v_pps": 1.3 * float(np.max(v)), "lag_ms": lag_ms,
                "angle_deg": 1.1 * angle,
                "stages": float(result.settings.max_stages),  # the budget: steady
                "m_lo": float(finite.min()) if finite.size else 1.0,
                "m_hi": float(finite.max()) if finite.size else 1.0}

    def _fits(self, result: Design) -> bool:
        """Whether a first table is drawn fairly by the axes as they are: inside them, and
        using at least half of the speed panel's time and speed."""
        need = self._targets(result)
        t_hi, v_hi = self.ax_v.get_xlim()[1], self.ax_v.get_ylim()[1]
        m_lo, m_hi = self.ax_m.get_ylim()
        l_hi, span = self.ax_l.get_xlim()[1], self.ax_l.get_ylim()[1]

        def fills(x: float, hi: float) -> bool:
            return 0.5 * hi <= x <= hi

        return (fills(need["t_ms"], t_hi) and fills(need["v_pps"], v_hi)
                and need["stages"] < self.ax_m.get_xlim()[1]
                and m_lo <= need["m_lo"] and need["m_hi"] <= m_hi
                and (need["lag_ms"] == 0 or fills(need["lag_ms"], l_hi))
                and (fills(need["angle_deg"], span) or need["angle_deg"] <= span
                     <= ANGLE_SPAN_DEG))

    def _limits(self, result: Design
                ) -> dict[Any, tuple[tuple[float, float], tuple[float, float]]]:
        """Each panel's (x, y) limits for `result`, rounded up with room to spare."""
        need = self._targets(result)
        slow_end = max((float(line.get_xdata()[-1]) for line in self.ref_lines.values()
                        if len(line.get_xdata())), default=0.0)
        # room for a longer move: the next change's first table fits without a full drawing
        limits = {
            self.ax_v: ((0.0, _rounded_up(1.2 * max(need["t_ms"], 1.02 * slow_end))),
                        (0.0, _rounded_up(need["v_pps"]))),
            self.ax_m: ((-1.0, need["stages"] + 1),
                        (min(0.8, 0.8 * need["m_lo"]), _rounded_up(max(2.0, 1.5 * need["m_hi"]))))}
        if need["lag_ms"] > 0:  # a first table has no trace: the last one's axes stay
            span = max(ANGLE_SPAN_DEG, _rounded_up(need["angle_deg"]))
            limits[self.ax_l] = ((0.0, _rounded_up(1.2 * need["lag_ms"])), (-span, span))
        return limits

    def _png(self) -> bytes:
        from PIL import Image

        renderer = self.canvas.get_renderer()
        size = (int(renderer.width), int(renderer.height))
        image = Image.frombuffer("RGBA", size, self.canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
        buf = io.BytesIO()
        image.save(buf, format="png", compress_level=1)  # the fast end: a PNG a change
        return buf.getvalue()


ANGLE_SPAN_DEG = 100.0  # the load-angle panel shows at least ±100° (the ±90° peak drawn)


def _reference_style(name: str) -> dict[str, Any]:
    """A reference line's look from verify.plot's styles (a (color, ls) pair or keywords)."""
    from verify.plot import REFERENCE_STYLE

    style: Any = REFERENCE_STYLE.get(name, ("k", "-"))
    if isinstance(style, dict):
        return {"lw": 1.1, **style}
    color, ls = style
    return {"color": color, "ls": ls, "lw": 1.1}


def _rounded_up(x: float) -> float:
    """The first of 1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8 × 10^k at or above `x` (> 0)."""
    if not x > 0:
        return 1.0
    scale = 10.0 ** math.floor(math.log10(x))
    return next(m * scale for m in (1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10)
                if m * scale >= x * (1 - 1e-12))


def _envelope(t: Any, y: Any, bins: int) -> tuple[Any, Any]:
    """At most 2·bins points keeping each bin's min and max (the peaks survive)."""
    import numpy as np

    n = len(t)
    if n <= 2 * bins:
        return t, y
    edges = np.linspace(0, n, bins + 1).astype(int)
    lo = np.minimum.reduceat(y, edges[:-1])
    hi = np.maximum.reduceat(y, edges[:-1])
    tt = np.repeat(t[edges[:-1]], 2)
    yy = np.column_stack([lo, hi]).ravel()
    return tt, yy


def render_figure(result: Design, slow: dict[str, Any] | None = None) -> bytes:
    """PNG of one design (a fresh `DesignFigure`)."""
    return DesignFigure().update(result, slow)


# --- the widget -------------------------------------------------------------------------------
def bundled_motors() -> dict[str, Motor]:
    """The shipped motors by file stem (the picker's choices)."""
    return {path.stem.removeprefix("motor-"): load_motor(path) for path in bundled_motor_paths()}


class Designer:
    """The widget: `controls` (sliders and pickers by name), `buttons`, `image` (the figure
    PNG), `summary`, `status`; `result` is the latest `Design`. Display it in a notebook
    (it shows its widget); setting a control from code recomputes as dragging it does."""

    def __init__(self, motor: Motor | None = None, *, pulses: int = OPENING_PULSES,
                 out_dir: str | Path = ".", motors: dict[str, Motor] | None = None,
                 load_angle: bool = True) -> None:
        try:
            import ipywidgets as w
        except ImportError:
            raise StepRampError("the designer needs ipywidgets: pip install "
                                "'stepramp[notebook]'") from None

        self.motors = dict(motors) if motors is not None else bundled_motors()
        if motor is not None:
            same = motor.to_json()
            name = next((k for k, m in self.motors.items() if m.to_json() == same), None)
            if name is None:
                name = motor.name or "motor"
                self.motors = {name: motor, **self.motors}
            self.motors[name] = motor
        else:
            name = next(iter(self.motors))
        # a machine's first design compiles the kernels: say so in the cell's output
        announce(lambda line: print(f"stepramp designer: {line}", flush=True))
        self.out_dir = Path(out_dir)
        self.load_angle = load_angle
        self.result: Design | None = None
        self.slow: dict[str, Any] = {}
        self.written: list[Path] = []
        self.draw_ms = 0.0
        self._held = False
        self._figure: DesignFigure | None = None
        base = self.motors[name]
        self.controls: dict[str, Any] = _widgets(w, list(self.motors), name,
                                                 control_specs(base, pulses))
        self.buttons: dict[str, Any] = {
            "references": w.Button(description="solve toppra, ruckig, casadi",
                                   layout=w.Layout(width="17em")),
            "write": w.Button(description="write table + upload files",
                              layout=w.Layout(width="17em")),
        }
        self.image = w.Image(format="png")
        self.summary = w.HTML()
        self.status = w.HTML()
        self.controls["motor"].observe(self._motor_changed, names="value")
        for key, control in self.controls.items():
            if key != "motor":
                control.observe(lambda _change: self.recompute(), names="value")
        self.buttons["references"].on_click(lambda _b: self.solve_references())
        self.buttons["write"].on_click(lambda _b: self.write())
        self.widget = w.HBox([
            w.VBox([*self.controls.values(), w.HBox(list(self.buttons.values())),
                    self.summary, self.status]),
            self.image])
        self.recompute()

    # --- actions ---------------------------------------------------------------------------
    @property
    def settings(self) -> Settings:
        return settings_from({k: c.value for k, c in self.controls.items() if k != "motor"})

    @property
    def motor(self) -> Motor:
        return self.motors[self.controls["motor"].value]

    def recompute(self) -> None:
        """Replan and redraw for the controls' current values (slow references dropped)."""
        if self._held:
            return
        self.slow = {}
        last = self.result
        try:
            for result in design_steps(self.motor, self.settings, load_angle=self.load_angle):
                self.result = result  # the first table, then the final one, each shown
                self._show()
                if not result.final:
                    self._say(f"{TIGHTENING} the first table (the stall criterion alone) is "
                              "shown; the final table follows")
                elif not result.complete:
                    self._say(f"the final table: {JUDGING}")
        except StepRampError as e:
            if self.result is not last and last is not None:
                self.result = last  # a first table whose final has none: the last design
                self._show()
            self._say(f"no table for these settings: {e}", error=True)
            return
        self._say("slow references: press “solve toppra, ruckig, casadi”")

    def solve_references(self) -> None:
        """toppra, ruckig and casadi on the current move (seconds, not milliseconds)."""
        from verify.references import references

        if self.result is None:
            return
        self._say("solving toppra, ruckig, casadi …")
        refs = references(self.result.motor, self.result.settings.pulses,
                          include=SLOW_REFERENCES)
        self.slow = {k: r for k, r in refs.items() if k != "exact"}
        self._show()
        self._say("references: " + ", ".join(
            f"{k} {r.duration_s * 1e3:.2f} ms" for k, r in self.slow.items()))

    def write(self) -> list[Path]:
        """Write the current table and its upload files into `out_dir`."""
        if self.result is None or not self.result.complete:
            return []  # a table not judged in full is never written
        stem = design_stem(self.controls["motor"].value, self.result)
        try:
            self.written = write_design(self.result, self.out_dir, stem)
        except StepRampError as e:
            self._say(str(e), error=True)
            return []
        self._say("wrote " + ", ".join(str(p) for p in self.written))
        return self.written

    # --- display ---------------------------------------------------------------------------
    def _motor_changed(self, change: dict[str, Any]) -> None:
        specs = control_specs(self.motor, int(self.controls["pulses"].value))
        # One recompute for the whole motor switch, not one per slider it resets.
        self._held = True
        try:
            for key in MOTOR_SPECIFIC:
                control, spec = self.controls[key], specs[key]
                # widen first: ipywidgets clamps the value to the range it has
                control.min, control.max = min(control.min, spec.lo), max(control.max, spec.hi)
                control.value = spec.value
                control.min, control.max, control.step = spec.lo, spec.hi, spec.step
        finally:
            self._held = False
        self.recompute()

    def _show(self) -> None:
        assert self.result is not None
        t0 = time.perf_counter()
        if self._figure is None:
            self._figure = DesignFigure()
        self.image.value = self._figure.update(self.result, self.slow)
        self.draw_ms = (time.perf_counter() - t0) * 1e3
        text = self.result.summary() + f"\nfigure drawn in {self.draw_ms:.0f} ms"
        self.summary.value = "<pre style='line-height:1.3'>" + _escape(text) + "</pre>"

    def _say(self, text: str, *, error: bool = False) -> None:
        color = "#b00" if error else "#444"
        self.status.value = f"<span style='color:{color}'>{_escape(text)}</span>"

    def snapshot(self) -> Any:
        """A static copy (figure and summary) for viewers without a live kernel."""
        import base64

        from IPython.display import HTML

        png = base64.b64encode(self.image.value).decode("ascii")
        return HTML(f"<div class='stepramp-designer-snapshot'>{self.summary.value}"
                    f"<img alt='designer figure' src='data:image/png;base64,{png}'/></div>")

    def _repr_mimebundle_(self, **kwargs: Any) -> Any:
        return self.widget._repr_mimebundle_(**kwargs)


def _widgets(w: Any, motors: list[str], motor: str, specs: dict[str, ControlSpec]
             ) -> dict[str, Any]:
    """The notebook's controls: the motor picker, a slider per spec, clock, plan-to-aim."""
    style = {"description_width": "11em"}
    layout = w.Layout(width="34em")
    controls: dict[str, Any] = {"motor": w.Dropdown(options=motors, value=motor,
                                                    description="motor", style=style,
                                                    layout=layout)}
    for key, spec in specs.items():
        cls = w.IntSlider if spec.integer else w.FloatSlider
        controls[key] = cls(value=spec.value, min=spec.lo, max=spec.hi, step=spec.step,
                            description=spec.label, readout_format=spec.fmt,
                            continuous_update=False, style=style, layout=layout)
    controls["clock"] = w.Dropdown(options=[AUTO_CLOCK, *INTERNAL_HZ], value=AUTO_CLOCK,
                                   description="clock", style=style, layout=layout)
    controls["plan_to_aim"] = w.Checkbox(value=True, description="plan to the aim",
                                         style=style, layout=layout)
    return controls


def designer(motor: Motor | None = None, **kw: Any) -> Designer:
    """The interactive designer for `motor` (default: the first bundled motor)."""
    return Designer(motor, **kw)


def _torque_span(motor: Motor) -> float:
    """Load torque slider range: up to half the usable torque at standstill."""
    return float(0.5 * motor.safety_factor * motor.torque_nm(0.0))


def _verdict(physics: Any) -> str:
    if physics.slipped:
        return "SLIPS A POLE"
    return "stable" if physics.stable else "UNSTABLE (past the 90° peak)"


def _slug(name: str) -> str:
    """A file-name-safe form of a motor's name."""
    import re

    return re.sub(r"[^A-Za-z0-9.]+", "-", name).strip("-") or "motor"


def _escape(text: str) -> str:
    import html

    return html.escape(text)


__all__: Sequence[str] = (
    "TIGHTENING", "ControlSpec", "Design", "DesignFigure", "DesignVerdict", "Designer",
    "Settings", "control_specs", "design", "design_files", "design_stem", "design_steps",
    "designer", "first_design", "judged_in_full", "loaded_motor", "render_figure",
    "settings_from", "verdict", "write_design")
