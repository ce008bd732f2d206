"""`stepramp mc200` (verify/cli/mc200.py): streams, follow, decode, in every control mode."""

from __future__ import annotations

import io
import json
import sys
from pathlib import Path

import pytest

from profiles import mc200 as M
from profiles.mc200.formats import render
from profiles.mc200.formats import render as render_stream
from tests.support.figures import problems, record_saved
from tests.support.file_checks import rules_of
from tests.support.mc200_replies import (
    EXAMPLE_REPLIES,
    EXAMPLE_STREAM,
    GUIDE_STREAM,
    SHORT_STREAM,
    lagging_replies,
    packets_of,
)
from tests.support.paths import ROOT
from verify import cli
from verify.check_file import check_file
from verify.cli import _common, main


def test_the_example_stream_is_the_guides(tmp_path: Path) -> None:
    """examples/move.mc200.hex: what the guide's `mc200 stream` writes (the replies' stream)."""
    out = tmp_path / "move.mc200.hex"
    assert main(["mc200", "stream", "--vmax", "20000", "--amax", "200000", "--jmax", "5000000",
                 "--pulses", "3200", "--period-us", "1000", "-o", str(out)]) == 0
    assert out.read_bytes() == EXAMPLE_STREAM.read_bytes()
    assert out.read_text().splitlines()[:-1] == M.render_hex(M.decode_stream(GUIDE_STREAM)
                                                             ).splitlines()


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def files(tmp_path: Path) -> tuple[Path, Path]:
    stream = tmp_path / "move.mc200.json"
    assert main(["mc200", "stream", "--vmax", "20000", "--amax", "200000", "--jmax",
                 "5000000", "--pulses", "3200", "--period-us", "1000", "-o", str(stream)]) == 0
    return stream, EXAMPLE_REPLIES


def test_follow_text_json_and_figure(files: tuple[Path, Path], tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str],
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    stream, replies = files
    code, out, err = _run(capsys, "mc200", "follow", str(stream), str(replies))
    assert code == 0 and err == ""  # the period is the JSON stream's
    assert out.splitlines()[:6] == [
        "following error (command − encoder): 315 replies to 315 packets, one every 1000 µs",
        "followed: replies 3–314 (a position commanded, the servo on)",
        "worst: +61 pulses at reply 153 (153 ms): command 1560, encoder 1499",
        "at the end: 0 pulses (command 3200, encoder 3200)",
        "the command reaches 3200 pulses at reply 305 (305 ms)",
        "in position: from reply 308 (308 ms), 3 ms after the command's end, to the log's end"]
    assert len(out.splitlines()) == 6 + 2 + 20
    figures = record_saved(monkeypatch)
    plot = tmp_path / "follow.png"
    code, out, _ = _run(capsys, "mc200", "follow", str(stream), str(replies), "--format",
                        "json", "--plot", str(plot))
    doc = json.loads(out)
    assert code == 0 and plot.read_bytes()[:4] == b"\x89PNG"
    assert doc["worst"] == {"reply": 153, "t_ms": 153.0, "error_pulses": 61.0,
                            "command_pulses": 1560.0, "encoder_pulses": 1499}
    assert doc["in_position"] == {"reply": 308, "t_ms": 308.0, "after_move_end_ms": 3.0}
    assert all(len(v) == 315 for v in doc["series"].values())
    assert doc["series"]["error_pulses"][:3] == [None, None, None]  # the servo still off
    [fig] = figures
    assert problems(fig) == []
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["position [pulses]", "following error [pulses]", "motor current [A]"]
    assert fig.axes[-1].get_xlabel() == "time [ms]"


@pytest.mark.parametrize(("argv", "needle"), [
    (["S.hex", "R"], "--period-us: S.hex (hex) does not say its packet period; give "
                     "--period-us [µs]"),
    (["S", "R", "--period-us", "10"], "--period-us (µs; each packet waits ≥ 15 µs from CS "
                                      "to CLK, the wiring page): 10.0 is outside"),
    (["S", "R", "--plot", "f.pdf"], "--plot f.pdf: the figure format is taken from the "
                                    "extension"),
    (["S", "S"], "replies: none says the control mode"),
    (["R", "R", "--period-us", "1000"], "stream packet 0: its reserved bytes"),
    (["S", "BAD"], "REPLIES BAD: block 7, byte 10: mc200.driver.checksum is"),
    (["S", "missing.hex"], "missing.hex: no such file"),
    (["S", "R", "--magic", "1234"], "argument --magic: '1234' is not one of"),
])
def test_follow_refuses_in_one_line(files: tuple[Path, Path], tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str], argv: list[str],
                                    needle: str) -> None:
    stream, replies = files
    hex_stream = tmp_path / "S.hex"
    hex_stream.write_bytes(render([GUIDE_STREAM[i:i + 12]
                                   for i in range(0, len(GUIDE_STREAM), 12)], "hex"))
    bad = bytearray(lagging_replies(GUIDE_STREAM, 3))
    bad[12 * 7 + 4] ^= 1
    (tmp_path / "BAD").write_bytes(bytes(bad))
    paths = {"S": str(stream), "S.hex": str(hex_stream), "R": str(replies),
             "BAD": str(tmp_path / "BAD"), "f.pdf": "f.pdf",
             "missing.hex": str(tmp_path / "missing.hex")}
    code, out, err = _run(capsys, "mc200", "follow", *[paths.get(a, a) for a in argv])
    err = err.replace(str(tmp_path) + "/", "")
    assert code == 2 and out == "" and needle in err, err
    assert err.count("\n") == 1 and "Traceback" not in err


MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


# --- the command line -----------------------------------------------------------------------------
RUCKIG = ["--vmax", "20000", "--amax", "200000", "--jmax", "5000000", "--pulses", "3200"]


@pytest.mark.parametrize(("argv", "needle"), [
    (["--period-us", "10"], "--period-us (µs; each packet waits ≥ 15 µs from CS to CLK, the "
                            "wiring page): 10.0 is outside the allowed range 15.0..1000000.0"),
    (["--period-us", "1000", "--din", "16"], "--din: 16 (0x10) is outside the allowed range "
                                             "0..15"),
    (["--period-us", "1000", "--magic", "0x12345678"], "argument --magic: '0x12345678' is "
                                                       "not one of the sheet's"),
    (["--period-us", "1000", "--mode", "current"], "--mode current needs --motor"),
    (["--period-us", "1000", "--torque-constant-nm-per-a", "0.3"], "only with --mode current"),
    (["--period-us", "1000", "--mode", "torque"], "argument --mode: invalid choice"),
])
def test_stream_options_refused_in_one_line(capsys: pytest.CaptureFixture[str],
                                            argv: list[str], needle: str) -> None:
    code, out, err = _run(capsys, "mc200", "stream", *RUCKIG, *argv)
    assert code == 2 and out == "" and needle in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_current_needs_its_torque_constant(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(capsys, "mc200", "stream", "--motor", str(MOTOR), "--pulses", "3200",
                        "--period-us", "1000", "--mode", "current")
    assert code == 2 and "--torque-constant-nm-per-a" in err and err.count("\n") == 1
    code, _, err = _run(capsys, "mc200", "stream", "--motor", str(MOTOR), "--pulses", "3200",
                        "--period-us", "1000", "--mode", "current",
                        "--torque-constant-nm-per-a", "0")
    assert code == 2 and err == ("stepramp mc200: --torque-constant-nm-per-a: 0.0 is outside "
                                 "the allowed range above 0.0 up to 1000.0\n")


@pytest.mark.parametrize("mode", ["velocity", "current"])
def test_stream_files_in_every_mode_check_clean(tmp_path: Path, mode: str,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / f"{mode}.json"
    extra = ["--torque-constant-nm-per-a", "0.3"] if mode == "current" else []
    argv = ["mc200", "stream", "--motor", str(MOTOR), "--pulses", "3200", "--period-us",
            "1000", "--mode", mode, "--din", "0b0011", "--spi-error-reset", "--magic",
            "F0F0F0F0", *extra, "-o", str(out)]
    assert main(argv) == 0
    doc = json.loads(out.read_text())
    assert (doc["mode"], doc["unit"]) == (mode, M.UNITS[mode])
    result = check_file(str(out))
    assert result.error is None and result.findings == []
    code, text, _ = _run(capsys, "mc200", "decode", str(out))
    lines = text.splitlines()
    assert code == 0 and "spi_error_reset=True" in lines[0] and "value_kind=raw" in lines[1]
    assert f"value_kind={mode}" in lines[-1] and lines[-1].endswith("din=3")
    code, text, _ = _run(capsys, "mc200", "decode", str(out), "--magic", "0F0F0F0F")
    assert code == 0 and "value_kind=raw" not in text  # read with the other page's magic


def test_stream_file_corrupted_and_hand_made(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    text = render_stream(packets_of(SHORT_STREAM), "hex").decode().splitlines()
    text[30] = text[30][:-1] + ("1" if text[30][-1] != "1" else "2")
    bad = tmp_path / "bad.mc200.hex"
    bad.write_text("\n".join(text) + "\n")
    assert rules_of(bad) == [("error", "mc200-corrupted")]
    assert main(["check", str(bad)]) == 1
    capsys.readouterr()
    assert main(["mc200", "decode", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("stepramp mc200: corrupted: the crc32 comment says CRC-32")
    assert len(err.splitlines()) == 1

    hand = tmp_path / "hand.mc200.hex"
    rendered = render_stream(packets_of(SHORT_STREAM), "hex").decode()
    hand.write_text("\n".join(line for line in rendered.splitlines()
                              if not line.startswith("#")) + "\n")
    assert rules_of(hand) == [("warning", "mc200-unchecked")]
    assert main(["mc200", "decode", str(hand), "--format", "json"]) == 0
    out, err = capsys.readouterr()
    assert len(json.loads(out)["packets"]) == len(SHORT_STREAM) // 12
    assert err.startswith(f"stepramp mc200: warning: {hand}: no CRC-32 in the file")


def test_mc200_stream_cli_writes_every_format(tmp_path: Path) -> None:
    args = ["mc200", "stream", "--vmax", "8000", "--amax", "80000", "--jmax", "8000000",
            "--pulses", "600", "--period-us", "2000"]
    for name, extra in (("s.h", []), ("s.ihex", ["--base-address", "0x1000"]),
                        ("s.json", []), ("s.txt", ["--format", "c", "--name", "x_axis"])):
        path = tmp_path / name
        assert main([*args, "-o", str(path), *extra]) == 0
        assert main(["mc200", "decode", str(path)]) == 0
        assert rules_of(path) == []
    assert b"stepramp mc200 stream --vmax 8000" in (tmp_path / "s.h").read_bytes()
    assert b"x_axis_packets[X_AXIS_PACKET_COUNT][12]" in (tmp_path / "s.txt").read_bytes()
    assert main([*args, "--name", "x"]) == 2  # --name is for C
    assert main([*args, "--base-address", "16", "--format", "hex"]) == 2


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_mc200_stream_draws_a_bar_on_a_terminal(monkeypatch: pytest.MonkeyPatch,
                                                tmp_path: Path) -> None:
    monkeypatch.setattr(_common, "PROGRESS_DELAY_S", 0.0)
    tty = _Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    out = tmp_path / "s.hex"
    assert cli.main(["mc200", "stream", "--vmax", "20000", "--amax", "2e5", "--jmax", "5e6",
                     "--pulses", "3200", "--period-us", "1000", "-o", str(out)]) == 0
    lines = [line for line in out.read_text().splitlines() if not line.startswith("#")]
    assert "encode packets" in tty.getvalue() and f"{len(lines)}/{len(lines)}" in tty.getvalue()
