"""Library functions the thin CLI calls: A-Link settings rendering, MC-200 streams,
the simulate CSV files. Each checked against numbers computed here independently."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import zlib
from pathlib import Path

import numpy as np
import pytest

from profiles import alink as A
from profiles import mc200 as M
from profiles.errors import FormatError
from profiles.motor import load_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import pulse_times_csv, samples_csv, simulate_move
from profiles.ppmc312.table import FreeCurveTable
from tests.support.paths import ROOT

MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"
MHZ1 = Clock.internal("1MHz")
TABLE = FreeCurveTable(MHZ1, (100, 200, 300, 400), (10, 20, 30, 40))


# --- A-Link settings documents ---------------------------------------------------------------

def _doc() -> dict:
    s = A.quantise_settings(500, 12345, 3.35)
    cmds = A.settings_commands(s, slave_address=5)
    return A.settings_document(s, cmds, summary={"predicted_time_s": 0.25}, warnings=["w"])


def test_settings_document_fields() -> None:
    doc = _doc()
    assert (doc["start_pps"], doc["high_pps"], doc["up_time_para"]) == (500, 12345, 335)
    assert doc["accel_ms_per_kpps"] == 3.35 and doc["predicted_time_s"] == 0.25
    assert doc["warnings"] == ["w"]
    assert [c["name"] for c in doc["commands"]] == ["MAX_SPEED", "MODE", "H_SPEED", "L_SPEED",
                                                    "UP_TIME"]
    first = doc["commands"][0]
    assert first["address"] == f"0x{A.command_address(5):03X}"
    words = [int(w, 16) for w in first["words"]]
    assert A.parse_command(*words) == (A.Cmd.MAX_SPEED, 1, 0, 1)  # pair code 1 first


def test_render_settings_hex_and_json_agree() -> None:
    doc = _doc()
    *hex_rows, check = A.render_settings(doc, "hex").splitlines()
    assert [[int(w, 16) for w in row.split()] for row in hex_rows] == [
        [int(w, 16) for w in c["words"]] for c in doc["commands"]]
    payload = b"".join(int(w, 16).to_bytes(2, "little") for c in doc["commands"]
                       for w in c["words"])
    crc = f"{zlib.crc32(payload):08X}"  # zlib's, independent of stepramp's
    assert check.startswith(f"# crc32 {crc}: ")
    assert json.loads(A.render_settings(doc, "json")) == {**doc, "crc32": crc}
    text = A.render_settings(doc, "text")
    assert "predicted_time_s: 0.25" in text and "warning: w" in text
    with pytest.raises(FormatError, match="format"):
        A.render_settings(doc, "xml")


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_render_settings_c_compiles(tmp_path: Path) -> None:
    (tmp_path / "a.h").write_text(A.render_settings(_doc(), "c"))
    (tmp_path / "m.c").write_text('#include "a.h"\nint main(void) '
                                  "{ return (int)stepramp_alink_words[4][0] & 0; }\n")
    done = subprocess.run(["gcc", "-Wall", "-Wextra", "-Werror", "-c", "m.c", "-o", "m.o"],
                          cwd=tmp_path, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr


# --- MC-200 streams ------------------------------------------------------------------------

def test_plan_stream_from_limits_ends_at_the_target() -> None:
    packets, duration = M.plan_stream(5000, period_us=1000, v_max_pps=20000.0,
                                      a_max_pps2=2e5, j_max_pps3=5e7)
    _, ruckig_duration = M.ruckig_profile(5000, 20000.0, 2e5, 5e7)
    assert duration == ruckig_duration
    assert len(packets) == 5 + math.ceil(duration / 1e-3 - 1e-9) + 10
    state = M.DriverModel().feed(packets)
    assert state.servo_on and state.command == 5000 and not state.spi_error


def test_plan_stream_from_motor_follows_the_chip_staircase() -> None:
    from profiles.ppmc312.planner import plan_free_curve

    motor = load_motor(MOTOR)
    run = simulate_move(plan_free_curve(motor, pulses=3000).table, 3000)
    packets, duration = M.plan_stream(3000, period_us=500,
                                      profile=(run.position_at, run.duration_s))
    assert duration == run.duration_s
    commands = [p.value for p in packets[5:-10]]
    t = np.minimum(np.arange(1, len(commands) + 1) * 500e-6, duration)
    assert commands == [int(x) for x in run.position_at(t)]


def test_plan_stream_needs_a_profile_or_all_limits() -> None:
    with pytest.raises(FormatError, match="j_max_pps3"):
        M.plan_stream(100, period_us=1000, v_max_pps=1.0, a_max_pps2=1.0)
    with pytest.raises(FormatError, match="not both"):
        M.plan_stream(100, period_us=1000, profile=M.ruckig_profile(100, 1e3, 1e4, 1e6),
                      v_max_pps=1.0)


def test_render_stream_formats() -> None:
    packets, duration = M.plan_stream(500, period_us=1000, v_max_pps=5000.0,
                                      a_max_pps2=5e4, j_max_pps3=5e6)
    raw = M.render_stream(packets, "bin", period_us=1000, duration_s=duration, pulses=500)
    assert isinstance(raw, bytes) and len(raw) == 12 * len(packets)
    text = M.render_stream(packets, "hex", period_us=1000, duration_s=duration, pulses=500)
    assert text.startswith(M.render_hex(packets)) and text.count("\n# crc32 ") == 1
    assert M.decode_stream(raw) == M.decode_stream(text.partition("#")[0])
    doc = json.loads(M.render_stream(packets, "json", period_us=1000, duration_s=duration,
                                     pulses=500))
    assert (doc["pulses"], doc["period_us"], len(doc["packets"])) == (500, 1000, len(packets))
    assert bytes.fromhex(doc["packets"][0]) == raw[:12]
    with pytest.raises(FormatError, match="format"):
        M.render_stream(packets, "csv", period_us=1000, duration_s=duration, pulses=500)


# --- simulate CSV files ----------------------------------------------------------------------

def test_pulse_times_csv_from_the_segments() -> None:
    run = simulate_move(TABLE, 150)
    expected = []  # every pulse ends one rate after the previous, segment by segment
    for s in run.segments:
        expected += [(s.start_tick + s.rate * (k + 1)) / 1e6 for k in range(s.pulses)]
    rows = pulse_times_csv(run).splitlines()
    assert rows[0] == "pulse,time_s" and len(rows) == 151
    for i, row in enumerate(rows[1:], start=1):
        n, t = row.split(",")
        assert int(n) == i and float(t) == pytest.approx(expected[i - 1], abs=1e-9)


def test_samples_csv_rows() -> None:
    run = simulate_move(TABLE, 150)
    rows = [r.split(",") for r in samples_csv(run, 11).splitlines()]
    assert rows[0] == ["t_s", "x_pulses", "v_pps", "a_pps2"] and len(rows) == 12
    assert float(rows[1][0]) == 0 and float(rows[-1][0]) == pytest.approx(run.duration_s)
    assert float(rows[-1][1]) == 150
    # a speed inside the move is 1 MHz over the running segment's rate
    t_mid, v_mid = float(rows[6][0]), float(rows[6][2])
    tick = t_mid * 1e6
    seg = next(s for s in run.segments if s.start_tick <= tick < s.end_tick)
    assert v_mid == pytest.approx(1e6 / seg.rate)
