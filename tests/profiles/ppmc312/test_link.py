"""The serial link master (profiles/ppmc312/link.py) against the serial chip on a real
pseudo-terminal, on a noisy line, and against scripted replies it must not believe."""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from profiles.errors import FieldChoiceError
from profiles.ppmc312.ascii import encode_frame
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.link import (
    ChipRefused,
    Exchange,
    GarbledReply,
    Link,
    LinkError,
    LinkTimeout,
    UnknownReply,
)
from profiles.ppmc312.replies import decode_reply
from profiles.ppmc312.serial_chip import LoopSerial, PtyServer, SerialChip
from profiles.ppmc312.table import InitTable

ADDRESS = 5


TABLE = InitTable(Clock.internal("8MHz"), "linear", 10_000, 400, 2000)


def move_s(pulses: int) -> float:
    run = simulate_move(TABLE, pulses)
    return run.first_pulse_latency_s + run.duration_s


def wait_stopped(link: Link, pulses: int) -> Any:
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


def test_poll_init_move_position_and_the_stop_report(link: Link, skewed: SkewedTime) -> None:
    assert str(link.poll()) == "ready"
    assert link.position() == 0
    link.init(TABLE)
    link.move(2000)  # 0.27 s: still running at the next poll
    assert len(skewed.slept) == 1 and 0.1 < skewed.slept[0] <= 0.115  # §7-1, once
    assert link.poll().state == "busy"
    stopped = wait_stopped(link, 2000)
    assert (stopped.state, stopped.code) == ("stopped", 0x38)
    assert str(stopped) == "stopped: normal stop at the commanded position (0x38)"
    assert link.poll().state == "ready"
    assert link.position() == 2000
    link.move(120, ccw=True)
    assert wait_stopped(link, 120).code == 0x38
    assert link.position() == 1880
    assert link.stats["resends"] == 0


def test_a_refused_init_names_the_chips_answer(link: Link) -> None:
    with pytest.raises(ChipRefused, match=r"init: the chip refused it: parameter error"):
        link.init(InitTable(Clock.internal("8MHz"), "linear", 450, 400, 2000))


@pytest.mark.parametrize("baud", [9_600, 57_600, 83_332, 115_200])
def test_another_line_speed_is_refused_naming_the_three(baud: int) -> None:
    """Refused before the port is opened, with the chip's three speeds (57 600 lies between
    them: a range would wrongly suggest it)."""
    with pytest.raises(FieldChoiceError, match=rf"baud.*{baud}.*19200, 38400, 83333"):
        Link("/nonexistent/tty", ADDRESS, baud=baud)


def test_a_missing_port_is_one_line() -> None:
    with pytest.raises(LinkError, match=r"^/nonexistent/tty: cannot open the serial port: "):
        Link("/nonexistent/tty", ADDRESS)


@pytest.mark.parametrize(("counter", "why"), [
    (1, "the encoder position (01)"), (2, "counter 0x02, none of the manual's (00, 01)")])
def test_a_position_reply_for_another_counter_is_refused(counter: int, why: str) -> None:
    reply = encode_frame("data", ADDRESS, bytes([counter]) + (7).to_bytes(4, "big"))
    with pytest.raises(GarbledReply, match=rf"^slave 5: position: the reply is for "
                                           rf"{re.escape(why)}, the pulse position \(00\) "
                                           r"was asked$"):
        Link(Scripted([reply]), ADDRESS, retries=0).position()


def test_a_resent_command_is_heard_each_time_and_a_damaged_reply_never() -> None:
    good = position_reply(1234)
    bad = good[:-1] + bytes([good[-1] ^ 0x01])
    refusal = encode_frame("special", ADDRESS, b"\x47")  # the chip's answer to damage
    heard = list[Exchange]()
    port = Scripted([bad, refusal, good])
    assert Link(port, ADDRESS, retries=2, on_reply=heard.append).position() == 1234
    assert [(e.reply, e.attempt) for e in heard] == [(refusal, 1), (good, 2)]
    assert all(e.sent == port.sent[0] for e in heard)
    assert decode_reply(heard[0].reply, reply_to="position").fields == {"code": 0x47}


class Scripted:
    """A port whose replies are given in advance, one per write."""

    def __init__(self, replies: list[bytes]) -> None:
        self.replies = list(replies)
        self.sent: list[bytes] = []
        self.timeout: float | None = 0.05
        self._buffer = b""

    def write(self, data: bytes) -> int:
        self.sent.append(bytes(data))
        self._buffer += self.replies.pop(0) if self.replies else b""
        return len(data)

    def read(self, size: int = 1) -> bytes:
        out, self._buffer = self._buffer[:size], self._buffer[size:]
        return out

    def reset_input_buffer(self) -> None:
        self._buffer = b""

    def close(self) -> None:
        pass


def position_reply(value: int, address: int = ADDRESS) -> bytes:
    return encode_frame("data", address, b"\x00" + value.to_bytes(4, "big"))


def test_a_bad_checksum_is_resent_and_the_good_reply_taken() -> None:
    good = position_reply(1234)
    bad = good[:-1] + bytes([good[-1] ^ 0x01])
    port = Scripted([bad, good])
    assert Link(port, ADDRESS, retries=1).position() == 1234
    assert len(port.sent) == 2 and port.sent[0] == port.sent[1]


@pytest.mark.parametrize(("reply", "why"), [
    (position_reply(7)[:-1] + b"0", "checksum mismatch"),
    (position_reply(7, address=4), "a reply from slave 4"),
    (b"12" + position_reply(7), "2 stray byte(s) before control byte"),
    (position_reply(7)[:5] + b"G" + position_reply(7)[6:], "not an ASCII hex character"),
    (encode_frame("ready", ADDRESS, b""), "unexpected ready reply"),
    (b"\xC5" + position_reply(7)[1:], "not a control byte"),
])
def test_garbled_replies_are_never_believed(reply: bytes, why: str) -> None:
    port = Scripted([reply] * 3)
    with pytest.raises(GarbledReply, match=r"^slave 5: position: .*" + why.replace("(", r"\(")
                       .replace(")", r"\)") + r".* \(3 attempts\)$"):
        Link(port, ADDRESS, retries=2).position()
    assert len(port.sent) == 3


def test_a_short_reply_is_a_timeout() -> None:
    with pytest.raises(LinkTimeout, match=r"reply cut short: 4 of 12 characters"):
        Link(Scripted([position_reply(7)[:5]]), ADDRESS, retries=0).position()


def test_an_unknown_special_reply_is_reported_as_such() -> None:
    port = Scripted([encode_frame("special", ADDRESS, b"\x99")])
    with pytest.raises(UnknownReply, match=r"^slave 5: poll: unknown special reply 0x99"):
        Link(port, ADDRESS).poll()


def test_command_error_47_is_resent_then_reported() -> None:
    refusal = encode_frame("special", ADDRESS, b"\x47")
    with pytest.raises(ChipRefused, match=r"command error 47 .* \(2 attempts\)"):
        Link(Scripted([refusal, refusal]), ADDRESS, retries=1).stop()
    assert Link(Scripted([refusal, encode_frame("ready", ADDRESS, b"")]), ADDRESS,
                retries=1).stop() is None


def test_error_replies_accept_the_printed_ready_byte_and_a_data_byte() -> None:
    count = encode_frame("ready", ADDRESS, b"\x01\x02")      # §18-11 as printed: 90 + a
    code = encode_frame("data", ADDRESS, b"\x43")            # a data reply (A0 + a)
    report = Link(Scripted([count, code]), ADDRESS).errors()
    assert (report.error_count, report.error_code) == (0x0102, 0x43)


def run_cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    from verify.cli import main

    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_link_runs_every_command(pty_chip: tuple[SerialChip, str], tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    chip, path = pty_chip
    base = ["link", "--port", path, "--address", str(ADDRESS)]
    table = tmp_path / "init.json"
    table.write_text('{"format": "stepramp.table/1", "device": "ppmc312", "kind": "init", '
                     '"clock": "8MHz", "shape": "linear", "start_rate": 10000, '
                     '"high_rate": 400, "accel_pulses": 2000}')
    assert run_cli([*base, "poll"], capsys) == (0, "slave 5: ready\n", "")
    code, out, err = run_cli([*base, "move", "--pulses", "100"], capsys)
    assert (code, out) == (1, "")
    assert err == "stepramp link: slave 5: move: the chip refused it: state error (B5 43)\n"
    # -v: init ends once the chip takes moves (§7-1), and says so; it waits real time.
    code, out, err = run_cli([*base, "-v", "init", str(table)], capsys)
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
    assert run_cli([*base, "move", "--pulses", "100000", "--ccw"], capsys) == (
        0, "slave 5: move of 100000 pulses CCW started\n", "")
    assert run_cli([*base, "poll"], capsys) == (0, "slave 5: busy\n", "")
    assert run_cli([*base, "stop"], capsys) == (0, "slave 5: pulse output stopped\n", "")
    assert run_cli([*base, "poll"], capsys) == (
        0, "slave 5: stopped: stopped by the immediate-stop command (0x37)\n", "")
    # CCW from 0: the 32-bit counter wraps, 0…0xFFFFFFFF (§2-1.6, §10-3)
    assert (1 << 32) - 100_000 < chip.position < 1 << 32
    assert run_cli([*base, "position"], capsys) == (
        0, f"slave 5: position {chip.position} pulses\n", "")
    # -v: the frame sent, then the reply as `stepramp answer --serial --reply-to position`
    # decodes it, indented; the position unsigned in both
    code, out, err = run_cli([*base, "-v", "position"], capsys)
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
    assert run_cli([*base, "errors"], capsys) == (
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
        assert run_cli([*base, "move", "--command", "continuous-constant", "--rate", "2000",
                        "--ccw"], capsys) == (
            0, "slave 5: continuous-constant (86) started: rate 2000, CCW\n", "")
        assert run_cli([*base, "move", "--command", "decel-stop"], capsys) == (
            0, "slave 5: decel-stop (81) taken\n", "")
        code, out, err = run_cli([*base, "move", "--command", "set-speed", "--rate", "500"],
                                 capsys)
        assert (code, out) == (1, "")
        assert err == ("stepramp link: slave 5: set-speed: the chip refused it: state error "
                       "(B5 43)\n")
        code, out, err = run_cli([*base, "-v", "move", "--command", "change-speed",
                                  "--rate", "500"], capsys)
        assert code == 1 and "  reply B5 34 33 " in out and "state error" in out
        # an unusable request: refused before the port is opened, one line, exit 2
        n = len(opened)
        for argv, message in (
                (["--command", "origin-search"], "the following arguments are required by "
                 "--command origin-search: --rate (see stepramp link move --help)"),
                (["--command", "stop", "--rate", "3"], "--rate: stop (80) does not take it"),
                (["--command", "constant", "--pulses", "5", "--rate", "1"], "--rate: 1 ")):
            code, out, err = run_cli([*base, "move", *argv], capsys)
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
        code, out, err = run_cli([*base, "move", "--command", "stop", "--override-at", "3000"],
                                 capsys)
        assert (code, out) == (1, "") and "stop: the chip refused it: state error" in err
        assert run_cli([*base, "move", "--command", "continuous-constant", "--rate", "2000"],
                       capsys)[0] == 0
        code, out, err = run_cli([*base, "-v", "move", "--command", "set-speed", "--rate",
                                  "1000", "--override-at", "2000"], capsys)
        assert (code, err) == (0, "")
        sent, reply, *_, said = out.splitlines()
        assert sent.startswith("slave 5: set-speed: sent 95 38 44 ")   # 8D (§16-9)
        assert reply.startswith("  reply 95 36 41: ready")
        assert said == "slave 5: set-speed (88) registered: rate 1000, at position 2000"
        assert run_cli([*base, "move", "--command", "decel-stop", "--on", "evt2"], capsys) == (
            0, "slave 5: decel-stop (81) registered: on /EVT1\n", "")
        fake.t += 1.0
        code, out, _ = run_cli([*base, "poll"], capsys)
        assert code == 0 and "override command executed" in out and "0x21" in out
        chip.event(1)
        assert "override command executed" in run_cli([*base, "poll"], capsys)[1]
        fake.t += 2.0
        assert run_cli([*base, "poll"], capsys)[1].startswith("slave 5: stopped: ")
        for argv, message in (
                (["--command", "accel", "--pulses", "9", "--override-at", "5"],
                 "--override-at: accel (82) does not take it"),
                (["--command", "set-speed", "--rate", "500", "--override-at", "5"],
                 "--override-at: 5 "),
                (["--command", "stop", "--override-at", "5", "--on", "evt1"], "not both")):
            code, out, err = run_cli([*base, "move", *argv], capsys)
            assert (code, out) == (2, "") and message in err and err.count("\n") == 1, err
