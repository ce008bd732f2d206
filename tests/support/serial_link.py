"""The PPMC-312 serial link master (profiles/ppmc312/link.py) on a test's clock: the
slave's address and init table the link tests use, the time a move takes, the clocks a
Link and its SerialChip share (real time skewed by the link's waits, or a clock only the
waits move), and the fixtures that open a Link to a chip served on a pseudo-terminal.

The fixtures (`skewed`, `pty_chip`, `link`) reach every test through tests/conftest.py's
pytest_plugins; the rest is imported as `from tests.support.serial_link import …`."""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import pytest

from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.link import Link
from profiles.ppmc312.serial_chip import PtyServer, SerialChip
from profiles.ppmc312.table import InitTable

ADDRESS = 5

TABLE = InitTable(Clock.internal("8MHz"), "linear", 10_000, 400, 2000)


def move_s(pulses: int) -> float:
    """How long a move of `pulses` on TABLE takes, its first pulse's latency included."""
    run = simulate_move(TABLE, pulses)
    return run.first_pulse_latency_s + run.duration_s


def wait_stopped(link: Link, pulses: int) -> Any:
    """The poll reply once a move of `pulses` on TABLE is over (real time waited)."""
    time.sleep(move_s(pulses) + 0.02)
    return link.poll()


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


class FakeTime:
    """A clock only the link's sleeps move (and the test, by setting `t`)."""

    def __init__(self) -> None:
        self.t = 100.0
        self.slept: list[float] = []

    def now(self) -> float:
        return self.t

    def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.t += seconds


@pytest.fixture
def skewed() -> SkewedTime:
    """The clock the `pty_chip` and the `link` share."""
    return SkewedTime()


@pytest.fixture
def pty_chip(skewed: SkewedTime) -> Iterator[tuple[SerialChip, str]]:
    """A SerialChip at ADDRESS served on a pseudo-terminal: (the chip, the terminal's path)."""
    chip = SerialChip(ADDRESS, clock_s=skewed.now)
    with PtyServer(chip) as server:
        yield chip, server.path


@pytest.fixture
def link(pty_chip: tuple[SerialChip, str], skewed: SkewedTime) -> Iterator[Link]:
    """A Link to the `pty_chip`, open for the test."""
    with Link(pty_chip[1], ADDRESS, timeout_s=0.5, **skewed.timing()) as opened:
        yield opened
