"""`stepramp link` (verify/cli/link.py): the serial link master from the command line."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from profiles.ppmc312.ascii import encode_frame
from profiles.ppmc312.link import Link
from profiles.ppmc312.serial_chip import LoopSerial, PtyServer, SerialChip
from tests.support.cli import run
from tests.support.paths import ROOT
from tests.support.serial_link import ADDRESS, TABLE, FakeTime
from tests.support.subprocess_env import checkout_env


class UnknownCode(SerialChip):
    """A slave that answers every frame with a special reply no table of the manual has."""

    def receive(self, data: bytes) -> bytes:
        return encode_frame("special", ADDRESS, b"\x99") if super().receive(data) else b""


def test_cli_link_v_shows_a_reply_no_reading_fits_then_the_link_s_error(
        capsys: pytest.CaptureFixture[str]) -> None:
    with PtyServer(UnknownCode(ADDRESS)) as server:
        code, out, err = run(capsys, "link", "--port", server.path, "--address", str(ADDRESS),
                             "-v", "poll")
    reply = encode_frame("special", ADDRESS, b"\x99").hex(" ").upper()
    assert code == 2
    assert out.splitlines() == [
        "slave 5: poll: sent 85 37 41",
        f"  reply {reply}: byte 1: special reply (B0+a): code 0x99 is none of the manual's "
        "(20, 21, 22, 23, 24, 25, 26, 27, 28, 42, 43, 44, 46, 47, 48, 49, 4A, §19)"]
    assert err == ("stepramp link: slave 5: poll: unknown special reply 0x99 (no code of the "
                   "manual's §15–19)\n")


def test_cli_emulate_serves_a_pty_until_sigterm(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    import signal
    import subprocess
    import sys

    env = checkout_env()
    link_path = tmp_path / "chip.tty"
    proc = subprocess.Popen([sys.executable, "-m", "verify.cli", "emulate", "--pty",
                             "--address", "9", "--link", str(link_path), "--log"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert proc.stdout is not None
        first = proc.stdout.readline()
        assert first.startswith("PPMC-312 slave 9 (ASCII serial mode) on /dev/")
        assert first.rstrip().endswith(f"(link {link_path})")
        assert link_path.is_symlink()
        assert run(capsys, "link", "--port", str(link_path), "--address", "9",
                   "position") == (0, "slave 9: position 0 pulses\n", "")
        assert proc.stdout.readline() == "position: 0\n"  # --log: one line per frame
    finally:
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(timeout=10)
    assert code == 0
    assert not link_path.exists()


def test_cli_link_runs_every_command(pty_chip: tuple[SerialChip, str], tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    chip, path = pty_chip
    base = ["link", "--port", path, "--address", str(ADDRESS)]
    table = tmp_path / "init.json"
    table.write_text('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "init", '
                     '"clock": "8MHz", "shape": "linear", "start_rate": 10000, '
                     '"high_rate": 400, "accel_pulses": 2000}')
    assert run(capsys, *base, "poll") == (0, "slave 5: ready\n", "")
    code, out, err = run(capsys, *base, "move", "--pulses", "100")
    assert (code, out) == (1, "")
    assert err == "stepramp link: slave 5: move: the chip refused it: state error (B5 43)\n"
    # -v: init ends once the chip takes moves (§7-1), and says so; it waits real time.
    code, out, err = run(capsys, *base, "-v", "init", str(table))
    assert (code, err) == (0, "")
    sent, *reply, accepted, waited = out.splitlines()
    assert sent.startswith("slave 5: init: sent 95 30 30 32 37 31 30 ")
    assert reply == ["  reply 95 36 41: ready (90+a): no pulse output, or the command "
                     "accepted, manual §19-1", "    control 95: ready reply from slave 5"]
    assert accepted == ("slave 5: init accepted: linear, start rate 10000, high rate 400, "
                        "2000 accel/decel pulses")
    assert re.fullmatch(r"slave 5: the chip accepts motion commands 115 ms after an init "
                        r"\(§7-1\): waiting 1[01]\d(\.\d)? ms", waited), waited
    assert chip.table is not None
    assert run(capsys, *base, "move", "--pulses", "100000", "--ccw") == (
        0, "slave 5: move of 100000 pulses CCW started\n", "")
    assert run(capsys, *base, "poll") == (0, "slave 5: busy\n", "")
    assert run(capsys, *base, "stop") == (0, "slave 5: pulse output stopped\n", "")
    assert run(capsys, *base, "poll") == (
        0, "slave 5: stopped: stopped by the immediate-stop command (0x37)\n", "")
    # CCW from 0: the 32-bit counter wraps, 0…0xFFFFFFFF (§2-1.6, §10-3)
    assert (1 << 32) - 100_000 < chip.position < 1 << 32
    assert run(capsys, *base, "position") == (
        0, f"slave 5: position {chip.position} pulses\n", "")
    # -v: the frame sent, then the reply as `stepramp answer --serial --reply-to position`
    # decodes it, indented; the position unsigned in both
    code, out, err = run(capsys, *base, "-v", "position")
    at = chip.position
    reply = encode_frame("data", ADDRESS, b"\x00" + at.to_bytes(4, "big"))
    assert (code, err) == (0, "")
    assert out.splitlines() == [
        "slave 5: position: sent 95 34 32 30 34",
        f"  reply {reply.hex(' ').upper()}: position read reply (A0+a), manual §18-1",
        "    control A5: data reply from slave 5",
        "    counter 00: pulse position",
        f"    position {at} (0x{at:08X})",
        f"slave 5: position {at} pulses"]
    assert run(capsys, *base, "errors") == (
        0, "slave 5: 0 line error(s) (framing, overrun and checksum); last error code 0x43 "
           "(state error)\n", "")


def test_cli_link_move_sends_any_motion_command(capsys: pytest.CaptureFixture[str]) -> None:
    from unittest import mock

    fake = FakeTime()
    chip = SerialChip(ADDRESS, clock_s=fake.now)
    chip.table = TABLE   # as if an init had gone long ago
    base = ["link", "--port", "loop://", "--address", str(ADDRESS)]
    opened: list[Any] = []

    class LoopLink(Link):
        def __init__(self, port: Any, address: int, **kw: Any) -> None:
            super().__init__(LoopSerial(chip), address, **kw)
            opened.append(self)

    with mock.patch("profiles.ppmc312.link.Link", LoopLink):
        assert run(capsys, *base, "move", "--command", "continuous-constant", "--rate", "2000",
                   "--ccw") == (
            0, "slave 5: continuous-constant (86) started: rate 2000, CCW\n", "")
        assert run(capsys, *base, "move", "--command", "decel-stop") == (
            0, "slave 5: decel-stop (81) taken\n", "")
        code, out, err = run(capsys, *base, "move", "--command", "set-speed", "--rate", "500")
        assert (code, out) == (1, "")
        assert err == ("stepramp link: slave 5: set-speed: the chip refused it: state error "
                       "(B5 43)\n")
        code, out, err = run(capsys, *base, "-v", "move", "--command", "change-speed",
                             "--rate", "500")
        assert code == 1 and "  reply B5 34 33 " in out and "state error" in out
        # an unusable request: refused before the port is opened, one line, exit 2
        n = len(opened)
        for argv, message in (
                (["--command", "origin-search"], "the following arguments are required by "
                 "--command origin-search: --rate (see stepramp link move --help)"),
                (["--command", "stop", "--rate", "3"], "--rate: stop (80) does not take it"),
                (["--command", "constant", "--pulses", "5", "--rate", "1"], "--rate: 1 ")):
            code, out, err = run(capsys, *base, "move", *argv)
            assert (code, out) == (2, "") and message in err and err.count("\n") == 1, err
        assert len(opened) == n


def test_cli_link_move_registers_the_override_forms(capsys: pytest.CaptureFixture[str]) -> None:
    from unittest import mock

    fake = FakeTime()
    chip = SerialChip(ADDRESS, clock_s=fake.now)
    chip.table = TABLE   # as if an init had gone long ago
    base = ["link", "--port", "loop://", "--address", str(ADDRESS)]

    class LoopLink(Link):
        def __init__(self, port: Any, address: int, **kw: Any) -> None:
            super().__init__(LoopSerial(chip), address, **kw)

    with mock.patch("profiles.ppmc312.link.Link", LoopLink):
        code, out, err = run(capsys, *base, "move", "--command", "stop", "--override-at", "3000")
        assert (code, out) == (1, "") and "stop: the chip refused it: state error" in err
        assert run(capsys, *base, "move", "--command", "continuous-constant",
                   "--rate", "2000")[0] == 0
        code, out, err = run(capsys, *base, "-v", "move", "--command", "set-speed", "--rate",
                             "1000", "--override-at", "2000")
        assert (code, err) == (0, "")
        sent, reply, *_, said = out.splitlines()
        assert sent.startswith("slave 5: set-speed: sent 95 38 44 ")   # 8D (§16-9)
        assert reply.startswith("  reply 95 36 41: ready")
        assert said == "slave 5: set-speed (88) registered: rate 1000, at position 2000"
        assert run(capsys, *base, "move", "--command", "decel-stop", "--on", "evt2") == (
            0, "slave 5: decel-stop (81) registered: on /EVT1\n", "")
        fake.t += 1.0
        code, out, _ = run(capsys, *base, "poll")
        assert code == 0 and "override command executed" in out and "0x21" in out
        chip.event(1)
        assert "override command executed" in run(capsys, *base, "poll")[1]
        fake.t += 2.0
        assert run(capsys, *base, "poll")[1].startswith("slave 5: stopped: ")
        for argv, message in (
                (["--command", "accel", "--pulses", "9", "--override-at", "5"],
                 "--override-at: accel (82) does not take it"),
                (["--command", "set-speed", "--rate", "500", "--override-at", "5"],
                 "--override-at: 5 "),
                (["--command", "stop", "--override-at", "5", "--on", "evt1"], "not both")):
            code, out, err = run(capsys, *base, "move", *argv)
            assert (code, out) == (2, "") and message in err and err.count("\n") == 1, err


@pytest.mark.parametrize(("argv", "message"), [
    (["--address", "16", "poll"], "address: 16 (0x10) is outside the allowed range 0..15"),
    (["--address", "6", "--timeout-s", "0.05", "--retries", "0", "poll"],
     "slave 6: poll: no reply within 0.05 s (1 attempt)"),
    (["--address", "5", "init", "{examples}/free-curve-nema17.json"], "no serial form"),
])
def test_cli_link_bad_input_is_one_line_exit_2(pty_chip: tuple[SerialChip, str], argv: list[str],
                                               message: str,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    examples = str(ROOT / "examples")
    argv = [a.replace("{examples}", examples) for a in argv]
    code, out, err = run(capsys, "link", "--port", pty_chip[1], *argv)
    assert (code, out) == (2, "")
    assert err.startswith("stepramp link: ") and message in err and err.count("\n") == 1
