"""verify.compare and verify.plot: the numbers and the figure behind `stepramp compare`."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from profiles.errors import ReferenceSolveError
from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.planner import plan_free_curve
from tests.support.figures import close
from verify.compare import compare_table
from verify.report import FileResult, file_lines

MOTOR = load_motor(bundled_motor_paths()[0])


PLAN = plan_free_curve(MOTOR, pulses=4000)


def test_numbers_are_the_chip_time_against_the_best_reference() -> None:
    cmp = compare_table(PLAN.table, MOTOR, 4000, include=("ruckig",))
    # the chip's time, from the table by hand: a trapezoid runs every accel and decel
    # stage once and the rest of the move at the fastest rate, each pulse `rate` ticks
    t = PLAN.table
    assert t.accel_total + t.decel_total <= 4000
    ticks = (sum(n * r for n, r in zip(t.accel_pulses, t.rates, strict=False))
             + sum(d * r for d, r in zip(t.decel, t.rates, strict=False))
             + (4000 - t.accel_total - t.decel_total) * t.rates[0])
    assert cmp.table_s == ticks / t.clock.hz
    assert cmp.optimum == "exact"  # the jerk-free optimum: a true lower bound
    assert cmp.ratio == pytest.approx(cmp.table_s / cmp.optimum_s)
    assert cmp.ratio >= 1.0
    assert cmp.stall_margin >= 1.0 - 1e-9  # the planner's table is stall-safe
    doc = cmp.to_json()
    assert {"table_s", "optimum_s", "ratio", "stall_margin", "references", "shape"} <= set(doc)
    assert set(doc["references"]) == {"exact", "ruckig"}
    assert "jerk_limited_optimum_s" not in doc
    assert "ratio" in cmp.to_text()
    # both judges on the move: the planner's table is safe by each
    assert cmp.safe and doc["safe"] and doc["failed_judges"] == []
    move, every = doc["safety"]["move"], doc["safety"]["every_move"]
    assert move["criterion_findings"] == [] and move["moves"] == [cmp.pulses]
    assert move["worst_load_angle_deg"] < 75 and every["moves"] == "every"
    assert every["worst_load_angle_deg"] >= move["worst_load_angle_deg"]
    text = cmp.to_text().splitlines()
    assert text[-1] == "verdict: SAFE"
    # the text says what the JSON says: the margin, and both judges' verdicts
    assert f"smallest stall margin: {cmp.stall_margin:.3f} (capability / need; ≥ 1 is " \
           "stall-safe)" in text
    assert "criterion: passes" in text
    la = cmp.move_verdict.load_angle
    assert la is not None and f"this move: SAFE; {la.describe()}" in text
    # every move as check reports it (verify.report): the findings, then the notes, each once
    every_lines = [line for line in text if line.startswith("every move: ")]
    assert every_lines == file_lines(FileResult("every move", True,
                                                cmp.every_verdict.findings(),
                                                notes=cmp.every_verdict.notes()))[0]
    worst = cmp.every_verdict.load_angle.describe()  # in a finding or a note, once
    assert sum(worst in line for line in every_lines) == 1
    assert len(set(text)) == len(text)  # no line said twice


def test_compare_reports_every_move_as_check_does(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    # the same findings and notes, in the same order, as `check --motor` prints for the table
    from profiles.ppmc312.table import dump_table
    from verify.cli import main

    path = tmp_path / "t.json"
    path.write_text(dump_table(PLAN.table))
    motor = str(bundled_motor_paths()[0])
    assert main(["check", str(path), "--motor", motor]) == 0
    checked = [line.split(": ", 1)[1] for line in capsys.readouterr().out.splitlines()
               if line.startswith(str(path) + ": ")]
    assert main(["compare", str(path), "--motor", motor, "--pulses", "4000",
                 "--references", "ruckig"]) == 0
    compared = [line.split(": ", 1)[1] for line in capsys.readouterr().out.splitlines()
                if line.startswith("every move: ")]
    assert checked and compared == checked


def test_staircase_edges_cover_the_move() -> None:
    run = simulate_move(PLAN.table, 4000)
    t, x, v = run.edges()
    assert t[0] == 0 and t[-1] == pytest.approx(run.duration_s)
    assert x[0] == 0 and x[-1] == 4000
    assert v.max() == pytest.approx(PLAN.table.speeds_pps().max())


@pytest.mark.slow  # compare with ruckig, then the figure drawn; CI runs it
@pytest.mark.parametrize("suffix", ["png", "svg"])
def test_figure_is_written(tmp_path: Path, suffix: str) -> None:
    cmp = compare_table(PLAN.table, MOTOR, 4000, include=("ruckig",))
    out = tmp_path / f"c.{suffix}"
    cmp.plot(out)
    head = out.read_bytes()[:64]
    assert head.startswith(b"\x89PNG") if suffix == "png" else b"<svg" in out.read_bytes()
    fig = cmp.figure()
    assert len(fig.axes) == 4  # and the load angle against time
    labels = [ax.get_xlabel() for ax in fig.axes]
    assert labels == ["time [ms]", "position [pulses]", "time [ms]", "stage (0 = fastest)"]


@pytest.mark.slow
def test_jerk_limited_motor_reports_casadi_as_the_jerk_limited_optimum() -> None:
    motor = dataclasses.replace(MOTOR, max_jerk_pps3=5e9)
    plan = plan_free_curve(motor, pulses=4000)
    cmp = compare_table(plan.table, motor, 4000, include=("casadi",))
    doc = cmp.to_json()
    assert doc["jerk_limited_optimum_s"] == cmp.references["casadi"].duration_s
    assert doc["jerk_limited_optimum_s"] >= cmp.optimum_s * (1 - 1e-3)


@pytest.fixture(scope="module")
def cmp() -> Any:
    return compare_table(PLAN.table, MOTOR, 4000, include=("ruckig",))


def legend_texts(fig: Any) -> list[str]:
    legends = [ax.get_legend() for ax in fig.axes] + list(fig.legends)
    return [t.get_text() for lg in legends if lg is not None for t in lg.get_texts()]


def test_compare_has_a_load_angle_panel_with_the_aim_and_the_peak(cmp: Any) -> None:
    fig = cmp.figure()
    [ax] = [a for a in fig.axes if a.get_ylabel().startswith("load angle")]
    levels = {round(float(line.get_ydata()[0]), 6) for line in ax.get_lines()
              if len(set(np.asarray(line.get_ydata(), float))) == 1 and
              len(line.get_ydata()) == 2}
    assert {75.0, -75.0, 90.0, -90.0} <= levels
    trace = next(line for line in ax.get_lines() if line.get_label() == "nominal, forward")
    worst = cmp.move_verdict.load_angle.worst_deg
    assert float(np.max(np.abs(trace.get_ydata()))) == pytest.approx(worst, rel=0.05)
    assert any(t.startswith("worst ") for t in legend_texts(fig))
    close(fig)


def test_without_physics_no_load_angle_panel() -> None:
    cmp = compare_table(PLAN.table, MOTOR, 4000, include=(), physics=False)
    fig = cmp.figure()
    assert not any(a.get_ylabel().startswith("load angle") for a in fig.axes)
    close(fig)


def test_a_failed_reference_is_shown_as_failed(monkeypatch: pytest.MonkeyPatch) -> None:
    import verify.references.casadi_ref as casadi_ref

    def fail(motor: Any, pulses: float) -> Any:
        raise ReferenceSolveError("casadi: Ipopt did not succeed (Infeasible_Problem)")

    monkeypatch.setattr(casadi_ref, "casadi_reference", fail)
    cmp = compare_table(PLAN.table, MOTOR, 4000, include=("casadi",), physics=False)
    assert cmp.failed_references == {"casadi": "Ipopt did not succeed (Infeasible_Problem)"}
    assert "casadi" not in cmp.references
    assert "  casadi   failed (Ipopt did not succeed (Infeasible_Problem))" in cmp.to_text()
    assert cmp.to_json()["failed_references"] == cmp.failed_references
    fig = cmp.figure()
    texts = legend_texts(fig)
    assert "casadi: FAILED (Ipopt did not succeed (Infeasible_Problem))" in texts
    close(fig)


def test_references_from_another_start_are_labelled_and_the_table_start_drawn() -> None:
    faster = dataclasses.replace(MOTOR, start_pps=MOTOR.start_pps * 1.5)
    cmp = compare_table(PLAN.table, faster, 4000, include=(), physics=False)
    start = cmp.from_table_start
    assert start is not None
    assert start.v_pps[0] == pytest.approx(cmp.table_start_pps)
    assert cmp.reference_start_pps == pytest.approx(faster.start_pps)
    fig = cmp.figure()
    legend = fig.axes[0].get_legend()
    assert f"{faster.start_pps:.6g} pps" in legend.get_title().get_text()
    assert any(t.startswith("exact from the table's start") for t in legend_texts(fig))
    assert "table/that" in cmp.to_text()
    close(fig)
    same = compare_table(PLAN.table, MOTOR, 4000, include=(), physics=False)
    assert same.from_table_start is None  # the planner's table starts at the motor's start


def test_a_long_move_gets_a_ramp_zoom_a_short_one_none(cmp: Any) -> None:
    fig = cmp.figure()
    assert not any(a.get_title().startswith("the ramp, zoomed") for a in fig.axes)
    close(fig)
    long = compare_table(PLAN.table, MOTOR, 400_000, include=(), physics=False)
    fig = long.figure()
    [zoom] = [a for a in fig.axes if a.get_title().startswith("the ramp, zoomed")]
    assert zoom.get_xlim()[1] < 0.1 * long.table_s * 1e3
    close(fig)


def test_an_unnamed_motor_is_titled_by_its_file(cmp: Any) -> None:
    unnamed = dataclasses.replace(cmp, motor=dataclasses.replace(MOTOR, name=""))
    fig = unnamed.figure("17hs19")
    assert fig.get_suptitle().startswith("17hs19: 4000 pulses")
    close(fig)
