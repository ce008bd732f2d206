"""`stepramp sync` and `stepramp simulate --axes`: files, report, exit codes; the A-Link."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest

from profiles import alink
from profiles.alink.formats import parse as alink_parse
from profiles.alink.formats import parse_c_set as alink_parse_c_set
from profiles.alink.sync import (
    MODE_SIG_STA,
    pulse_times_s,
)
from profiles.joint import spread_tolerance_s
from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312 import decode_upload
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.formats import parse, parse_c_set
from profiles.ppmc312.table import load_table
from profiles.ppmc312.upload import decode_move
from tests.support.figures import record_saved, scale_labels
from tests.support.paths import ROOT
from verify.cli import main
from verify.criterion import check_stall
from verify.devices import load_axes
from verify.safety import judge_safety
from verify.sync import output_names

MOTORS = [load_motor(p) for p in bundled_motor_paths()]


NEMA17, NEMA23, PK566 = MOTORS


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int, str]:
    root = tmp_path_factory.mktemp("sync")
    shutil.copytree(ROOT / "examples", root / "examples")
    (root / "profiles" / "data").mkdir(parents=True)
    for p in bundled_motor_paths():
        shutil.copy(p, root / "profiles" / "data" / p.name)
    code = main(["sync", str(root / "examples" / "axes-xy.json"), "-o", str(root / "out"),
                 "--mode", "line", "--plot", str(root / "xy.png")])
    return root, code, "line"


@pytest.mark.slow  # stepramp sync end-to-end (the module's `written` run); CI runs it
def test_sync_writes_every_file(written: tuple[Path, int, str]) -> None:
    root, code, _ = written
    assert code == 0
    out = root / "out"
    names = {p.name for p in out.iterdir()}
    for axis in ("x", "y"):
        assert {f"{axis}.table.json", f"{axis}.upload.hex", f"{axis}.upload.ihex",
                f"{axis}.move.hex"} <= names
    assert {"axes.h", "axes.json", "report.json"} <= names
    assert names == set(output_names(["x", "y"], "ppmc312"))  # what -o is checked for
    assert (root / "xy.png").stat().st_size > 10_000


@pytest.mark.slow  # stepramp sync end-to-end (the module's `written` run); CI runs it
def test_report_matches_the_written_tables(written: tuple[Path, int, str]) -> None:
    root, _, mode = written
    out = root / "out"
    report = json.loads((out / "report.json").read_text())
    assert report["mode"] == mode and report["device"] == "ppmc312"
    durations = []
    for item in report["axes"]:
        table = load_table(out / f"{item['name']}.table.json")
        run = simulate_move(table, abs(item["pulses"]))
        assert item["duration_s"] == run.duration_s   # as simulate computes it
        durations.append(run.duration_s)
        # every table judged over every move length by both judges: the one verdict
        motor = load_axes(root / "examples" / "axes-xy.json").axes[
            [a["name"] for a in report["axes"]].index(item["name"])].motor
        assert item["safety"] == judge_safety(table, motor).to_json()
        assert item["safety"]["safe"] and item["safety"]["criterion_findings"] == []
        assert item["safety"]["moves"] == "every"
        assert item["safety"]["within_aim"] and item["safe"]  # planned like `plan` plans
        # the upload files decode back to the table, each verified by its own check
        for ext in ("hex", "ihex"):
            parsed = parse((out / f"{item['name']}.upload.{ext}").read_bytes())
            assert parsed.integrity == "verified" and decode_upload(parsed.items) == table
        parsed = parse((out / f"{item['name']}.move.hex").read_bytes())
        assert parsed.integrity == "verified"
        move = decode_move(parsed.items[0])
        assert move == {"pulses": abs(item["pulses"]), "ccw": item["pulses"] < 0,
                        "high_rate": 0, "override": True, "trigger": 1}
        assert not check_stall(table, NEMA17 if item["name"] == "x" else PK566)
    assert report["finish_spread_s"] == pytest.approx(max(durations) - min(durations), abs=1e-12)
    assert report["finish_spread_s"] <= spread_tolerance_s(max(durations))
    assert report["max_line_deviation_pulses"] < 3
    assert report["ruckig"]["phase_synchronised_s"] >= report["ruckig"]["time_synchronised_s"]


@pytest.mark.slow  # stepramp sync end-to-end (the module's `written` run); CI runs it
def test_c_header_compiles_with_distinct_prefixes(written: tuple[Path, int, str],
                                                   tmp_path: Path) -> None:
    root, _, _ = written
    text = (root / "out" / "axes.h").read_text()
    assert "x_block_0" in text and "y_block_0" in text and "x_move_block_0" in text
    assert "stepramp_block" not in text
    # every upload in it (each axis's table and move command) is read back verified
    uploads = parse_c_set(text.encode())
    assert sorted(uploads) == ["x", "x_move", "y", "y_move"]
    assert all(p.integrity == "verified" for p in uploads.values())
    for name in ("x", "y"):
        table = load_table(root / "out" / f"{name}.table.json")
        assert decode_upload(uploads[name].items) == table
        assert uploads[f"{name}_move"].items == parse(
            (root / "out" / f"{name}.move.hex").read_bytes()).items
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    main_c = tmp_path / "main.c"
    main_c.write_text('#include "axes.h"\n#include "axes.h"\nint main(void) { return '
                      '(int)(X_BLOCK_COUNT + Y_BLOCK_COUNT + x_move_block_0[0] + '
                      'y_move_blocks[0][0] + X_MOVE_CRC32 + x_block_lengths[0] + y_blocks[0][0])'
                      ' > 0 ? 0 : 1; }\n')
    done = subprocess.run([cc, "-std=c99", "-Wall", "-Werror", "-Wno-unused-const-variable",
                           "-I", str(root / "out"), str(main_c), "-o", str(tmp_path / "a.out")],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert subprocess.run([str(tmp_path / "a.out")]).returncode == 0


@pytest.mark.slow  # stepramp sync end-to-end (the module's `written` run); CI runs it
def test_simulate_axes_prints_the_joint_timeline(written: tuple[Path, int, str],
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    root, _, _ = written
    report = json.loads((root / "out" / "report.json").read_text())
    assert main(["simulate", "--axes", str(root / "out" / "axes.json")]) == 0
    text = capsys.readouterr().out
    assert "x  accel" in text and "y  done: 5000 pulses" in text
    assert text.splitlines()[-1] == (
        f"finish spread {report['finish_spread_s'] * 1e6:.3f} µs, line deviation "
        f"{report['max_line_deviation_pulses']:.4g} pulses")
    assert main(["simulate", "--axes", str(root / "out" / "axes.json"), "--format",
                 "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["max_line_deviation_pulses"] == pytest.approx(
        report["max_line_deviation_pulses"], rel=1e-12)
    durations = [a["duration_s"] for a in doc["axes"]]
    assert doc["finish_spread_s"] == pytest.approx(max(durations) - min(durations), abs=1e-12)
    assert doc["finish_spread_s"] == pytest.approx(report["finish_spread_s"], abs=1e-12)


@pytest.mark.parametrize("argv", [
    ["simulate", "--axes", "examples/axes-xy.json"],          # motors, not tables
    ["simulate", "--axes", "missing.json"],
    ["simulate", "examples/free-curve-nema17.json"],           # no --pulses
    ["sync", "missing.json", "-o", "out"],
    ["sync", "examples/free-curve-nema17.json", "-o", "out"],  # not an axes file
    ["sync", "examples/axes-xy.json", "-o", "out", "--plot", "x.pdf"],
])
def test_unusable_input_exits_2_with_one_line_and_no_files(
        argv: list[str], written: tuple[Path, int, str], tmp_path: Path,
        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    root, _, _ = written
    shutil.copytree(root / "examples", tmp_path / "examples")
    shutil.copytree(root / "profiles", tmp_path / "profiles")
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_alink_pulse_times_end_at_the_modelled_duration() -> None:
    s = alink.AlinkSettings(800, 20_000, 200)
    for n in (50, 3_000, 40_000):   # a triangle and trapezoids
        t = pulse_times_s(s, n)
        assert len(t) == n and (t[1:] > t[:-1]).all()
        assert t[-1] == pytest.approx(alink.move_time_s(s, n).duration_s, rel=1e-9)


def test_alink_sync_cli_writes_commands_with_sta(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    (tmp_path / "profiles" / "data").mkdir(parents=True)
    for p in bundled_motor_paths():
        shutil.copy(p, tmp_path / "profiles" / "data" / p.name)
    assert main(["sync", str(tmp_path / "examples" / "axes-alink.json"), "-o",
                 str(tmp_path / "ab"), "--no-ruckig"]) == 0
    report = json.loads((tmp_path / "ab" / "report.json").read_text())
    assert report["device"] == "alink" and "ruckig" not in report
    assert {p.name for p in (tmp_path / "ab").iterdir()} == set(output_names(["a", "b"],
                                                                             "alink"))
    header = alink_parse_c_set((tmp_path / "ab" / "axes.h").read_bytes())
    assert sorted(header) == ["a", "b"]
    for item in report["axes"]:
        # every file carries its CRC-32 and is read back verified
        parsed = alink_parse((tmp_path / "ab" / f"{item['name']}.commands.hex").read_bytes())
        assert parsed.integrity == "verified"
        decoded = [(c.cmd, c.func, c.para) for c in parsed.items]
        cmds = [d[0] for d in decoded]
        assert cmds[-2:] == [alink.Cmd.MODE_SIG, alink.Cmd.MOVE_R]
        assert decoded[-2][2] == MODE_SIG_STA and decoded[-1][2] == item["pulses"]
        assert header[item["name"]].integrity == "verified"
        assert [c.words for c in header[item["name"]].items] == [c.words for c in parsed.items]
        settings = alink_parse((tmp_path / "ab" / f"{item['name']}.settings.json").read_bytes())
        assert settings.integrity == "verified"
        assert [c.words for c in settings.items] == [c.words for c in parsed.items[:-2]]
        s = alink.settings_from_commands(settings.items)
        assert (s.start_pps, s.high_pps, s.accel_para) == (
            item["start_pps"], item["high_pps"], item["up_time_para"])


def test_simulate_axes_reports_the_spread_of_tables_that_do_not_end_together(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Two axes running one table for different lengths: the spread is their difference."""
    table = ROOT / "examples" / "free-curve-nema17.json"
    axes = {"format": "stepramp.axes/1", "mode": "time", "axes": [
        {"name": "x", "table": str(table), "pulses": 1000},
        {"name": "y", "table": str(table), "pulses": -3000}]}
    (tmp_path / "axes.json").write_text(json.dumps(axes))
    assert main(["simulate", "--axes", str(tmp_path / "axes.json"), "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    loaded = load_table(table)
    spread = simulate_move(loaded, 3000).duration_s - simulate_move(loaded, 1000).duration_s
    assert spread > 0
    assert doc["finish_spread_s"] == pytest.approx(spread, rel=1e-12)


@pytest.mark.slow  # plans a two-axis line move (~3 s); CI runs it
def test_sync_scales_in_mm_when_every_axis_shares_its_units(
        tmp_path: Any, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from verify import cli

    motor = json.loads(bundled_motor_paths()[0].read_text())
    (tmp_path / "m.json").write_text(json.dumps({**motor, "travel_mm_per_rev": 8.0}))
    (tmp_path / "axes.json").write_text(json.dumps({
        "format": "stepramp.axes/1", "mode": "line",
        "axes": [{"name": "x", "motor": "m.json", "pulses": 4000},
                 {"name": "y", "motor": "m.json", "pulses": -1500}]}))
    saved = record_saved(monkeypatch)
    assert cli.main(["sync", str(tmp_path / "axes.json"), "-o", str(tmp_path / "out"),
                     "--no-ruckig", "--plot", str(tmp_path / "s.png")]) in (0, 1)
    path_ax, _, speed_ax = saved[0].axes
    assert sorted(scale_labels(path_ax)) == ["position [mm]", "position [mm]"]
    assert scale_labels(speed_ax) == ["speed [mm/s]"]
