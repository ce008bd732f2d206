"""Issue #20's reproducers, one test each (items 1, 7-13, 15): each exits 2 with one line
naming the right input, or gives a proper 0/1 verdict, and leaves no file behind.

Every test works in its own temporary folder (copies of the examples and motors)."""

from __future__ import annotations

import json
import os
import shutil
import threading
from pathlib import Path

import pytest

from profiles.errors import FieldRangeError, bounded, echo
from profiles.motor import bundled_motor_paths
from tests.support.cli import run
from tests.support.paths import ROOT

EXAMPLE = ROOT / "examples" / "free-curve-nema17.json"


INIT = ROOT / "examples" / "init-linear.json"


def one_line(err: str, command: str) -> str:
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"stepramp {command}: "), err
    return lines[0]


@pytest.fixture
def work(tmp_path: Path) -> Path:
    """A folder with the examples and the bundled motors where the axes files find them."""
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    (tmp_path / "profiles" / "data").mkdir(parents=True)
    for p in bundled_motor_paths():
        shutil.copy(p, tmp_path / "profiles" / "data" / p.name)
    return tmp_path


# --- 1: show on a table with a rate of 0 --------------------------------------------------------
def test_show_a_rate_of_0_is_one_line_naming_the_stage(capsys: pytest.CaptureFixture[str],
                                                         tmp_path: Path) -> None:
    doc = json.loads(EXAMPLE.read_text())
    doc["rates"][3] = 0
    f = tmp_path / "r0.json"
    f.write_text(json.dumps(doc))
    for fmt in ("text", "json", "csv"):
        code, out, err = run(capsys, "show", f, "--format", fmt)
        line = one_line(err, "show")
        assert code == 2 and out == "" and f"{f}: rates[3]: 0 is outside" in line
    code, _, err = run(capsys, "check", f)  # the chip rule is check's to report
    assert code == 1 and "rates[3] = 0" in _


# --- 7: every file sync writes carries its check ------------------------------------------------
@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
def test_alink_read_verifies_what_sync_wrote(capsys: pytest.CaptureFixture[str],
                                             work: Path) -> None:
    code, _, err = run(capsys, "sync", work / "examples" / "axes-alink.json", "-o",
                       work / "ab", "--no-ruckig")
    assert code == 0, err
    for name in ("a.commands.hex", "a.settings.json", "b.commands.hex", "b.settings.json"):
        code, _, err = run(capsys, "alink", "read", work / "ab" / name)
        assert code == 0 and err == "", (name, err)  # no "hand-made?" warning
    # a changed word is caught by the check
    f = work / "ab" / "a.commands.hex"
    f.write_text(f.read_text().replace("4112", "4113", 1))
    code, _, err = run(capsys, "alink", "read", f)
    assert code == 2 and "corrupted" in one_line(err, "alink")


# --- 8: all or none across a command's outputs --------------------------------------------------
def test_sync_plot_into_a_missing_folder_leaves_nothing(capsys: pytest.CaptureFixture[str],
                                                         work: Path) -> None:
    code, _, err = run(capsys, "sync", work / "examples" / "axes-alink.json", "-o",
                       work / "out", "--plot", work / "nodir" / "f.png", "--no-ruckig")
    assert code == 2 and "nodir does not exist" in one_line(err, "sync")
    assert not (work / "out").exists() and not (work / "nodir").exists()


def test_sync_writes_all_or_none(capsys: pytest.CaptureFixture[str], work: Path) -> None:
    """One file sync cannot write (report.json is a folder there): none of the others is
    written either, and a folder sync made itself is removed again."""
    (work / "out" / "report.json").mkdir(parents=True)
    code, _, err = run(capsys, "sync", work / "examples" / "axes-alink.json", "-o",
                       work / "out", "--no-ruckig")
    assert code == 2 and "report.json" in one_line(err, "sync")
    assert sorted(p.name for p in (work / "out").iterdir()) == ["report.json"]
    code, _, err = run(capsys, "sync", work / "examples" / "axes-alink.json", "-o",
                       work / "new", "--no-ruckig", "--plot", f"{work / 'x.png'}/")
    assert code == 2 and not (work / "new").exists()


# --- 9 and 10: -o naming a folder or an input ---------------------------------------------------
@pytest.mark.parametrize("argv", [
    ["export", "T", "-o", "OUT"], ["check", "T", "-o", "OUT"], ["show", "T", "-o", "OUT"],
    ["decode", "U", "-o", "OUT"], ["simulate", "T", "--pulses", "100", "--csv", "OUT"],
    ["expand", "I", "-o", "OUT"], ["move", "--pulses", "100", "-o", "OUT"],
])
def test_o_naming_a_folder_is_refused_before_reading(
        argv: list[str], capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    (tmp_path / "u.hex").write_bytes(b"")  # unreadable as an upload: never read
    fill = {"T": str(EXAMPLE), "I": str(INIT), "U": str(tmp_path / "u.hex")}
    (tmp_path / "d").mkdir()
    for out, says in ((f"{tmp_path}/newdir/", "ends in /"), (tmp_path / "d", "is a directory"),
                      (f"{tmp_path}/d/", "ends in /")):
        code, _, err = run(capsys, *[str(out) if a == "OUT" else fill.get(a, a)
                                     for a in argv])
        assert code == 2 and says in one_line(err, argv[0]), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d", "u.hex"]
    assert list((tmp_path / "d").iterdir()) == []


@pytest.mark.parametrize("how", ["same", "symlink", "hard link"])
@pytest.mark.parametrize("command", ["export", "check", "show", "expand"])
def test_o_naming_the_input_leaves_it_untouched(how: str, command: str,
                                                capsys: pytest.CaptureFixture[str],
                                                tmp_path: Path) -> None:
    src = INIT if command == "expand" else EXAMPLE
    t = tmp_path / "t.json"
    shutil.copy(src, t)
    out = t
    if how == "symlink":
        (tmp_path / "link.json").symlink_to("t.json")
        out = tmp_path / "link.json"
    elif how == "hard link":
        os.link(t, tmp_path / "hard.json")
        out = tmp_path / "hard.json"
    code, stdout, err = run(capsys, command, t, "-o", out)
    assert code == 2 and stdout == ""
    assert "is the input" in one_line(err, command)
    assert t.read_bytes() == src.read_bytes()


def test_an_input_through_another_option_is_guarded(capsys: pytest.CaptureFixture[str],
                                                    tmp_path: Path) -> None:
    motor = tmp_path / "m.json"
    shutil.copy(bundled_motor_paths()[0], motor)
    code, _, err = run(capsys, "check", EXAMPLE, "--motor", motor, "-o", motor)
    assert code == 2 and "is the input" in one_line(err, "check")
    assert motor.read_bytes() == bundled_motor_paths()[0].read_bytes()
    code, _, err = run(capsys, "simulate", EXAMPLE, "--pulses", "100", "--csv",
                       tmp_path / "a.csv", "--samples", tmp_path / "a.csv")
    assert code == 2 and "names the same file" in one_line(err, "simulate")
    assert not (tmp_path / "a.csv").exists()


def test_sync_never_writes_over_its_axes_file(capsys: pytest.CaptureFixture[str],
                                              work: Path) -> None:
    """An axes file named axes.json in -o's folder would be replaced by the one sync writes
    for simulate --axes: refused, nothing written."""
    folder = work / "examples"
    shutil.copy(folder / "axes-xy.json", folder / "axes.json")
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    code, _, err = run(capsys, "sync", folder / "axes.json", "-o", folder, "--no-ruckig")
    assert code == 2 and "is the input" in one_line(err, "sync")
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before


# --- 11: named pipes ---------------------------------------------------------------------------
def test_a_named_pipe_is_an_input(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    fifo = tmp_path / "t.fifo"
    os.mkfifo(fifo)

    def feed() -> None:
        with open(fifo, "wb") as fh:
            fh.write(EXAMPLE.read_bytes())

    writer = threading.Thread(target=feed, daemon=True)
    writer.start()
    code, out, err = run(capsys, "check", fifo)
    writer.join(10)
    assert code == 0 and "1 ok" in out, err


# --- 12: motor options and bounded echoes ------------------------------------------------------
CURVE = ["--curve", str(ROOT / "examples" / "curve-example.csv"), "--speed-unit", "pps",
         "--torque-unit", "Nm", "--rotor-inertia-gcm2", "50"]


DATASHEET = ["--holding-torque-nm", "0.4", "--rated-current-a", "1.5", "--resistance-ohm",
             "2", "--inductance-mh", "3", "--supply-v", "24", "--rotor-inertia-gcm2", "50"]


@pytest.mark.parametrize("argv, says", [
    ([*CURVE, "--microstep", "0"], "--microstep: 0 is outside the allowed range 1..1024"),
    ([*DATASHEET, "--microstep", "0"], "--microstep: 0 is outside the allowed range 1..1024"),
    ([*CURVE, "--phases", "3"], "argument --phases: invalid choice: 3 (choose from 2, 5)"),
    ([*DATASHEET, "--inductance-mh", "0"],
     "--inductance-mh: 0 mH is outside any stepper's phase inductance (0.05..500 mH)"),
    ([*DATASHEET[:-1], "-50"],
     "--rotor-inertia-gcm2: -50 g·cm² is outside any stepper's rotor inertia"),
])
def test_motor_new_names_the_option(argv: list[str], says: str,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "motor", "new", *argv)
    usage = says.startswith("argument")  # argparse names the sub-command
    assert code == 2 and out == "" and says in one_line(err, "motor new" if usage else "motor")


def test_a_huge_field_is_echoed_bounded(capsys: pytest.CaptureFixture[str],
                                        tmp_path: Path) -> None:
    csv = tmp_path / "big.csv"
    csv.write_text("speed,torque\n" + "1" * 131_073 + "x,0.3\n100,0.2\n")
    code, _, err = run(capsys, "motor", "new", *CURVE[:1], csv, *CURVE[2:])
    line = one_line(err, "motor")
    assert code == 2 and len(line) < 300 and "(131078 characters)" in line
    code, _, err = run(capsys, "motor", "new", *DATASHEET, "--load", "disc:" + "x" * 131_073)
    assert code == 2 and len(one_line(err, "motor")) < 300
    code, _, err = run(capsys, "export", EXAMPLE, "--format", "c", "--name", "y" * 100_000)
    assert code == 2 and len(one_line(err, "export")) < 300


def test_echo_and_bounded() -> None:
    assert echo("abc") == "'abc'" and echo(5) == "5"
    long = echo("é" * 1000)
    assert long.startswith("'éé") and long.endswith("… (1000 characters)") and len(long) < 90
    assert echo(10 ** 5000) == "an integer of about 5000 digits"  # never str(): 4300 digits
    assert len(bounded("x" * 5000)) < 1100 and bounded("short") == "short"
    e = FieldRangeError("f", "v" * 10_000, 0, 1)
    assert len(str(e)) < 200 and "(10000 characters)" in str(e)
    assert "about 400 digits" not in str(FieldRangeError("f", 10 ** 400, 0, 1))


# --- 13: sync at the axes schema's pulse limit --------------------------------------------------
def test_simulate_axes_at_the_pulse_limit(capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path) -> None:
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.table import FreeCurveTable, dump_table

    for name, table in (("x", FreeCurveTable(Clock.internal("1MHz"), (100, 200), (50, 50))),
                        ("y", FreeCurveTable(Clock.internal("1MHz"), (430, 800), (20, 20)))):
        (tmp_path / f"{name}.table.json").write_text(dump_table(table))
    (tmp_path / "axes.json").write_text(json.dumps(
        {"format": "stepramp.axes/1", "mode": "line", "axes": [
            {"name": "x", "table": "x.table.json", "pulses": 0xFFFFFFFF},
            {"name": "y", "table": "y.table.json", "pulses": -1_000_000_000}]}))
    code, out, err = run(capsys, "simulate", "--axes", tmp_path / "axes.json", "--format",
                         "json")
    assert code == 0, err
    doc = json.loads(out)
    assert [a["pulses"] for a in doc["axes"]] == [0xFFFFFFFF, 1_000_000_000]
    assert doc["max_line_deviation_pulses"] > 1e5  # 2325.58 pps against 10 000: the drift


@pytest.mark.slow
def test_sync_at_the_pulse_limit(capsys: pytest.CaptureFixture[str], work: Path) -> None:
    axes = json.loads((work / "examples" / "axes-xy.json").read_text())
    axes["axes"][0]["pulses"] = 0xFFFFFFFF
    axes["axes"][1]["pulses"] = -1_000_000_000
    f = work / "examples" / "big.json"
    f.write_text(json.dumps(axes))
    code, _, err = run(capsys, "sync", f, "-o", work / "big", "--no-ruckig")
    assert code in (0, 1), err
    report = json.loads((work / "big" / "report.json").read_text())
    assert [a["pulses"] for a in report["axes"]] == [0xFFFFFFFF, -1_000_000_000]
    assert report["finish_spread_s"] <= report["finish_spread_tolerance_s"]


# --- 15: expand gives check's verdict ----------------------------------------------------------
def test_expand_exits_1_where_check_and_export_do(capsys: pytest.CaptureFixture[str],
                                                  tmp_path: Path) -> None:
    doc = json.loads(INIT.read_text())
    doc["start_rate"] = doc["high_rate"] + 50  # less than 0x80 apart: chip code 02
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(doc))
    verdicts = {}
    for command in ("check", "export", "expand"):
        code, _, err = run(capsys, command, f, *(["-o", tmp_path / "out"]
                                                 if command != "check" else []))
        verdicts[command] = code
        if command != "check":
            assert "error [init-gap] (chip 0x02)" in err and "refused" in err
    assert verdicts == {"check": 1, "export": 1, "expand": 1}
    assert not (tmp_path / "out").exists()
    code, out, _ = run(capsys, "expand", INIT)
    assert code == 0 and '"kind": "free_curve"' in out


def test_plan_moves_with_an_empty_file_name_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # `--moves ''` planned without the mix and exited 0 (an empty string is falsy)
    out = tmp_path / "t.json"
    code, _, err = run(capsys, "plan", "--motor", "nema17-1600", "--moves", "", "-o", out)
    assert code == 2 and "empty file name" in err and not out.exists()


@pytest.mark.parametrize("command", ["check", "sweep"])
def test_samples_are_bounded(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                             command: str) -> None:
    # an unbounded --samples ran out of memory
    args = (["check", "examples/free-curve-nema17.json", "--motor", "nema17-1600"]
            if command == "check" else
            ["sweep", "--motors", "nema17-1600", "--pulses", "2000", "-o", tmp_path / "s.csv"])
    code, _, err = run(capsys, *args, "--samples", "10000000")
    assert code == 2 and "at most 100000" in err and len(err.strip().splitlines()) == 1
