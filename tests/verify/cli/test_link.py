"""`stepramp link` (verify/cli/link.py): the serial link master from the command line."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from profiles.ppmc312.ascii import encode_frame
from profiles.ppmc312.link import (
    Link,
)
from profiles.ppmc312.serial_chip import PtyServer, SerialChip
from tests.support.subprocess_env import checkout_env

ADDRESS = 5


class SkewedTime:
    """Real time plus every wait the link asked for: the link's waits after an init cost
    no real time, and the chip, on the same clock, sees them pass (moves still run on
    real time)."""

    def __init__(self) -> None:
        self.skew = 0.0
        self.slept: list[float] = []

    def now(self) -> float:
        return time.monotonic() + self.skew

    def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.skew += seconds

    def timing(self) -> dict[str, Any]:
        """A Link's clock_s and sleep_s."""
        return {"clock_s": self.now, "sleep_s": self.sleep}


@pytest.fixture
def skewed() -> SkewedTime:
    return SkewedTime()


@pytest.fixture
def pty_chip(skewed: SkewedTime) -> Iterator[tuple[SerialChip, str]]:
    chip = SerialChip(ADDRESS, clock_s=skewed.now)
    with PtyServer(chip) as server:
        yield chip, server.path


@pytest.fixture
def link(pty_chip: tuple[SerialChip, str], skewed: SkewedTime) -> Iterator[Link]:
    with Link(pty_chip[1], ADDRESS, timeout_s=0.5, **skewed.timing()) as opened:
        yield opened


def run_cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    from verify.cli import main

    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


class UnknownCode(SerialChip):
    """A slave that answers every frame with a special reply no table of the manual has."""

    def receive(self, data: bytes) -> bytes:
        return encode_frame("special", ADDRESS, b"\x99") if super().receive(data) else b""


def test_cli_link_v_shows_a_reply_no_reading_fits_then_the_link_s_error(
        capsys: pytest.CaptureFixture[str]) -> None:
    with PtyServer(UnknownCode(ADDRESS)) as server:
        code, out, err = run_cli(["link", "--port", server.path, "--address", str(ADDRESS),
                                  "-v", "poll"], capsys)
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
        assert run_cli(["link", "--port", str(link_path), "--address", "9", "position"],
                       capsys) == (0, "slave 9: position 0 pulses\n", "")
        assert proc.stdout.readline() == "position: 0\n"  # --log: one line per frame
    finally:
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(timeout=10)
    assert code == 0
    assert not link_path.exists()
