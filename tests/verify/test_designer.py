"""The interactive designer (verify/designer.py): its controls in-process, its notebook
driven from Python in an executed kernel, and a screenshot of the rendered notebook
in headless Chromium."""

from __future__ import annotations

import itertools
import json
import os
import shutil
import subprocess
from dataclasses import replace as dataclasses_replace
from pathlib import Path
from typing import Any

import ipywidgets  # noqa: F401  (a [dev] dependency: missing, the suite fails)
import numpy as np
import pytest

from profiles.errors import StepRampError
from profiles.motor import bundled_motor_paths, load_motor
from profiles.motor.reserve import parse_cruise_reserve
from profiles.ppmc312 import decode_upload
from profiles.ppmc312.formats import parse_upload
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import load_table
from tests.support.paths import ROOT
from tests.support.subprocess_env import checkout_env
from verify.designer import (
    JUDGING,
    TIGHTENING,
    Designer,
    DesignFigure,
    Settings,
    control_specs,
    design,
    design_steps,
    designer,
    first_design,
    loaded_motor,
    verdict,
)

NEMA17 = load_motor(next(p for p in bundled_motor_paths() if "nema17" in p.name))


@pytest.fixture
def d(tmp_path: Path) -> Designer:
    return designer(NEMA17, pulses=5_000, out_dir=tmp_path, load_angle=True)


def test_it_opens_on_the_given_motor_with_a_figure(d: Designer) -> None:
    assert d.motor is NEMA17 and d.result is not None
    assert d.image.value[:8] == b"\x89PNG\r\n\x1a\n"
    assert d.result.settings == Settings(pulses=5_000, safety_factor=NEMA17.safety_factor,
                                         load_torque_nm=NEMA17.load_torque_nm,
                                         friction_torque_nm=NEMA17.friction_torque_nm)
    assert "5000 pulses" in d.summary.value and "load angle" in d.summary.value


def test_the_figure_names_its_three_axes_and_marks_the_peak() -> None:
    """Speed against time, the stall margin per stage, the load angle against time with
    the ±90° peak drawn; each axis says its quantity and unit."""
    from verify.designer import DesignFigure

    fig = DesignFigure()
    labels = [(ax.get_xlabel(), ax.get_ylabel()) for ax in (fig.ax_v, fig.ax_m, fig.ax_l)]
    assert labels == [("time [ms]", "speed [pps]"), ("stage (0 = fastest)", "stall margin"),
                      ("time [ms]", "load angle [° el.]")]
    peaks = sorted(line.get_ydata()[0] for line in fig.ax_l.get_lines()
                   if line is not fig.lag_line)
    assert peaks == [-90, 90]


@pytest.mark.parametrize(("control", "value", "slower"), [
    ("safety_factor", 0.3, True),
    ("load_inertia_kgm2", 3 * NEMA17.inertia_kgm2, True),
    ("load_torque_nm", 0.05, True),
    ("pulses", 8_000, True),
    ("max_stages", 8, True),
])
def test_each_slider_replans_and_redraws(d: Designer, control: str, value: Any,
                                         slower: bool) -> None:
    before = d.result
    assert before is not None
    png, summary = d.image.value, d.summary.value
    d.controls[control].value = value
    after = d.result
    assert after is not before and after is not None
    assert d.image.value != png and d.summary.value != summary
    assert (after.execution.duration_s > before.execution.duration_s) == slower
    # The plan is the one for the loaded motor the settings describe.
    assert after.motor.to_json() == loaded_motor(NEMA17, after.settings).to_json()
    assert after.plan.table == design(NEMA17, after.settings).plan.table


def test_verdict_is_the_one_safety_verdict_over_every_move() -> None:
    from profiles.ppmc312.table import FreeCurveTable
    from verify.safety import judge_safety

    result = design(NEMA17, Settings(pulses=3_000))
    assert result.verdict is not None and result.physics is not None
    assert result.verdict.to_json() == judge_safety(
        result.plan.table, result.motor, aim_deg=result.settings.load_angle_aim_deg).to_json()
    assert result.verdict.moves is None  # every move the table can run, not only this one
    worst = result.verdict.load_angle.worst_deg  # type: ignore[union-attr]
    assert worst >= abs(result.physics.worst_angle_deg) - 0.1
    level = "safe" if worst <= result.settings.load_angle_aim_deg else "past-aim"
    assert verdict(result).level == level and verdict(result).safe

    tight = design(NEMA17, dataclasses_replace(result.settings, load_angle_aim_deg=worst - 1,
                                               plan_to_aim=False))
    assert verdict(tight).level == "past-aim" and verdict(tight).safe
    violent = FreeCurveTable(result.plan.table.clock, (200, 10_000), (400, 400))
    unsafe = dataclasses_replace(result, verdict=judge_safety(violent, result.motor))
    assert verdict(unsafe).level == "unsafe" and not verdict(unsafe).safe
    assert "criterion" in verdict(unsafe).text
    stalls = dataclasses_replace(result, verdict=None, margins={**result.margins, "min": 0.97})
    assert verdict(stalls).level == "unsafe" and "0.970 < 1" in verdict(stalls).text
    assert f"verdict: {verdict(result).text}" in result.summary()


def test_friction_reaches_the_plan() -> None:
    base = Settings(pulses=3_000)
    plain = design(NEMA17, base, load_angle=False)
    rough = design(NEMA17, dataclasses_replace(base, friction_torque_nm=0.06), load_angle=False)
    assert rough.motor.friction_torque_nm == 0.06
    assert rough.execution.duration_s > plain.execution.duration_s
    with pytest.raises(StepRampError, match="load_angle_aim_deg"):
        design(NEMA17, dataclasses_replace(base, load_angle_aim_deg=120.0))


@pytest.mark.slow
def test_plan_to_aim_plans_as_stepramp_plan_does() -> None:
    from profiles.ppmc312.planner import plan_free_curve

    base = Settings(pulses=3_000, load_angle_aim_deg=40.0)
    aimed = design(NEMA17, dataclasses_replace(base, plan_to_aim=True))
    assert aimed.plan.table == plan_free_curve(loaded_motor(NEMA17, base), pulses=3_000,
                                               load_angle_deg=40.0).table
    assert aimed.plan.table != design(NEMA17, dataclasses_replace(base, plan_to_aim=False),
                                      load_angle=False).plan.table
    assert aimed.physics is not None and abs(aimed.physics.worst_angle_deg) <= 40.0


def test_control_specs_hold_the_motors_values_within_their_ranges() -> None:
    specs = control_specs(NEMA17, 5_000)
    assert specs["pulses"].value == 5_000 and specs["pulses"].integer
    assert specs["safety_factor"].value == NEMA17.safety_factor
    assert specs["friction_torque_nm"].value == NEMA17.friction_torque_nm
    for spec in specs.values():
        assert spec.lo <= spec.value <= spec.hi and spec.step > 0
    with pytest.raises(StepRampError, match="pulses"):
        control_specs(NEMA17, 5)


def test_stage_budget_and_clock_reach_the_table(d: Designer) -> None:
    d.controls["max_stages"].value = 12
    assert d.result is not None and len(d.result.plan.table.rates) <= 12
    d.controls["clock"].value = "1MHz"
    assert d.result.plan.table.clock.name == "1MHz"


def test_load_torque_is_the_motors_signed_load_torque(d: Designer) -> None:
    d.controls["load_torque_nm"].value = -0.04
    assert d.result is not None
    assert d.result.motor.load_torque_nm == pytest.approx(-0.04)
    assert d.result.motor.friction_torque_nm == NEMA17.friction_torque_nm
    assert d.controls["load_torque_nm"].min < 0 < d.controls["load_torque_nm"].max


def test_motor_picker_switches_motor_and_resets_its_sliders(d: Designer) -> None:
    other = next(k for k in d.motors if "nema23" in k)
    d.controls["safety_factor"].value = 0.3
    d.controls["motor"].value = other
    assert d.result is not None and d.motor is d.motors[other]
    assert d.result.settings.safety_factor == d.motors[other].safety_factor
    assert d.result.settings.load_inertia_kgm2 == 0.0
    assert d.result.motor.name == d.motors[other].name


def test_impossible_settings_say_why_and_keep_the_last_design(d: Designer) -> None:
    d.controls["load_torque_nm"].value = d.controls["load_torque_nm"].max
    kept, png = d.result, d.image.value
    d.controls["safety_factor"].value = 0.1  # the load torque now exceeds the motor's torque
    assert "no table for these settings" in d.status.value
    assert "cannot accelerate from rest" in d.status.value
    assert d.result is kept and d.image.value == png


def test_write_button_writes_the_table_and_upload_files_that_decode_back(
        d: Designer, tmp_path: Path) -> None:
    d.buttons["write"].click()
    names = sorted(p.name for p in d.written)
    assert names == sorted(f"design-nema17-1600-5000.{ext}" for ext in
                           ("table.json", "upload.hex", "upload.bin", "upload.h"))
    assert d.result is not None
    table = d.result.plan.table
    assert load_table(tmp_path / "design-nema17-1600-5000.table.json") == table
    for ext in ("hex", "bin"):
        blocks = parse_upload((tmp_path / f"design-nema17-1600-5000.upload.{ext}").read_bytes())
        assert decode_upload(blocks) == table
    assert "wrote" in d.status.value


@pytest.mark.slow
def test_reference_button_solves_the_slow_references(d: Designer) -> None:
    png = d.image.value
    d.buttons["references"].click()
    assert set(d.slow) == {"toppra", "ruckig", "casadi"}
    assert d.image.value != png
    assert d.result is not None
    for name in ("toppra", "casadi"):  # time-optimal solvers land on the exact optimum
        assert d.slow[name].duration_s == pytest.approx(d.result.exact.duration_s, rel=0.03)
    d.controls["pulses"].value = 6_000  # a new move: the old references no longer apply
    assert d.slow == {}


DRIVE = """\
import hashlib, json
def _state():
    return {"png": hashlib.sha256(design.image.value).hexdigest(),
            "summary": design.summary.value, "move_s": design.result.execution.duration_s,
            "stages": len(design.result.plan.table.rates),
            "clock": design.result.plan.table.clock.name}
_runs = {"start": _state()}
for _name, _value in [("pulses", 20000), ("safety_factor", 0.4),
                      ("load_inertia_kgm2", 8 * motor.inertia_kgm2), ("load_torque_nm", 0.03),
                      ("clock", "1MHz"), ("max_stages", 16), ("motor", "nema23-heavy")]:
    design.controls[_name].value = _value
    _runs[_name] = _state()
design.buttons["write"].click()
_runs["written"] = sorted(p.name for p in design.written)
print("DRIVE " + json.dumps(_runs))
"""


def execute_notebook(tmp_path: Path, extra: list[str], kernel: tuple[str, Any]) -> Any:
    import nbformat
    from jupyter_client.manager import KernelManager
    from nbclient import NotebookClient

    nb = nbformat.read(str(ROOT / "notebooks" / "design-interactive.ipynb"), as_version=4)
    for source in extra:
        nb.cells.append(nbformat.v4.new_code_cell(source))
    name, ksm = kernel
    env = checkout_env(MPLBACKEND="Agg")
    km = KernelManager(kernel_name=name, kernel_spec_manager=ksm)
    client = NotebookClient(nb, km=km, timeout=180, store_widget_state=True,
                            resources={"metadata": {"path": str(tmp_path)}})
    old = dict(os.environ)
    os.environ.update(env)
    try:
        client.execute()
    finally:
        os.environ.clear()
        os.environ.update(old)
    return nb


@pytest.fixture(scope="module")
def kernel(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Any]:
    from tests.support.notebooks import kernel_for_this_interpreter

    return kernel_for_this_interpreter(tmp_path_factory.mktemp("kernelspec"))


@pytest.mark.slow
def test_widgets_driven_in_a_kernel_change_the_outputs(tmp_path: Path,
                                                       kernel: tuple[str, Any]) -> None:
    nb = execute_notebook(tmp_path, [DRIVE], kernel)
    text = "".join(o.get("text", "") for o in nb.cells[-1].outputs if o.output_type == "stream")
    runs = json.loads(text.split("DRIVE ", 1)[1])
    steps = ["start", "pulses", "safety_factor", "load_inertia_kgm2", "load_torque_nm", "clock",
             "max_stages", "motor"]
    for previous, step in itertools.pairwise(steps):
        assert runs[step]["png"] != runs[previous]["png"], step
        assert runs[step]["summary"] != runs[previous]["summary"], step
    for step in ("pulses", "safety_factor", "load_inertia_kgm2", "load_torque_nm"):
        i = steps.index(step)
        assert runs[step]["move_s"] > runs[steps[i - 1]]["move_s"], step
    assert runs["clock"]["clock"] == "1MHz" and runs["max_stages"]["stages"] <= 16
    assert "NEMA23" in runs["motor"]["summary"]
    assert len(runs["written"]) == 4 and all((tmp_path / n).is_file() for n in runs["written"])
    # The widget's state went into the notebook (what a viewer renders).
    assert "application/vnd.jupyter.widget-state+json" in nb.metadata.get("widgets", {})


def browser() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


@pytest.mark.slow
def test_screenshot_of_the_rendered_notebook(tmp_path: Path, kernel: tuple[str, Any]) -> None:
    chrome = browser()
    if chrome is None:
        pytest.skip("no Chromium installed (Debian package `chromium`; .ci/run installs it)")
    from matplotlib.image import imread
    from nbconvert import HTMLExporter

    nb = execute_notebook(tmp_path, [], kernel)
    html, _ = HTMLExporter().from_notebook_node(nb)
    page = tmp_path / "design-interactive.html"
    page.write_text(html, encoding="utf-8")
    shot = tmp_path / "design-interactive.png"
    done = subprocess.run([chrome, "--headless", "--no-sandbox", "--disable-gpu",
                           "--hide-scrollbars", "--window-size=1280,4000",
                           f"--screenshot={shot}", page.as_uri()],
                          capture_output=True, text=True, timeout=180)
    assert shot.is_file(), done.stderr[-2000:]
    pixels = imread(str(shot))[..., :3]
    assert pixels.shape[0] >= 2000 and pixels.shape[1] >= 1000
    # The designer's figure is on the page: the staircase's red (tab:red) and the
    # exact optimum's grey lines, not a blank or an error page.
    red = np.all(np.abs(pixels - np.array([214, 39, 40]) / 255) < 0.08, axis=-1)
    assert red.sum() > 500, f"{red.sum()} staircase-red pixels"
    assert pixels.std() > 0.05


NEMA17_PATH = next(p for p in bundled_motor_paths() if "nema17" in p.name)




# a move whose plain table rings past the aim: the tightening changes it (4 plans)
RINGS = Settings(pulses=5_000, safety_factor=NEMA17.safety_factor)


def test_a_change_shows_a_marked_first_table_then_the_final_one() -> None:
    first, final, judged = design_steps(NEMA17, RINGS)
    assert (first.final, final.final, judged.final) == (False, True, True)
    assert (first.complete, final.complete, judged.complete) == (False, False, True)
    # the first is the plain criterion's table for the same loaded motor and reserve
    plain = plan_free_curve(parse_cruise_reserve(RINGS.cruise_reserve).applied(
        loaded_motor(NEMA17, RINGS)), pulses=RINGS.pulses)
    assert first.plan.table == plain.table
    assert first.verdict is None and first.physics is None
    said = verdict(first)
    assert said.level == "tightening" and not said.safe and TIGHTENING in said.text
    assert first.summary().startswith(TIGHTENING)
    # the tightening changed it; the final one is judged, safe and said so
    assert final.plan.table != first.plan.table
    assert final.verdict is not None and verdict(final).level == "safe"
    assert TIGHTENING not in final.summary() and TIGHTENING not in verdict(final).text
    # judged for the moves and decel stops first, saying the other commands are judged
    assert [name for name, _ in final.verdict.commands] == ["decel-stop"]
    assert verdict(final).text.endswith(JUDGING)
    # then the same table with the verdict over every command: design()'s
    whole = design(NEMA17, RINGS)
    assert judged.plan is final.plan and judged.plan.table == whole.plan.table
    assert judged.verdict.to_json() == whole.verdict.to_json()
    assert verdict(judged) == verdict(whole) and JUDGING not in verdict(judged).text


def test_without_the_aim_or_the_load_angle_a_change_is_one_step() -> None:
    plain = Settings(pulses=3_000, plan_to_aim=False)
    assert [r.final for r in design_steps(NEMA17, plain, load_angle=False)] == [True]
    assert [r.final for r in design_steps(NEMA17, plain)] == [False, True, True]  # judged


def test_the_final_table_is_the_one_stepramp_plan_writes(tmp_path: Path) -> None:
    from verify import cli

    out = tmp_path / "plan.table.json"
    assert cli.main(["plan", "--motor", str(NEMA17_PATH), "--pulses", str(RINGS.pulses),
                     "-o", str(out)]) == 0
    _, final, judged = design_steps(NEMA17, RINGS)
    assert final.plan.table == judged.plan.table == load_table(out)


def test_a_first_table_is_drawn_over_the_last_axes_and_marked() -> None:
    fig = DesignFigure()
    final = design(NEMA17, RINGS)
    final_png = fig.update(final)
    assert fig.last_drawing == "full" and not fig.mark.get_visible()
    limits = fig.ax_v.get_xlim(), fig.ax_v.get_ylim()
    nearby = Settings(pulses=5_500, safety_factor=RINGS.safety_factor)
    png = fig.update(first_design(NEMA17, nearby))
    assert fig.last_drawing == "over" and (fig.ax_v.get_xlim(), fig.ax_v.get_ylim()) == limits
    assert fig.mark.get_visible() and TIGHTENING in fig.mark.get_text()
    assert fig.ax_v.get_title().startswith(TIGHTENING)
    assert fig.table_line.get_linestyle() == "--"
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and png != final_png
    # its final table fits the same axes: drawn over them too, the mark gone
    near = design(NEMA17, nearby)
    over = fig.update(near)
    assert fig.last_drawing == "over" and not fig.mark.get_visible()
    assert not fig.ax_v.get_title().startswith(TIGHTENING)
    # nothing of the tables drawn before stays behind: the picture is a fresh figure's
    fresh = DesignFigure()
    assert fresh.update(near) == over
    assert [ax.get_xlim() + ax.get_ylim() for ax in (fresh.ax_v, fresh.ax_m, fresh.ax_l)]\
        == [ax.get_xlim() + ax.get_ylim() for ax in (fig.ax_v, fig.ax_m, fig.ax_l)]
    fig.update(first_design(NEMA17, nearby))
    # a first table the axes cannot hold gets new limits, only the panels whose limits
    # moved drawn again (the picture a full drawing at those limits is), marked all the same
    longer = first_design(NEMA17, Settings(pulses=60_000))
    far = fig.update(longer)
    assert fig.last_drawing == "panels" and fig.mark.get_visible() and far != png
    assert fig.ax_v.get_xlim()[1] > limits[0][1]
    fig.shown, fig.background = (), None
    assert fig.update(longer) == far and fig.last_drawing == "full"
    fig.update(design(NEMA17, nearby))  # the axes too long for it now: new limits
    assert fig.last_drawing == "panels" and not fig.mark.get_visible()
    # the references shown change the legend: in full
    fig.update(design(NEMA17, nearby), {"toppra": design(NEMA17, nearby).exact})
    assert fig.last_drawing == "full"


def test_the_notebook_shows_both_tables_and_never_writes_a_first(tmp_path: Path) -> None:
    d = designer(NEMA17, pulses=3_000, out_dir=tmp_path)
    shown: list[str] = []
    d.summary.observe(lambda change: shown.append(change["new"]), names="value")
    d.controls["pulses"].value = RINGS.pulses
    assert len(shown) == 3 and TIGHTENING in shown[0] and JUDGING in shown[1]
    assert TIGHTENING not in shown[1] + shown[2] and JUDGING not in shown[2]
    assert d.result is not None and d.result.complete
    for step in list(design_steps(NEMA17, RINGS))[:2]:  # neither is judged in full
        d.result = step
        assert d.write() == [] and not any(tmp_path.iterdir())


@pytest.mark.slow  # a Panel page: about 2 s
def test_the_page_shows_the_first_table_then_the_final_on_the_next_turn() -> None:
    pytest.importorskip("panel")
    from verify.webdesigner import DesignPage

    page = DesignPage(NEMA17, pulses=3_000, motor_name="nema17")
    assert page.result is not None and page.result.final  # it opens on a final table
    later: list[Any] = []

    class Doc:  # a served tab's document: callbacks run on the server's next turn
        session_context = object()

        def add_next_tick_callback(self, callback: Any) -> None:
            later.append(callback)

    page._doc = Doc()
    page.controls["pulses"].value = RINGS.pulses
    assert page.result.final is False and len(later) == 1
    assert "data-level='tightening'" in page.verdict.object
    assert all(b.disabled for b in page.downloads.values())
    assert TIGHTENING in page.summary.object
    page.controls["pulses"].value = 5_200  # a newer change before the final came
    later.pop(0)()                          # the older final is dropped
    assert page.result.settings.pulses == 5_200 and not page.result.final
    later.pop(0)()
    assert page.result.final and page.result.plan.table == design(
        NEMA17, page.settings).plan.table
    assert "data-level='safe'" in page.verdict.object and JUDGING in page.verdict.object
    assert all(b.disabled for b in page.downloads.values())  # not judged in full yet
    assert "final table shown in" in page.summary.object
    later.pop(0)()
    assert page.result.complete and not later
    assert "data-level='safe'" in page.verdict.object and JUDGING not in page.verdict.object
    assert not any(b.disabled for b in page.downloads.values())
    assert "judged in full in" in page.summary.object


@pytest.mark.slow  # NEMA23: a few tightening plans and two verdicts, about 1.5 s
def test_the_verdict_on_the_motor_as_planned_is_the_loaded_motors() -> None:
    """The final design is judged on the motor the planner had (the loaded motor with its
    top speed capped for the cruise reserve), so the tightening's verdicts are reused;
    the verdict is the one `check --motor` gives on the loaded motor."""
    from verify.safety import judge_safety

    nema23 = load_motor(next(p for p in bundled_motor_paths() if "nema23" in p.name))
    settings = Settings(pulses=12_000, safety_factor=nema23.safety_factor)
    loaded = loaded_motor(nema23, settings)
    capped = parse_cruise_reserve(settings.cruise_reserve).applied(loaded)
    assert capped.top_pps < loaded.top_pps  # the reserve binds on this motor
    final = design(nema23, settings)
    assert final.verdict is not None
    assert final.verdict.to_json() == judge_safety(final.plan.table, loaded).to_json()


def test_readouts_and_the_speed_axis_speak_the_axis_units() -> None:
    """mm and mm/s where the motor file states its travel per revolution, rev and rpm
    otherwise (profiles.motor.travel's conversions), beside pulses and pps."""
    import dataclasses

    screw = dataclasses.replace(NEMA17, travel_mm_per_rev=8.0)  # 1600 pulses/rev
    fig = DesignFigure()
    for motor, length, speed in ((screw, "(25 mm)", "speed [mm/s]"),
                                 (NEMA17, "(3.125 rev)", "speed [rpm]")):
        result = first_design(motor, Settings(pulses=5_000))
        summary = result.summary()
        assert f"5000 pulses {length}" in summary
        top = float(result.execution.edges()[2].max())
        assert f"({result.units.speed_text(top)})" in summary
        fig.update(result)
        assert fig.last_drawing == "full"  # another motor's units: a new second scale
        (second,) = fig.ax_v.child_axes
        assert second.get_ylabel() == speed and length in fig.ax_v.get_title()
    assert result.units.speed(top) == pytest.approx(top * 60 / 1600)
