"""The CLI's safety verdicts judge every move length: check --motor, compare, plan."""

from __future__ import annotations

import itertools
import json
import re
from pathlib import Path
from typing import Any

import pytest

from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.table import FreeCurveTable, dump_table, load_table
from tests.support.paths import ROOT
from verify.cli import main
from verify.safety import judge_safety

MOTORS = {p.stem: p for p in bundled_motor_paths()}
NEMA23 = MOTORS["motor-nema23-heavy"]
NEMA17 = MOTORS["motor-nema17-1600"]
PK566 = MOTORS["motor-pk566-5phase-half"]


def run(capsys: pytest.CaptureFixture[str], *argv: str | Path) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def switching_table(tmp_path: Path) -> Path:
    # LE=1, decel counts heavy at the slow end: short triangles switch down
    table = FreeCurveTable(Clock.internal("8MHz"), (1455, 1873, 2500), (40, 40, 40), (2, 2, 200))
    path = tmp_path / "switch.table.json"
    path.write_text(dump_table(table))
    return path


def test_check_motor_fails_a_table_unsafe_only_for_some_lengths(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = switching_table(tmp_path)
    code, out, _ = run(capsys, "check", path, "--motor", NEMA23, "--no-physics")
    assert code == 1 and "stall-switch" in out
    shortest = int(re.search(r"shortest move that runs it: (\d+) pulses",  # type: ignore[union-attr]
                             out[out.index("stall-switch"):]).group(1))
    table = load_table(path)
    # the named length really switches down; a trapezoid of the whole table does not
    segs = simulate_move(table, shortest).segments
    assert any(a.phase == "accel" and b.phase == "decel" and b.rate > a.rate
               for a, b in itertools.pairwise(segs))
    whole = table.accel_total + table.decel_total
    code, out, _ = run(capsys, "check", path, "--motor", NEMA23, "--no-physics",
                       "--pulses", f"{whole},{whole + 1000}")
    assert "stall-switch" not in out
    code, out, _ = run(capsys, "check", path, "--motor", NEMA23, "--no-physics",
                       "--pulses", str(shortest))
    assert code == 1 and "stall-switch" in out


def test_check_pulses_needs_a_motor_and_valid_lengths(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = switching_table(tmp_path)
    assert run(capsys, "check", path, "--pulses", "100")[0] == 2
    code, _, err = run(capsys, "check", path, "--motor", NEMA23, "--pulses", "0")
    assert code == 2 and "move length" in err


def test_check_motor_reports_the_load_angle_judge(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # a motor file that vouches for a 21 kpps start (the criterion believes it) while
    # its rotor (ω_n ≈ 1700 rad/s, 0.196 rad per pulse) swings 2.3 rad on a 20 kpps step
    motor = json.loads(NEMA17.read_text())
    motor.update(start_pps=21000, max_jump_pps=21000)
    motor_path = tmp_path / "optimistic.motor.json"
    motor_path.write_text(json.dumps(motor))
    table = FreeCurveTable(Clock.internal("8MHz"), (300, 400), (800, 800))
    path = tmp_path / "t.table.json"
    path.write_text(dump_table(table))
    code, out, _ = run(capsys, "check", path, "--motor", motor_path, "--format", "json")
    rules = {f["rule"] for f in json.loads(out)["files"][0]["findings"]}
    assert code == 1 and "load-angle" in rules
    assert not rules & {"stall-jump", "stall-accel", "stall-decel", "stall-start-speed"}
    message = next(f["message"] for f in json.loads(out)["files"][0]["findings"]
                   if f["rule"] == "load-angle")
    assert "the criterion passes" in message
    assert run(capsys, "check", path, "--motor", motor_path, "--no-physics")[0] == 0


def test_compare_exits_1_on_an_unsafe_move(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    path = switching_table(tmp_path)
    table = load_table(path)
    code, out, _ = run(capsys, "compare", path, "--motor", NEMA23, "--pulses",
                       str(table.accel_total + table.decel_total + 500), "--references",
                       "ruckig", "--format", "json")
    doc = json.loads(out)
    assert code == (0 if doc["safe"] else 1)
    assert doc["failed_judges"] == ([] if doc["safe"] else doc["failed_judges"])
    example = ROOT / "examples" / "free-curve-nema17.json"
    code, out, _ = run(capsys, "compare", example, "--motor", NEMA23, "--pulses", "5000",
                       "--references", "ruckig")
    assert code == 1 and ("verdict: UNSAFE (failed: criterion, load angle, decel-stop, "
                          "constant, origin-search, origin-return, stop, set-speed)") in out


@pytest.mark.slow  # end-to-end; CI runs it
def test_plan_moves_writes_one_table_for_a_duty_cycle(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mix = tmp_path / "mix.csv"
    mix.write_text("pulses,weight\n300,4\n3000,1\n")
    out_path = tmp_path / "duty.table.json"
    code, out, _ = run(capsys, "plan", "--motor", PK566, "--moves", mix, "--format", "json",
                       "-o", out_path)
    assert code == 0
    doc = json.loads(out)
    table = load_table(out_path)
    times = {int(k): v for k, v in doc["move_times_s"].items()}
    assert times == {n: pytest.approx(simulate_move(table, n).duration_s) for n in (300, 3000)}
    assert doc["weighted_time_s"] == pytest.approx(4 * times[300] + times[3000])
    assert doc["safety"] == judge_safety(table, load_motor(PK566)).to_json()
    assert doc["safety"]["safe"] is True and doc["safety"]["within_aim"]


@pytest.mark.parametrize("text, why", [
    ("pulses;weight\n300;1\n", "header"),
    ("pulses,weight\n300,x\n", "line 2"),
    ("pulses,weight\n", "no move lengths"),
    ("pulses,weight\n0,1\n", "line 2"),
])
def test_plan_moves_refuses_bad_mixes(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                      text: str, why: str) -> None:
    mix = tmp_path / "mix.csv"
    mix.write_text(text)
    out_path = tmp_path / "t.json"
    code, _, err = run(capsys, "plan", "--motor", PK566, "--moves", mix, "-o", out_path)
    assert code == 2 and why in err and len(err.strip().splitlines()) == 1
    assert not out_path.exists()


@pytest.mark.parametrize("pulses", [7, 4_294_967_296])
def test_a_mix_length_outside_the_chips_range_names_it(tmp_path: Path, pulses: int,
                                                       capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    """8 pulses (2 stages × 2 pulses × 2 sides) up to the 32-bit pulse count."""
    mix = tmp_path / "mix.csv"
    mix.write_text(f"pulses,weight\n300,1\n{pulses},1\n")
    code, _, err = run(capsys, "plan", "--motor", PK566, "--moves", mix)
    assert code == 2
    assert err.endswith(f"mix.csv, line 3, pulses: {pulses}"
                        f"{f' (0x{pulses:X})' if pulses > 9 else ''} is outside the allowed "
                        "range 8..4294967295 (0xFFFFFFFF)\n")


def plan_from(capsys: pytest.CaptureFixture[str], tmp_path: Path, motor: str, source: str,
              pulses: int) -> tuple[int, dict[str, Any], Path]:
    out_path = tmp_path / f"{source}-{pulses}.json"
    code, out, err = run(capsys, "plan", "--motor", motor, "--pulses", str(pulses), "--from",
                         source, "--format", "json", "-o", out_path)
    return code, json.loads(out) if code == 0 else {"err": err}, out_path


@pytest.mark.parametrize("source", ["ruckig", "toppra"])
def test_plan_from_a_reference_gives_a_safe_table_and_its_price(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], source: str) -> None:
    code, doc, out_path = plan_from(capsys, tmp_path, NEMA17, source, 2000)
    assert code == 0 and out_path.exists()
    assert doc["safety"]["safe"] and doc["safety"]["within_aim"]
    table = load_table(out_path)
    assert doc["move_time_s"] == pytest.approx(simulate_move(table, 2000).duration_s)
    # what following the reference costs: its time beside the reference's and the planner's
    assert doc["table/planner"] == pytest.approx(doc["move_time_s"] / doc["planner_s"])
    assert doc["table/reference"] == pytest.approx(doc["move_time_s"] / doc["reference_s"])
    code, _, _ = run(capsys, "check", out_path, "--motor", NEMA17)
    assert code == 0


@pytest.mark.slow
@pytest.mark.parametrize("pulses", [2000, 10_000])
@pytest.mark.parametrize("source", ["ruckig", "toppra"])
@pytest.mark.parametrize("motor", [NEMA17, NEMA23, PK566])
def test_plan_from_every_bundled_motor_and_reference(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], motor: str, source: str,
        pulses: int) -> None:
    code, doc, out_path = plan_from(capsys, tmp_path, motor, source, pulses)
    assert code == 0, doc
    assert run(capsys, "check", out_path, "--motor", motor)[0] == 0
