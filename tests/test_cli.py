"""The `stepramp` command: exit codes, output shapes, bad input, no half-written files."""

from __future__ import annotations

import json
import subprocess
import sys
import zlib
from pathlib import Path

import pytest

from profiles.ppmc312.emulator import expected_answers
from profiles.ppmc312.formats import parse_upload
from profiles.ppmc312.table import load_table
from profiles.ppmc312.upload import decode_move, decode_upload, encode_table
from tests.support.paths import ROOT
from verify.cli import main

GOOD = ROOT / "examples" / "free-curve-nema17.json"
BAD = ROOT / "examples" / "free-curve-bad.json"
INIT = ROOT / "examples" / "init-linear.json"


def run(capsys: pytest.CaptureFixture[str], *argv: str | Path) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_check_good_and_bad(capsys: pytest.CaptureFixture[str]) -> None:
    assert run(capsys, "check", GOOD, INIT)[0] == 0
    code, out, _ = run(capsys, "check", GOOD, BAD)
    assert code == 1
    assert "chip 0x18" in out and "chip 0x19" in out


def test_check_json_shape(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "check", GOOD, BAD, "--format", "json")
    assert code == 1
    doc = json.loads(out)
    assert [f["path"] for f in doc["files"]] == [str(GOOD), str(BAD)]
    assert doc["files"][0]["ok"] is True and doc["files"][1]["ok"] is False
    finding = next(f for f in doc["files"][1]["findings"] if f["chip_code"] == "0x18")
    assert set(finding) == {"severity", "rule", "chip_code", "stage", "message"}
    assert finding["severity"] == "error" and finding["stage"] == 0


def test_check_upload_files_by_what_the_chip_answers(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    hexfile = tmp_path / "good.upload.hex"
    assert run(capsys, "export", GOOD, "--format", "hex", "-o", hexfile)[0] == 0
    assert run(capsys, "check", hexfile)[0] == 0
    binfile = tmp_path / "good.upload.bin"
    assert run(capsys, "export", GOOD, "--format", "bin", "-o", binfile)[0] == 0
    assert run(capsys, "check", binfile)[0] == 0
    # an upload whose stage count the chip refuses (0x11): one stage only
    # hand-edited, without the CRC line: judged (with a warning) by what the chip answers
    lines = [line for line in hexfile.read_text().splitlines() if not line.startswith("#")]
    first = lines[0].split()
    first[4] = "01"
    (tmp_path / "bad.upload.hex").write_text(" ".join(first) + "\n" + "\n".join(lines[1:]))
    code, out, _ = run(capsys, "check", tmp_path / "bad.upload.hex", "--format", "json")
    assert code == 1
    codes = {f["chip_code"] for f in json.loads(out)["files"][0]["findings"]}
    assert "0x11" in codes


def test_export_decode_round_trip(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    table = load_table(GOOD)
    for fmt in ("hex", "bin", "json"):
        out = tmp_path / f"t.{fmt}"
        assert run(capsys, "export", GOOD, "--format", fmt, "-o", out)[0] == 0
        back = tmp_path / f"back-{fmt}.json"
        assert run(capsys, "decode", out, "-o", back)[0] == 0
        assert load_table(back) == table
    assert decode_upload(parse_upload((tmp_path / "t.hex").read_bytes())) == table


def test_export_hex_format_is_exact(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "export", GOOD, "--format", "hex")
    assert code == 0
    blocks = encode_table(load_table(GOOD))
    answers = expected_answers(blocks) or []
    payload = b"".join(blocks)
    # each block, then the answer the chip gives to it (the handshake, manual §7-2)
    assert out == "".join(b.hex(" ").upper() + "\n# answer: " + a.hex(" ").upper() + "\n"
                          for b, a in zip(blocks, answers, strict=True)) + (
        f"# crc32 {zlib.crc32(payload):08X}: CRC-32 of the {len(payload)} bytes above\n")
    assert out.splitlines()[0].startswith("02 ")
    assert out.splitlines()[-3].startswith("01 ")
    assert out.splitlines()[-2].startswith("# answer: 03 08 01 0F ")


def test_export_ascii_init_frame(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "export", INIT, "--to", "ascii", "--address", "3",
                       "--format", "hex")
    assert code == 0
    frame = bytes.fromhex(out.splitlines()[0])
    assert frame[0] == 0x93  # command frame to slave 3
    assert all(0x30 <= b < 0x7F for b in frame[1:])


def test_export_refuses_table_with_errors(capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path) -> None:
    out = tmp_path / "bad.hex"
    code, _, err = run(capsys, "export", BAD, "-o", out)
    assert code == 1 and "--force" in err
    assert not out.exists()
    assert run(capsys, "export", BAD, "--force", "-o", out)[0] == 0
    assert out.read_text().startswith("02 ")


@pytest.mark.parametrize("content, match", [
    ("", "empty"),
    ("{not json", "not valid JSON"),
    ('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "free_curve", '
     '"clock": "8MHz", "rates": [400, 70000], "accel_pulses": [10, 10]}', "65535"),
    ('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "free_curve", '
     '"clock": "8MHz", "rates": [400, 800], "accel_pulses": [10, -3]}', "accel_pulses"),
    ('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "free_curve", '
     '"clock": "8MHz", "rates": [400, 800], "accel_pulses": [10, 3], "extra": 1}', "unknown"),
    ('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "free_curve", '
     '"clock": "9MHz", "rates": [400, 800], "accel_pulses": [10, 3]}', "clock"),
])
def test_bad_table_files_exit_2_with_one_line(capsys: pytest.CaptureFixture[str],
                                              tmp_path: Path, content: str, match: str) -> None:
    path = tmp_path / "t.json"
    path.write_text(content)
    out = tmp_path / "out.hex"
    code, _, err = run(capsys, "export", path, "-o", out)
    assert code == 2
    assert match in err and len(err.strip().splitlines()) == 1
    assert "Traceback" not in err
    assert not out.exists() and list(tmp_path.iterdir()) == [path]


@pytest.mark.parametrize("content", ["02 03 01 00\n", "zz 01\n", "02 03 01 00 1A\n01 04 01 90",
                                     "\x00\x01\x02"])
def test_corrupt_uploads_exit_2(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                content: str) -> None:
    path = tmp_path / "u.hex"
    path.write_text(content)
    out = tmp_path / "t.json"
    code, _, err = run(capsys, "decode", path, "-o", out)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not out.exists()


def test_missing_file_and_bad_arguments(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "check", "/nonexistent.json", "--format", "json")
    assert code == 2
    assert "no such file" in json.loads(out)["files"][0]["error"]
    assert run(capsys, "export", GOOD, "--address", "-1")[0] == 2
    assert run(capsys, "export", GOOD, "--to", "ascii", "--address", "16")[0] == 2
    assert run(capsys, "frobnicate")[0] == 2


def test_check_junit_is_xml(capsys: pytest.CaptureFixture[str]) -> None:
    import xml.etree.ElementTree as ET

    code, out, _ = run(capsys, "check", GOOD, BAD, "--format", "junit")
    assert code == 1
    root = ET.fromstring(out)
    assert len(root.findall(".//testcase")) == 2
    assert root.findall(".//failure")


def test_console_script_cold_imports_nothing_heavy() -> None:
    # numpy too: a table's checks are plain Python over at most 127 stages; numpy's
    # import is 0.12 s, most of what a cold start would otherwise cost
    code = ("import sys; from verify import cli; "
            "rc = cli.main(['check', sys.argv[1]]); "
            "heavy = [m for m in ('toppra', 'casadi', 'matplotlib', 'ruckig', 'numba', "
            "'numpy') "
            "if m in sys.modules]; print(rc, heavy)")
    res = subprocess.run([sys.executable, "-c", code, str(GOOD)], capture_output=True,
                         text=True, cwd=ROOT, check=False)
    assert res.stdout.strip().splitlines()[-1] == "0 []", res.stdout + res.stderr


def test_expand_init_table(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from profiles.ppmc312.init_model import expand_init
    from profiles.ppmc312.table import FreeCurveTable

    out = tmp_path / "free.json"
    assert run(capsys, "expand", INIT, "-o", out)[0] == 0
    free = load_table(out)
    assert isinstance(free, FreeCurveTable)
    assert free == expand_init(load_table(INIT))  # type: ignore[arg-type]
    init = load_table(INIT)
    assert free.accel_total == init.accel_pulses  # type: ignore[union-attr]
    assert run(capsys, "expand", GOOD)[0] == 2


def test_move_command_bytes(capsys: pytest.CaptureFixture[str]) -> None:
    from profiles.ppmc312.ascii import decode_serial_move

    code, out, _ = run(capsys, "move", "--pulses", "0x12345678", "--ccw", "--format", "bus")
    assert code == 0
    # the manual's bus example order (§5-6): last byte first, header last
    assert out.splitlines()[-5:-1] == ["DWR 40", "DWR 82", "DWR 08", "DWR 03"]
    code, out, _ = run(capsys, "move", "--pulses", "5000", "--high-rate", "300")
    assert decode_move(bytes.fromhex(out.splitlines()[0])) == {
        "pulses": 5000, "ccw": False, "high_rate": 300, "override": False, "trigger": 0}
    code, out, _ = run(capsys, "move", "--pulses", "5000", "--to", "ascii", "--address", "2")
    assert decode_serial_move(bytes.fromhex(out.splitlines()[0]))["pulses"] == 5000
    assert run(capsys, "move", "--pulses", "0")[0] == 2
    assert run(capsys, "move", "--pulses", "9", "--to", "ascii", "--override", "1")[0] == 2


@pytest.mark.parametrize(("trg", "code"), [("1", 0), ("3", 0), ("0", 2), ("2", 2)])
def test_move_override_takes_the_triggers_the_chip_accepts(
        capsys: pytest.CaptureFixture[str], trg: str, code: int) -> None:
    """SPEC §1: with OV = 1, TRG 01 and 11 register; 00 and 10 are a parameter error."""
    got, out, err = run(capsys, "move", "--pulses", "9", "--override", trg)
    assert got == code
    if code == 0:
        assert decode_move(bytes.fromhex(out.splitlines()[0]))["trigger"] == int(trg)
    else:
        assert "--override: invalid choice" in err


def test_decode_table_read_response(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from profiles.ppmc312.formats import render
    from profiles.ppmc312.upload import encode_table_read_response

    table = load_table(GOOD)
    path = tmp_path / "read.hex"
    path.write_bytes(render(encode_table_read_response(table), "hex"))  # type: ignore[arg-type]
    out = tmp_path / "t.json"
    assert run(capsys, "decode", path, "--table-read", "--clock", "8MHz", "-o", out)[0] == 0
    assert load_table(out) == table
    code, _, err = run(capsys, "decode", path, "--table-read")
    assert code == 2 and "--clock" in err


def test_simulate_pulse_times_and_samples(capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path) -> None:
    from profiles.ppmc312.execution import simulate_move

    run_ = simulate_move(load_table(GOOD), 3000)
    pt, sm = tmp_path / "pt.csv", tmp_path / "s.csv"
    code, out, _ = run(capsys, "simulate", GOOD, "--pulses", "3000", "--pulse-times", pt,
                       "--samples", sm)
    assert code == 0 and "trapezoid" in out
    rows = pt.read_text().splitlines()
    assert rows[0] == "pulse,time_s" and len(rows) == 3001
    assert float(rows[-1].split(",")[1]) == pytest.approx(run_.duration_s, abs=1e-9)
    samples = sm.read_text().splitlines()
    assert samples[0] == "t_s,x_pulses,v_pps,a_pps2" and len(samples) == 1001
    assert float(samples[-1].split(",")[1]) == 3000


def test_check_with_motor_on_an_init_table_the_chip_refuses(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    # No stages can be built, so there is nothing to judge for stall-safety: the chip's
    # error is the finding (exit 1), not "unusable input".
    path = tmp_path / "init.json"
    path.write_text('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "init", '
                    '"clock": "8MHz", "shape": "linear", "start_rate": 400, '
                    '"high_rate": 400, "accel_pulses": 2000}')
    motor = ROOT / "profiles" / "data" / "motor-nema17-1600.json"
    code, out, _ = run(capsys, "check", path, "--motor", motor, "--format", "json")
    assert code == 1
    assert [f["chip_code"] for f in json.loads(out)["files"][0]["findings"]] == ["0x03"]


@pytest.mark.parametrize("argv, named", [
    (["answer", "03", "01", "-inf"], "stepramp answer:"),
    (["check", "x.json", "--no-such-option"], "stepramp check:"),
    (["alink", "decode", "0", "0", "0", "-1e9"], "stepramp alink:"),
])
def test_unrecognized_arguments_name_the_command(argv: list[str], named: str,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(named) and "unrecognized arguments" in err and err.count("\n") == 1


def test_plan_moves_from_stdin_carries_the_mix_hash(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    # --moves - is read once: the plan and its provenance (the file's hash) both need it
    import hashlib
    import io

    mix = b"pulses,weight\n2000,1\n"
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(mix)))
    out = tmp_path / "t.json"
    assert main(["plan", "--motor", "nema17-1600", "--moves", "-", "-o", str(out)]) == 0
    provenance = json.loads(out.read_text())["provenance"]
    assert provenance["pulses"] == [2000]
    assert hashlib.sha256(mix).hexdigest() in json.dumps(provenance)


@pytest.mark.parametrize("motor", ["nema17-1600", "nema23-heavy", "pk566-5phase-half"])
def test_plan_summary_is_short_lines_each_said_once(motor: str, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    # issue 32 item 10: what was planned, what holds it back, the reserve, the verdict,
    # the other commands: a few lines of at most 120 characters, no reason said twice
    from verify.plan_text import LINE_MAX

    monkeypatch.chdir(tmp_path)  # the last line names the table as given: a short path
    out = "t.json"
    assert main(["plan", "--motor", motor, "--pulses", "2000", "-o", out]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert 4 <= len(lines) <= 8
    assert all(len(line) <= LINE_MAX for line in lines), lines
    assert lines[0].startswith("planned: ") and " pps; a move of 2000 pulses takes " in lines[0]
    assert any(line.startswith("cruise reserve at the top speed kept (") for line in lines)
    assert any(line.startswith("verdict: SAFE for every move length: worst load angle ")
               for line in lines)
    assert lines[-1].strip() == f"stepramp check {out} --motor {motor}"
    clauses = [c.strip() for line in lines for c in line.split(";")]
    assert len(clauses) == len(set(clauses)), lines
    # the planner's jargon stays in --format json ("info")
    assert not any(word in "\n".join(lines) for word in ("info:", "×0.", "tightened where"))


def test_plan_says_what_the_tightening_changed_in_plain_words() -> None:
    # "start speed lowered to 2 840 pps …" rather than "start ×0.483"
    from types import SimpleNamespace

    from profiles.ppmc312.planner.problem import Shaping
    from verify.plan_text import LINE_MAX, _tightening

    motor = SimpleNamespace(start_pps=5880.0)
    assert _tightening(Shaping.uniform(0.483), motor, 75.0) == [
        "start speed lowered to 2 840 pps (from 5 880 pps)",
        "ramp made gentler everywhere (48% of the torque it could use) to keep the rotor "
        "within 75°"]
    assert _tightening(Shaping((), (1.0,), 0.483), motor, 75.0) == [
        "start speed lowered to 2 840 pps (from 5 880 pps) to keep the rotor within 75°"]
    banded = Shaping((9112.0, 30755.0), (1.0, 0.93, 1.0), 0.5)
    lines = _tightening(banded, motor, 75.0)
    assert lines == ["start speed lowered to 2 940 pps (from 5 880 pps)",
                     "ramp made gentler between 9 112 and 30 755 pps (down to 93% of the torque "
                     "it could use) to keep the rotor within 75°"]
    assert all(len(line) <= LINE_MAX for line in lines)
