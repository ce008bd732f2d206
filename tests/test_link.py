"""The serial link master (profiles/ppmc312/link.py) against the serial chip on a real
pseudo-terminal, on a noisy line, and against scripted replies it must not believe."""

from __future__ import annotations

import random
import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import serial

from profiles.errors import FieldChoiceError, UnsupportedError
from profiles.ppmc312.ascii import encode_frame
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.link import REPLY_TO as LINK_REPLY_TO
from profiles.ppmc312.link import (
    ChipRefused,
    Exchange,
    GarbledReply,
    Link,
    LinkError,
    LinkTimeout,
    PollReply,
    UnknownReply,
)
from profiles.ppmc312.replies import REPLY_TO, decode_reply
from profiles.ppmc312.serial_chip import LoopSerial, PtyServer, SerialChip
from profiles.ppmc312.table import FreeCurveTable, InitTable
from tests.support.paths import ROOT
from tests.support.subprocess_env import checkout_env

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


# --- every command on a real pty --------------------------------------------------------

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


def test_stop_halts_a_move_midway(link: Link, pty_chip: tuple[SerialChip, str]) -> None:
    link.init(TABLE)
    link.move(100_000)
    time.sleep(0.1)
    link.stop()
    held = link.position()
    assert 0 < held < 100_000
    time.sleep(0.05)
    assert link.position() == held == pty_chip[0].position
    assert (link.poll().code, link.end_status()) == (0x37, 0x37)


def test_errors_reads_the_count_and_the_code(link: Link,
                                             pty_chip: tuple[SerialChip, str]) -> None:
    report = link.errors()
    assert (report.error_count, report.error_code, report.error_text) == (0, 0, "no error")
    with pytest.raises(ChipRefused, match=r"slave 5: move: the chip refused it: state error "
                                          r"\(B5 43\)") as refused:
        link.move(100)  # no table yet
    assert refused.value.code == 0x43
    # the whole message, as the CLI prints it after "stepramp link: "
    assert str(refused.value) == "slave 5: move: the chip refused it: state error (B5 43)"
    pty_chip[0].checksum_errors = 2  # as if two damaged frames had reached it
    report = link.errors()
    assert (report.error_count, report.error_code, report.error_text) == (2, 0x43,
                                                                          "state error")


def test_a_refused_init_names_the_chips_answer(link: Link) -> None:
    with pytest.raises(ChipRefused, match=r"init: the chip refused it: parameter error"):
        link.init(InitTable(Clock.internal("8MHz"), "linear", 450, 400, 2000))


def test_a_free_curve_has_no_serial_form(link: Link) -> None:
    table = FreeCurveTable(Clock.internal("8MHz"), (400, 800), (100, 100))
    with pytest.raises(UnsupportedError, match="no serial form"):
        link.init(table)  # type: ignore[arg-type]


def test_a_silent_slave_times_out_after_the_retries(pty_chip: tuple[SerialChip, str]) -> None:
    with Link(pty_chip[1], ADDRESS + 1, timeout_s=0.05, retries=2) as other:
        with pytest.raises(LinkTimeout, match=r"^slave 6: poll: no reply within 0.05 s "
                                              r"\(3 attempts\)$"):
            other.poll()
        assert other.stats["attempts"] == 3


@pytest.mark.parametrize("baud", [19_200, 38_400, 83_333])
def test_every_line_speed_of_the_manual_talks(pty_chip: tuple[SerialChip, str], baud: int
                                             ) -> None:
    """§13: 19 200, 38 400 and 83 333 bit/s (a pty carries any of them)."""
    with Link(pty_chip[1], ADDRESS, baud=baud, timeout_s=0.5) as opened:
        assert opened.position() == 0


@pytest.mark.parametrize("baud", [9_600, 57_600, 83_332, 115_200])
def test_another_line_speed_is_refused_naming_the_three(baud: int) -> None:
    """Refused before the port is opened, with the chip's three speeds (57 600 lies between
    them: a range would wrongly suggest it)."""
    with pytest.raises(FieldChoiceError, match=rf"baud.*{baud}.*19200, 38400, 83333"):
        Link("/nonexistent/tty", ADDRESS, baud=baud)


def test_a_missing_port_is_one_line() -> None:
    with pytest.raises(LinkError, match=r"^/nonexistent/tty: cannot open the serial port: "):
        Link("/nonexistent/tty", ADDRESS)


def test_link_over_loop_transport(skewed: SkewedTime) -> None:
    chip = SerialChip(ADDRESS, clock_s=skewed.now)
    link = Link(LoopSerial(chip), ADDRESS, timeout_s=0.2, **skewed.timing())
    link.init(TABLE)
    link.move(2000)
    assert chip.busy
    assert wait_stopped(link, 2000).code == 0x38
    assert link.position() == 2000


# --- the time the chip needs after an init (§7-1; profiles/ppmc312/timing.py) -------------

S_TABLE = InitTable(Clock.internal("8MHz"), "s_curve", 10_000, 400, 2000)


def timed_link(fake: FakeTime, notes: list[str], sleep: Any = None) -> tuple[SerialChip, Link]:
    """The chip and the link on one fake clock, over the in-process loop port."""
    chip = SerialChip(ADDRESS, clock_s=fake.now)
    return chip, Link(LoopSerial(chip), ADDRESS, clock_s=fake.now,
                      sleep_s=fake.sleep if sleep is None else sleep, on_note=notes.append)


def test_the_link_waits_out_the_window_before_the_first_move_only() -> None:
    fake, notes = FakeTime(), list[str]()
    chip, link = timed_link(fake, notes)
    link.init(TABLE)
    link.move(100)
    # The fake clock stood still while the frames went: the whole window is waited.
    assert fake.slept == [pytest.approx(0.115, abs=1e-12)]
    assert notes == ["the chip accepts motion commands 115 ms after an init (§7-1): "
                     "waiting 115 ms"]
    assert chip.log[-1].startswith("move: 100 pulses CW")
    fake.t += 1.0       # the move is over
    link.move(100)      # no init since: no wait
    assert len(fake.slept) == 1 and len(notes) == 1
    assert sum(line.startswith("move:") for line in chip.log) == 2


def test_time_already_spent_is_not_waited_again() -> None:
    fake, notes = FakeTime(), list[str]()
    chip, link = timed_link(fake, notes)
    link.init(S_TABLE)
    fake.t += 0.100     # the host did other things
    link.move(100)
    assert fake.slept == [pytest.approx(0.075, abs=1e-12)]
    assert notes == ["the chip accepts motion commands 175 ms after an init (§7-1): "
                     "waiting 75 ms"]
    fake.t += 1.0
    link.init(S_TABLE)
    fake.t += 0.2       # past the window: nothing to wait
    link.move(100)
    assert len(fake.slept) == 1 and len(notes) == 1
    assert sum(line.startswith("move:") for line in chip.log) == 2


def test_a_link_that_did_not_wait_would_be_refused_by_the_chip() -> None:
    fake, notes = FakeTime(), list[str]()
    chip, link = timed_link(fake, notes, sleep=lambda _s: None)  # a sleep that takes no time
    link.init(TABLE)
    with pytest.raises(ChipRefused, match=r"^slave 5: move: the chip refused it: state error "
                                          r"\(B5 43\)$"):
        link.move(100)
    assert chip.log[-1] == ("refused 0x43: move 0 ms after the init: the chip accepts motion "
                            "commands 115 ms after an init (§7-1)")


def test_the_position_is_the_unsigned_counter() -> None:
    """§2-1.6: positions 0…0xFFFFFFFF; a CCW move past 0 reads 0xFFFFFF9C, never −100,
    and a CW move back wraps to 50 (the emulator's counter is 32 bits too)."""
    fake, notes = FakeTime(), list[str]()
    chip, link = timed_link(fake, notes)
    link.init(TABLE)
    link.move(100, ccw=True)
    fake.t += 1.0  # the move is over
    assert link.position() == chip.position == 0xFFFFFF9C
    link.move(150)
    fake.t += 1.0
    assert link.position() == chip.position == 50


@pytest.mark.parametrize(("counter", "why"), [
    (1, "the encoder position (01)"), (2, "counter 0x02, none of the manual's (00, 01)")])
def test_a_position_reply_for_another_counter_is_refused(counter: int, why: str) -> None:
    reply = encode_frame("data", ADDRESS, bytes([counter]) + (7).to_bytes(4, "big"))
    with pytest.raises(GarbledReply, match=rf"^slave 5: position: the reply is for "
                                           rf"{re.escape(why)}, the pulse position \(00\) "
                                           r"was asked$"):
        Link(Scripted([reply]), ADDRESS, retries=0).position()


def test_a_stop_is_never_delayed_and_waiting_needs_an_init() -> None:
    fake, notes = FakeTime(), list[str]()
    _, link = timed_link(fake, notes)
    link.wait_until_motion_accepted()   # no init yet: nothing to wait for
    link.init(TABLE)
    link.stop()
    assert fake.slept == [] and notes == []
    link.wait_until_motion_accepted()   # what `stepramp link init` does before it ends
    assert fake.slept == [pytest.approx(0.115, abs=1e-12)]
    link.move(100)
    assert len(fake.slept) == 1


# --- every reply heard (on_reply), read through the one decoder ---------------------------

def test_every_reply_taken_is_heard_with_the_command_it_answers() -> None:
    fake, heard = FakeTime(), list[Exchange]()
    chip = SerialChip(ADDRESS, clock_s=fake.now)
    link = Link(LoopSerial(chip), ADDRESS, clock_s=fake.now, sleep_s=fake.sleep,
                on_reply=heard.append)
    link.init(TABLE)
    link.move(100, ccw=True)     # reads the position first (a lost reply's check)
    assert link.poll().state == "busy"
    fake.t += 1.0
    assert link.poll().code == 0x38
    assert link.errors().error_code == 0
    assert [(e.what, e.reply_to) for e in heard] == [
        ("init", "command"), ("position", "position"), ("move", "command"),
        ("poll", "poll"), ("poll", "poll"), ("error count", "error-count"),
        ("error code", "error-code")]
    decoded = [decode_reply(e.reply, reply_to=e.reply_to) for e in heard]
    assert [a.kind.key for a in decoded] == ["ready", "position", "ready", "busy",
                                             "stop report", "error count", "error code"]
    assert decoded[4].fields == {"end_code": 0x38}
    assert all(e.sent[0] in (0x80 + ADDRESS, 0x90 + ADDRESS) and e.attempt == 0
               for e in heard)
    assert set(LINK_REPLY_TO.values()) <= set(REPLY_TO)  # every exchange has its reading


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


# --- replies the link must not believe ----------------------------------------------------

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


# --- lost replies: nothing lost, nothing done twice ----------------------------------------

class PassThrough:
    """A port wrapper: everything goes to `port` unless a subclass says otherwise."""

    def __init__(self, port: Any) -> None:
        self.port = port

    @property
    def timeout(self) -> float | None:
        return self.port.timeout  # type: ignore[no-any-return]

    @timeout.setter
    def timeout(self, value: float | None) -> None:
        self.port.timeout = value

    def write(self, data: bytes) -> int:
        return self.port.write(data)  # type: ignore[no-any-return]

    def read(self, size: int = 1) -> bytes:
        return self.port.read(size)  # type: ignore[no-any-return]

    def reset_input_buffer(self) -> None:
        self.port.reset_input_buffer()

    def close(self) -> None:
        self.port.close()


class DropReplies(PassThrough):
    """Drops the chip's reply to chosen writes (counted from 0)."""

    def __init__(self, port: Any, drop: set[int]) -> None:
        super().__init__(port)
        self.drop, self.writes = drop, 0

    def write(self, data: bytes) -> int:
        n = self.port.write(data)
        if self.writes in self.drop:
            # Wait for the reply's first byte however slow the machine, then swallow
            # the rest: the master sees nothing.
            timeout = self.port.timeout
            self.port.timeout = 5.0
            assert self.port.read(1), "the chip did not answer"
            self.port.timeout = 0.05
            while self.port.read(64):
                pass
            self.port.timeout = timeout
        self.writes += 1
        return n  # type: ignore[no-any-return]


def test_a_move_whose_reply_is_lost_is_not_sent_twice(pty_chip: tuple[SerialChip, str],
                                                       skewed: SkewedTime) -> None:
    chip, path = pty_chip
    port = DropReplies(serial.Serial(path, timeout=0.1), drop={2})  # init, position, MOVE
    with Link(port, ADDRESS, timeout_s=0.3, **skewed.timing()) as link:
        link.init(TABLE)
        link.move(200)
        assert sum(line.startswith("move:") for line in chip.log) == 1
        assert link.stats["timeouts"] >= 1
        assert wait_stopped(link, 200).code == 0x38
        assert link.position() == 200
    port.close()


def test_a_lost_stop_report_is_recovered_from_the_end_status(
        pty_chip: tuple[SerialChip, str], skewed: SkewedTime) -> None:
    chip, path = pty_chip
    port = DropReplies(serial.Serial(path, timeout=0.1), drop={3})  # init, position, move, POLL
    with Link(port, ADDRESS, timeout_s=0.3, **skewed.timing()) as link:
        link.init(TABLE)
        link.move(100)
        time.sleep(move_s(100) + 0.02)
        stopped = link.poll()   # the chip's A0 38 is lost; the resent poll gets ready
        assert (stopped.state, stopped.code) == ("stopped", 0x38)
        assert "poll: stop report 0x38" in chip.log
        assert link.poll().state == "ready"
    port.close()


# --- a noisy line ---------------------------------------------------------------------------

class NoisyLine(PassThrough):
    """Between master and chip: each byte, either way, has a bit flipped or is dropped
    with the given probabilities (a seeded generator: the same faults each run)."""

    def __init__(self, port: Any, seed: int, flip: float, drop: float) -> None:
        super().__init__(port)
        self.rng, self.flip, self.drop = random.Random(seed), flip, drop
        self.faults = 0

    def _noise(self, data: bytes) -> bytes:
        out = bytearray()
        for byte in data:
            roll = self.rng.random()
            if roll < self.drop:
                self.faults += 1
                continue
            if roll < self.drop + self.flip:
                self.faults += 1
                byte ^= 1 << self.rng.randrange(8)
            out.append(byte)
        return bytes(out)

    def write(self, data: bytes) -> int:
        self.port.write(self._noise(data))
        return len(data)

    def read(self, size: int = 1) -> bytes:
        return self._noise(self.port.read(size))


@pytest.mark.parametrize("seed", [pytest.param(1, marks=pytest.mark.slow),  # ~6 s each
                                  pytest.param(2, marks=pytest.mark.slow),
                                  pytest.param(3, marks=pytest.mark.slow)])
def test_a_noisy_line_loses_and_misreads_nothing(pty_chip: tuple[SerialChip, str],
                                                 skewed: SkewedTime, seed: int) -> None:
    chip, path = pty_chip
    noisy = NoisyLine(serial.Serial(path, timeout=0.1), seed, flip=0.02, drop=0.02)
    link = Link(noisy, ADDRESS, timeout_s=0.15, retries=10, **skewed.timing())
    link.init(TABLE)
    assert chip.table == TABLE
    expected = 0
    rng = random.Random(seed)
    for _ in range(6):
        pulses, ccw = rng.randint(20, 150), rng.random() < 0.4
        link.move(pulses, ccw=ccw)
        expected = (expected + (-pulses if ccw else pulses)) % (1 << 32)  # §2-1.6: wraps
        time.sleep(move_s(pulses) + 0.01)
        assert link.poll() == PollReply("stopped", 0x38, "normal stop at the commanded position")
        assert link.position() == expected == chip.position
        assert link.poll().state == "ready"
        before = chip.error_count
        report = link.errors()
        assert before <= report.error_count <= chip.error_count
    assert sum(line.startswith("move:") for line in chip.log) == 6  # no move twice
    assert noisy.faults >= 5 and link.stats["resends"] > 0 and chip.error_count > 0
    noisy.close()


# --- the commands: `stepramp link …` and `stepramp emulate --pty` ----------------------------

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
    code, out, err = run_cli(["link", "--port", pty_chip[1], *argv], capsys)
    assert (code, out) == (2, "")
    assert err.startswith("stepramp link: ") and message in err and err.count("\n") == 1


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


# --- every serial motion command through the link (§16, the emulator's model) ---------------

def motion_link(fake: FakeTime, origin_at: int | None = None, on_reply: Any = None
                ) -> tuple[SerialChip, Link]:
    chip = SerialChip(ADDRESS, clock_s=fake.now, origin_at=origin_at)
    link = Link(LoopSerial(chip), ADDRESS, clock_s=fake.now, sleep_s=fake.sleep,
                on_reply=on_reply)
    link.init(TABLE)
    return chip, link


def poll_until_stopped(link: Link, fake: FakeTime, step_s: float = 0.05) -> Any:
    for _ in range(2000):
        fake.t += step_s
        reply = link.poll()
        if reply.state != "busy":
            return reply
    raise AssertionError("still busy")


@pytest.mark.parametrize(("name", "params"), [
    ("accel", {"pulses": 3000}), ("constant", {"pulses": 200, "rate": 1000}),
    ("step", {"ccw": True}), ("continuous", {}), ("continuous-constant", {"rate": 2000}),
    ("origin-search", {"rate": 1000, "index": True}), ("origin-return", {"rate": 0}),
])
def test_every_start_command_is_sent_answered_and_stopped(name: str, params: dict[str, Any]
                                                          ) -> None:
    fake = FakeTime()
    heard: list[Exchange] = []
    _, link = motion_link(fake, on_reply=heard.append)
    link.motion(name, **params)     # waits out the window after the init (§7-1)
    assert heard[-1].what == name and heard[-1].reply_to == "command"
    assert fake.slept == [pytest.approx(0.115, abs=1e-12)]
    assert link.poll().state == "busy" or name == "step"
    link.motion("stop")
    reply = poll_until_stopped(link, fake)
    assert reply.state == "stopped" and reply.code in (0x37, 0x38)


def test_a_constant_run_then_poll_until_stopped_advances_by_its_pulses() -> None:
    fake = FakeTime()
    _, link = motion_link(fake)
    link.motion("constant", rate=1000, pulses=4000)   # 8000 pps: half a second
    assert poll_until_stopped(link, fake, 0.1) == PollReply(
        "stopped", 0x38, "normal stop at the commanded position")
    assert link.position() == 4000
    link.motion("constant", rate=1000, pulses=1000, ccw=True)
    poll_until_stopped(link, fake)
    assert link.position() == 3000


def test_continuous_then_decel_stop_and_the_speed_changes_while_it_runs() -> None:
    fake = FakeTime()
    _, link = motion_link(fake)
    link.motion("continuous", rate=0)
    fake.t += 2.0
    assert link.poll().state == "busy"
    link.motion("change-speed", rate=1000)
    link.motion("set-speed", rate=800)
    fake.t += 1.0
    at = link.position()
    link.motion("decel-stop")
    assert poll_until_stopped(link, fake).code == 0x36
    assert link.position() > at


def test_the_chips_refusals_name_the_command() -> None:
    fake = FakeTime()
    chip, link = motion_link(fake)
    link.wait_until_motion_accepted()
    with pytest.raises(ChipRefused, match=r"^slave 5: change-speed: the chip refused it: "
                                          r"state error \(B5 43\)$"):
        link.motion("change-speed", rate=1000)
    with pytest.raises(ChipRefused, match=r"^slave 5: constant: the chip refused it: "
                                          r"parameter error \(B5 42\)$") as refused:
        link.motion("constant", rate=300, pulses=10)   # the table's rates: 400..10 000
    assert refused.value.code == 0x42
    assert chip.log[-1] == ("refused 0x42: constant (83): rate 300 is not within the "
                            "rates of the table it holds (400..10000) (§11-6 0x20)")


def test_origin_search_meets_org_where_the_emulator_puts_it() -> None:
    fake = FakeTime()
    _, link = motion_link(fake, origin_at=1500)
    link.motion("origin-search", rate=1000)
    assert poll_until_stopped(link, fake) == PollReply("stopped", 0x32,
                                                       "stopped at the origin input")
    assert link.position() == 1500


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


def test_cli_emulate_input_options_are_for_the_pty(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_cli(["emulate", "--bus", "x.bus", "--event-at", "0:5"], capsys)
    assert (code, out) == (2, "") and "--event-at: for --pty" in err
    code, out, err = run_cli(["emulate", "--pty", "--event-at", "2:5"], capsys)
    assert (code, out) == (2, "") and "NAME one of 0, 1" in err
    code, out, err = run_cli(["emulate", "--bus", "x.bus", "--limit-at", "fl:5"], capsys)
    assert (code, out) == (2, "") and "--limit-at: for --pty" in err
    code, out, err = run_cli(["emulate", "--pty", "--limit-at", "XL:5"], capsys)
    assert (code, out) == (2, "") and "NAME one of FL, BL, FHL, BHL" in err


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


def test_a_registration_whose_reply_is_lost_is_not_resent() -> None:
    from profiles.errors import LinkTimeout

    fake = FakeTime()
    chip = SerialChip(ADDRESS, clock_s=fake.now)
    chip.table = TABLE

    class Swallow(LoopSerial):  # type: ignore[misc]
        drop = False

        def write(self, data: bytes) -> int:
            replies = self.chip.receive(bytes(data))
            if replies and not self.drop:
                protocol_loop.Serial.write(self, replies)
            return len(data)

    from serial.urlhandler import protocol_loop

    port = Swallow(chip)
    link = Link(port, ADDRESS, clock_s=fake.now, sleep_s=fake.sleep, timeout_s=0.02)
    link.motion("continuous-constant", rate=2000)
    port.drop = True
    with pytest.raises(LinkTimeout, match="may be registered in the override buffer; not "
                                          "resent"):
        link.motion("stop", override_at=5000)
    assert len(chip._overrides) == 1 and link.stats["resends"] == 0
