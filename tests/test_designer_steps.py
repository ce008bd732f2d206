"""The designer's steps a change (issue #32 item 9): a first table at once, marked as
being tightened and never offered as safe, then the final table, which is the one
`stepramp plan` writes for the same inputs, judged for moves and decel stops, then its
verdict over every command. The time budget itself is benched
(bench/bench_designer.py), not timed here."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from profiles.motor import bundled_motor_paths, load_motor
from profiles.motor.reserve import parse_cruise_reserve
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import load_table
from verify.designer import (
    JUDGING,
    TIGHTENING,
    DesignFigure,
    Settings,
    design,
    design_steps,
    designer,
    first_design,
    loaded_motor,
    verdict,
)

NEMA17_PATH = next(p for p in bundled_motor_paths() if "nema17" in p.name)
NEMA17 = load_motor(NEMA17_PATH)
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
    assert [ax.get_xlim() + ax.get_ylim() for ax in (fresh.ax_v, fresh.ax_m, fresh.ax_l)] \
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
