"""verify.compare and verify.plot: the numbers and the figure behind `stepramp compare`."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.planner import plan_free_curve
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
