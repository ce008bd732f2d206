"""`stepramp plan` (verify/cli/plan.py): plans, duty cycles, every move length, clocks in any
case, cruise reserve, summaries."""

from __future__ import annotations

import io
import json
import re
import sys
from pathlib import Path
from typing import Any

import pytest

from profiles.motor import bundled_motor_paths, load_motor
from profiles.motor.catalogue import resolve
from profiles.motor.reserve import CruiseReserve
from profiles.ppmc312.ascii import decode_serial_init
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.init_model import expand_init
from profiles.ppmc312.planner import duty_cycle
from profiles.ppmc312.table import InitTable, load_table
from tests.support.cli import run
from tests.support.datasheet_motor import datasheet_motor_file
from tests.support.motor_folders import LEAD_MM, screw_motor_file
from tests.support.paths import ROOT
from verify.cli import main
from verify.plan_text import pps
from verify.safety import judge_safety

MOTORS = {p.stem: p for p in bundled_motor_paths()}


PK566 = MOTORS["motor-pk566-5phase-half"]
NEMA17 = MOTORS["motor-nema17-1600"]


# --- plan --moves --------------------------------------------------------------------------------
def plan_moves(tmp_path: Path, capsys: pytest.CaptureFixture[str],
               text: str) -> tuple[int, str]:
    mix = tmp_path / "mix.csv"
    mix.write_text(text)
    out = tmp_path / "t.json"
    code = main(["plan", "--motor", str(PK566), "--moves", str(mix), "-o", str(out)])
    err = capsys.readouterr().err
    assert not out.exists() or code == 0
    return code, err


@pytest.mark.parametrize("text, says", [
    ("pulses,weight\n1," + "1" * 140_000 + "\n", "mix.csv, line 2: cannot be read as CSV"),
    ("pulses,weight\n1," + "1" * 5000 + "\n", "mix.csv, line 2, weight: 5000 characters"),
    ("pulses,weight\n300,1\n5,1\n", "mix.csv, line 3, pulses: 5 is outside the allowed "
                                    "range 8..4294967295"),
    ("pulses,weight\n300,nan\n", "mix.csv, line 2, weight: nan is outside"),
    ("pulses,weight\n300,1e400\n", "mix.csv, line 2, weight: inf is outside"),
    ("pulses,weight\n3x0,1\n", "mix.csv, line 2, pulses: '3x0' is not an integer"),
    ("pulses,weight\n300,1,2\n", "mix.csv, line 2: 3 fields, expected 2"),
    ("x" * 100_000 + "\n300,1\n", "the first line must be the header pulses,weight (got 'xxx"),
])
def test_plan_moves_names_the_file_line_and_field(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, says: str) -> None:
    code, err = plan_moves(tmp_path, capsys, text)
    assert code == 2 and says in err, err
    assert len(err.splitlines()) == 1 and len(err) < 300  # one short line, never the field
    assert "--pulses" not in err and "motor" not in err


def test_plan_moves_caps_its_rows(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                  monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(duty_cycle, "MIX_ROWS_MAX", 3)
    code, err = plan_moves(tmp_path, capsys, "pulses,weight\n300,1\n400,1\n300,1\n400,1\n")
    assert code == 2 and "more than 3 rows, the cap of plan --moves" in err
    monkeypatch.setattr(duty_cycle, "MIX_ROWS_MAX", 10)
    monkeypatch.setattr(duty_cycle, "MIX_LENGTHS_MAX", 1)
    code, err = plan_moves(tmp_path, capsys, "pulses,weight\n300,1\n400,1\n")
    assert code == 2 and "2 distinct move lengths, more than the 1 plan --moves takes" in err


def test_plan_moves_names_the_first_byte_that_is_not_utf8(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The words and detail a JSON input gets (profiles.reading.utf8_text)."""
    mix = tmp_path / "mix.csv"
    mix.write_bytes(b"pulses,weight\n30\xff,1\n")
    code = main(["plan", "--motor", str(PK566), "--moves", str(mix)])
    assert code == 2
    assert capsys.readouterr().err.endswith(
        "mix.csv: not a UTF-8 text file (byte 0xff at offset 16)\n")


def test_plan_moves_says_when_rows_are_merged(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    # one length (a spreadsheet's byte-order mark first): one candidate table to plan
    code, err = plan_moves(tmp_path, capsys, "\ufeffpulses,weight\n300,1\n300,2\n300,1\n")
    assert code == 0
    (note,) = err.splitlines()  # the table is -o's, the summary went to stdout
    assert note.startswith("stepramp plan: note: ") and "3 rows, 1 distinct move length " in note
    assert "1 candidate table planned" in note


@pytest.mark.parametrize("option, value", [("--load-angle", "nan"), ("--load-angle", "inf"),
                                           ("--load-angle", "-1"), ("--load-angle", "0")])
def test_plan_refuses_a_load_angle_out_of_range(capsys: pytest.CaptureFixture[str],
                                                option: str, value: str) -> None:
    assert main(["plan", "--motor", str(PK566), option, value]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"stepramp plan: {option}: ") and "allowed range 1.0..90.0" in err


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


MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


def test_cli_clock_any_case_and_error_lists_names(capsys: pytest.CaptureFixture[str],
                                                  tmp_path: Path) -> None:
    out = tmp_path / "t.json"
    code, _, _ = run(capsys, "plan", "--motor", MOTOR, "--clock", "8mhz", "--max-stages", "20",
                     "-o", out)
    assert code == 0 and load_table(out).clock == Clock.internal("8MHz")
    code, _, err = run(capsys, "plan", "--motor", MOTOR, "--clock", "9mhz")
    assert code == 2
    assert all(n in err for n in ("8MHz", "1MHz", "500kHz", "250kHz", "62.5kHz", "15.625kHz"))
    assert "Traceback" not in err


@pytest.mark.slow  # plan --kind end-to-end (the init planner's search); CI runs it
@pytest.mark.parametrize(("kind", "shape"), [("linear", "linear"), ("s-curve", "s_curve")])
def test_plan_init_table_exports_as_ascii(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                          kind: str, shape: str) -> None:
    from profiles.ppmc312.execution import simulate_move

    out = tmp_path / "init.json"
    code, summary, _ = run(capsys, "plan", "--motor", MOTOR, "--kind", kind, "--pulses",
                           "4000", "--format", "json", "-o", out)  # with -o: summary on stdout
    assert code == 0
    doc = json.loads(summary)
    table = load_table(out)
    assert isinstance(table, InitTable) and table.shape == shape and not table.separate
    assert doc["kind"] == kind and doc["pulses"] == 4000
    # the summary's time is the modelled move of the written table
    assert doc["move_time_s"] == simulate_move(table, 4000).duration_s
    # the CLI checks it clean with the motor, and exports it as an ASCII init frame
    assert run(capsys, "check", out, "--motor", MOTOR)[0] == 0
    code, frame_hex, _ = run(capsys, "export", out, "--to", "ascii", "--address", "2")
    assert code == 0
    assert decode_serial_init(bytes.fromhex(frame_hex.splitlines()[0])) == table


def test_plan_kind_refusals_name_the_options(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "plan", "--motor", MOTOR, "--kind", "linear")
    assert code == 2 and "--pulses" in err
    code, _, err = run(capsys, "plan", "--motor", MOTOR, "--kind", "s-curve", "--pulses", "9",
                       "--from", "ruckig")
    assert code == 2 and "--from" in err
    code, _, err = run(capsys, "plan", "--motor", MOTOR, "--kind", "linear", "--pulses", "9",
                       "--max-stages", "3")
    assert code == 2 and "--max-stages" in err


NEMA23 = load_motor(resolve("nema23-heavy"))


NEMA23_CAP = 10666.6667  # where its curve falls to 2 × its 0.2 N·m friction (0.4 N·m)


def test_plan_keeps_and_reports_it(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "t.json"
    code, said, err = run(capsys, "plan", "--motor", "nema23-heavy", "--pulses", "40000",
                          "-o", str(out))
    assert code == 0, err
    table = load_table(out)
    top = table.clock.hz / table.rates[0]
    assert top <= NEMA23_CAP
    assert f"top {pps(top)};" in said.splitlines()[0]
    assert (f"cruise reserve at the top speed kept (≥ 2×, ≥ 10 %): pull-out "
            f"{float(NEMA23.torque_nm(top)):.3g} N·m, "
            f"{float(NEMA23.torque_nm(top)) / 0.2:.3g}× the cruising need, "
            f"{float(NEMA23.torque_nm(top)) / 1.9 * 100:.3g} % of standstill") in said.splitlines()
    assert table.provenance is not None and table.provenance.cruise_reserve == "2x,10%"
    code, said, _ = run(capsys, "plan", "--motor", "nema23-heavy", "--pulses", "40000",
                        "--cruise-reserve", "off", "--format", "json", "-o", str(out))
    reserve = json.loads(said)["cruise_reserve"]
    assert reserve["reserve"] == "off" and reserve["speed_pps"] > NEMA23_CAP  # it binds
    assert not CruiseReserve().at(NEMA23, reserve["speed_pps"]).kept


def test_init_tables_keep_it(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "init.json"
    code, _, err = run(capsys, "plan", "--motor", "nema23-heavy", "--kind", "linear",
                       "--pulses", "40000", "--cruise-reserve", "3x", "-o", str(out))
    assert code == 0, err
    table = load_table(out)
    assert table.kind == "init"
    assert table.clock.hz / table.high_rate <= CruiseReserve(3.0).top_pps(NEMA23) + 1e-6


def test_plan_moves_from_stdin_carries_the_mix_hash(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    # --moves - is read once: the plan and its provenance (the file's hash) both need it
    import hashlib

    mix = b"pulses,weight\n2000,1\n"
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(mix)))
    out = tmp_path / "t.json"
    assert main(["plan", "--motor", "nema17-1600", "--moves", "-", "-o", str(out)]) == 0
    provenance = json.loads(out.read_text())["provenance"]
    assert provenance["pulses"] == [2000]
    assert hashlib.sha256(mix).hexdigest() in json.dumps(provenance)


PULSES = 4000


@pytest.fixture(scope="module")
def datasheet_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The datasheet NEMA17 on its lead screw (tests/support/datasheet_motor.py)."""
    return datasheet_motor_file(tmp_path_factory.mktemp("motor") / "17hs19.json",
                                "--name", "17hs19")


def test_plan_tightens_the_datasheet_motors_linear_table(
        capsys: pytest.CaptureFixture[str], tmp_path: Path, datasheet_path: Path) -> None:
    """The report's command: planned (exit 0), not refused; the table is within the aim at
    every move length and under every command by judge_safety asked here again, and the
    summary says what changed and what it cost, in numbers the table itself gives."""
    table_path = tmp_path / "lin.json"
    code, out, err = run(capsys, "plan", "--kind", "linear", "--motor", datasheet_path,
                         "--pulses", PULSES, "-o", table_path)
    assert code == 0, err  # the summary: on stdout, the table being written to its file
    table = load_table(table_path)
    motor = load_motor(datasheet_path)
    verdict = judge_safety(table, motor)
    assert verdict.moves is None and verdict.safe and verdict.within_aim, verdict.describe()
    assert {name for name, _ in verdict.commands} >= {"origin-return", "decel-stop", "constant"}
    # the plain table (the motor's own start speed) was not: the tightening did the work
    start = re.search(r"start speed lowered to ([\d ]+) pps \(from ([\d ]+) pps\) to keep the "
                      r"rotor within 75° under every command judged", out)
    assert start, out
    assert int(start[1].replace(" ", "")) == round(table.clock.hz / table.start_rate)
    assert int(start[1].replace(" ", "")) < int(start[2].replace(" ", ""))
    price = re.search(rf"price: a move of {PULSES} pulses takes ([\d.]+) ms, ([\d.]+)% longer "
                      r"than the untightened table's ([\d.]+) ms", out)
    assert price, out
    took = simulate_move(expand_init(table), PULSES).duration_s * 1e3
    assert float(price[1]) == pytest.approx(took, rel=1e-3)
    assert float(price[2]) == pytest.approx((took / float(price[3]) - 1) * 100, abs=0.06)


def test_plan_commands_narrows_the_verdict_and_refuses_an_unknown_one(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, out, err = run(capsys, "plan", "--kind", "linear", "--motor", "nema17-1600",
                         "--pulses", "2000", "--commands", "82,81", "--format", "json",
                         "-o", tmp_path / "t.json")
    assert code == 0, err
    assert list(json.loads(out)["safety"]["commands"]) == ["decel-stop"]
    code, _, err = run(capsys, "plan", "--kind", "linear", "--motor", "nema17-1600",
                       "--pulses", "2000", "--commands", "82,warp")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "'warp'" in err


@pytest.fixture
def screw(tmp_path: Path) -> str:
    """The bundled nema17-1600 with an 8 mm lead screw's travel."""
    return screw_motor_file(tmp_path)


def test_plan_gives_mm_beside_pulses(screw: str, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "t.json"
    assert main(["plan", "--motor", screw, "--pulses", "3200", "-o", str(out),
                 "--format", "json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["pulses"] == 3200 and "move_time_s" in summary   # the pulse keys stay
    assert summary["travel_mm_per_rev"] == LEAD_MM
    assert summary["move_mm"] == pytest.approx(16.0)
    per_pulse = LEAD_MM / 1600
    table = json.loads(out.read_text())
    top = 8e6 / table["rates"][0] if table["clock"] == "8MHz" else None
    if top is not None:
        assert summary["top_speed_pps"] == pytest.approx(top)
    for key in ("top_speed", "start_speed"):
        assert summary[f"{key}_mm_s"] == pytest.approx(summary[f"{key}_pps"] * per_pulse)
    assert summary["ramp_accel_mm_s2"] == pytest.approx(summary["ramp_accel_pps2"] * per_pulse)
    assert "top_speed_rpm" not in summary


def test_plan_text_says_mm_and_a_rotary_motor_rev_and_rpm(
        screw: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--motor", screw, "--pulses", "3200", "-o",
                 str(tmp_path / "t.json")]) == 0
    lines = capsys.readouterr().out.splitlines()
    [line] = [x for x in lines if x.startswith("in mm: top ")]
    assert " mm/s (from " in line and " mm/s² on average" in line
    assert "a move of 3200 pulses = 16 mm (0.005 mm per pulse)" in line
    assert main(["plan", "--motor", "nema17-1600", "--pulses", "3200", "-o",
                 str(tmp_path / "r.json"), "--format", "json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["travel_mm_per_rev"] is None and summary["move_rev"] == 2.0
    assert summary["top_speed_rpm"] == pytest.approx(summary["top_speed_pps"] * 60 / 1600)
    assert summary["ramp_accel_rev_s2"] == pytest.approx(summary["ramp_accel_pps2"] / 1600)


def test_plan_distance_mm_is_the_nearest_pulse_said_when_rounded(
        screw: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "t.json"
    assert main(["plan", "--motor", screw, "--distance-mm", "10.0012", "-o", str(out),
                 "--format", "json"]) == 0
    got = capsys.readouterr()
    summary = json.loads(got.out)
    # 10.0012 mm / 0.005 mm = 2000.24 pulses → 2000, 10 mm
    assert summary["pulses"] == 2000 and summary["move_mm"] == pytest.approx(10.0)
    assert summary["asked_move_mm"] == 10.0012
    assert ("--distance-mm 10.0012 mm is 2000 pulses (rounded to the nearest pulse): 10 mm, "
            "-0.0012 mm") in got.err
    assert json.loads(out.read_text())["provenance"]["pulses"] == [2000]
    assert main(["plan", "--motor", screw, "--distance-mm", "10", "-o", str(out)]) == 0
    assert "rounded" not in capsys.readouterr().err


def test_plan_distance_rev_on_any_motor(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--motor", "nema17-1600", "--distance-rev", "2.5", "-o",
                 str(tmp_path / "t.json"), "--format", "json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["pulses"] == 4000 and summary["asked_move_rev"] == 2.5


@pytest.mark.parametrize("argv, text", [
    (["--motor", "nema17-1600", "--distance-mm", "10"],
     "--distance-mm [mm]: motor nema17-1600 has no travel_mm_per_rev"),
    (["--motor", "SCREW", "--distance-mm", "0"],
     "--distance-mm [mm]: 0 mm is 0 pulses, outside 1..4294967295 pulses (0.005..2.14748e+07 "
     "mm at 0.005 mm per pulse)"),
    (["--motor", "SCREW", "--distance-mm", "-3"], "--distance-mm [mm]: -3 mm is -600 pulses"),
    (["--motor", "SCREW", "--distance-mm", "inf"], "--distance-mm [mm]: inf mm is not a "
                                                   "finite length"),
    (["--motor", "SCREW", "--distance-mm", "3e7"], "--distance-mm [mm]: 3e+07 mm is 6e+09"),
    (["--motor", "SCREW", "--distance-mm", "10", "--pulses", "2000"],
     "--pulses, --distance-mm and --distance-rev each give the move's length"),
    (["--motor", "SCREW", "--distance-mm", "10", "--distance-rev", "2"],
     "--pulses, --distance-mm and --distance-rev each give the move's length"),
    (["--motor", "nema17-1600", "--distance-rev", "0.0001"], "--distance-rev [rev]: 0.0001 rev"),
])
def test_plan_distance_refusals_name_the_flag_and_unit(
        argv: list[str], text: str, screw: str, capsys: pytest.CaptureFixture[str]) -> None:
    argv = [screw if a == "SCREW" else a for a in argv]
    assert main(["plan", *argv]) == 2
    err = capsys.readouterr().err
    assert text in err and len(err.splitlines()) == 1


# --- plan --from ---------------------------------------------------------------------------------
def plan_from(capsys: pytest.CaptureFixture[str], tmp_path: Path, motor: str, source: str,
              pulses: int) -> tuple[int, dict[str, Any], Path]:
    """`stepramp plan --from SOURCE` for `motor`: (exit code, its JSON or its stderr, the
    table's path)."""
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
@pytest.mark.parametrize("motor", [NEMA17, MOTORS["motor-nema23-heavy"], PK566])
def test_plan_from_every_bundled_motor_and_reference(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], motor: str, source: str,
        pulses: int) -> None:
    code, doc, out_path = plan_from(capsys, tmp_path, motor, source, pulses)
    assert code == 0, doc
    assert run(capsys, "check", out_path, "--motor", motor)[0] == 0
