"""The serial link master (profiles/ppmc312/link.py) against the serial chip on a real
pseudo-terminal, on a noisy line, and against scripted replies it must not believe."""

from __future__ import annotations

import re

import pytest

from profiles.errors import FieldChoiceError
from profiles.ppmc312.ascii import encode_frame
from profiles.ppmc312.clock import Clock
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
from profiles.ppmc312.table import InitTable
from tests.support.serial_link import ADDRESS, TABLE, SkewedTime, wait_stopped


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
