"""The PPMC-312 on its parallel bus, register by register (manual §5-4, §5-6, §5-8, §11-9):
bus scripts run through the bus emulator, every expected read checked, an answer left
unread raising alarm F4 01 at the line that overwrote it."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles.errors import CorruptedError, DecodeError
from profiles.ppmc312.bus import (
    BusChip,
    answer_reads,
    read_bus_script,
    run_bus_script,
)
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.emulator import expected_answers
from profiles.ppmc312.formats import parse, render
from profiles.ppmc312.table import FreeCurveTable, InitTable
from profiles.ppmc312.upload import bus_writes, encode_free_curve, encode_init
from tests.support.bus_scripts import header_lines, read_groups
from tests.support.strategies import accepted_tables

SETTINGS = settings(max_examples=40, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


CLOCK = Clock.internal("8MHz")


BLOCKS = encode_free_curve(FreeCurveTable(CLOCK, (100, 200, 300), (10, 20, 30)), max_data=4)


SCRIPT = render(BLOCKS, "bus").decode().splitlines()


# --- our own scripts ---------------------------------------------------------------------------
@SETTINGS
@given(st.data(), st.booleans(), st.integers(3, 30))
def test_our_bus_script_runs_without_an_alarm(data: st.DataObject, le: bool,
                                              max_data: int) -> None:
    blocks = encode_free_curve(data.draw(accepted_tables(separate=le)), max_data=max_data)
    run = run_bus_script(render(blocks, "bus"))
    assert run.ok, run.message
    assert run.alarm is None and run.blocks == len(blocks)
    assert list(run.answers) == expected_answers(blocks)


def test_an_init_script_runs() -> None:
    blocks = [encode_init(InitTable(CLOCK, "linear", 0x2710, 0x190, 0x7D0))]
    run = run_bus_script(render(blocks, "bus"))
    assert run.ok and run.answers == (bytes.fromhex("03 01 00"),)
    assert run.message == "1 blocks written, 1 answers read, every expected read matched"


@SETTINGS
@given(st.data(), st.integers(3, 30))
def test_a_skipped_read_raises_f4_01_at_the_next_header(data: st.DataObject,
                                                        max_data: int) -> None:
    blocks = encode_free_curve(data.draw(accepted_tables()), max_data=max_data)
    lines = render(blocks, "bus").decode().splitlines()
    k = data.draw(st.integers(0, len(blocks) - 2))  # not the last: a block must follow
    start = read_groups(lines)[k]
    size = 0x40 - int(lines[start + 2].split()[1], 16)
    skipped = lines[:start] + lines[start + 3 + size:]
    run = run_bus_script("\n".join(skipped))
    assert not run.ok and run.alarm == 0x01
    assert run.line == header_lines(skipped)[k + 1]
    assert f"block {k + 1} is issued while block {k}'s answer" in run.message
    assert "alarm F4 01" in run.message and "23 02 F4 01" in run.message


def test_a_half_read_answer_still_fills_its_buffer() -> None:
    """§5-4/§5-8: the answer leaves its buffer with its last byte; one DRR short, the
    next block's answer overwrites it."""
    last_drr = read_groups(SCRIPT)[0] + 7  # block 0's fifth and last DRR read (the header)
    assert SCRIPT[last_drr] == "DRR 03"
    short = SCRIPT[:last_drr] + SCRIPT[last_drr + 1:]
    run = run_bus_script("\n".join(short))
    assert run.alarm == 0x01 and run.line == header_lines(short)[1]


def test_a_wrong_expected_byte_is_reported_at_its_line() -> None:
    bad = list(SCRIPT)
    k = read_groups(bad)[2] + 3  # block 2's answer, its first DRR read: the remaining 03
    assert bad[k] == "DRR 03"
    bad[k] = "DRR 02"
    run = run_bus_script("\n".join(bad))
    assert not run.ok and run.line == k + 1 and run.alarm is None
    assert run.message == (f"line {k + 1}: DRR reads 03, the script expects 02 (the chip "
                           "answers 03 03 01 01 03)")
    bad = list(SCRIPT)
    bad[k - 1] = "RAR 3C"
    assert run_bus_script("\n".join(bad)).message == f"line {k}: RAR reads 3B, the script " \
                                                     "expects 3C"


def test_scripts_written_before_the_handshake() -> None:
    writes = [f"{r} {v:02X}" for b in BLOCKS for r, v in bus_writes(b)]
    run = run_bus_script("\n".join(writes))  # no waits at all
    assert run.line == 8 and "no CSR read since the last block was issued" in run.message
    waited = [line for b in BLOCKS for line in
              ("WAIT CSR.MWEF 0", *(f"{r} {v:02X}" for r, v in bus_writes(b)))]
    run = run_bus_script("\n".join(waited))  # §5-6 followed, answers never read
    assert run.alarm == 0x01 and run.line == header_lines(waited)[1]
    # …and the format still reads them, without answers
    assert parse("\n".join(waited).encode()).items == BLOCKS


def test_an_answer_left_unread_at_the_end_is_reported() -> None:
    lines = SCRIPT[:read_groups(SCRIPT)[-1]]
    run = run_bus_script("\n".join(lines))
    assert not run.ok and run.alarm is None and run.line == len(lines)
    assert "block 5's command response 03 08 01 0F 00 00 3C 00 00 3C unread" in run.message


@pytest.mark.parametrize(("script", "line", "says"), [
    ("WAIT CSR.MREF 0", 1, "WAIT CSR.MREF 0 would never end: no response is waiting"),
    ("RCR --", 1, "RCR read with no response waiting"),
    ("WAR 1B", 1, "WAR written without WCR 20"),
    ("WCR 20\nDWR 03", 2, "DWR written before WCR 20 and WAR"),
    ("WCR 21", 1, "WCR 21: WCR takes 0x20 only"),
    ("WCR 20\nWAR 1F\nWCR 20", 3, "WCR 20 with the block before it unfinished"),
    ("WCR 20\nWAR 21", 2, "WAR 21 gives a block of -1 bytes"),
    ("WCR 20\nWAR 1D\nDWR 00\nDWR 01\nDWR 03\nRAR 3D", 6, "RAR read before RCR"),
    ("WCR 20\nWAR 1D\nDWR 00\nDWR 01\nDWR 03\nRCR --\nDRR 00", 7, "DRR read before RAR"),
    ("WCR 20\nWAR 15\n" + "\n".join(f"DWR {b:02X}" for b in reversed(encode_init(
        InitTable(CLOCK, "linear", 0x2710, 0x190, 0x7D0)))) + "\nRCR --\nRAR 3D\nDRR 00\n"
     "DRR 01\nDRR 03\nDRR 00", 19, "DRR read before RCR's dummy read"),  # one read too many
])
def test_procedure_slips_are_reported_at_their_line(script: str, line: int, says: str) -> None:
    run = run_bus_script(script)
    assert not run.ok and run.line == line, run
    assert run.message.startswith(f"line {line}: ")
    assert any(part in run.message for part in says.split("|")), run.message


@pytest.mark.parametrize(("script", "says"), [
    ("WAIT CSR.MREF 1", "line 1: a wait is 'WAIT CSR.MWEF 0' or 'WAIT CSR.MREF 0'"),
    ("WAIT CSR.EWRQ 0", "line 1: a wait is"),
    ("WCR 20\nRCR 00", "line 2: RCR is a dummy read, written 'RCR --'"),
    ("WCR 20\nFOO 12", "line 2: expected 'WCR|WAR|DWR XX', 'RCR --', 'RAR|DRR XX'"),
    ("DRR 0102", "line 1: a register access carries one byte"),
    ("DRR 1", "line 1, column 1.*odd"),
    ("# comments only\n\n", "the bus script holds no register access"),
])
def test_a_line_that_is_no_access_is_a_decode_error(script: str, says: str) -> None:
    with pytest.raises(DecodeError, match=says):
        run_bus_script(script)


# --- the chip's registers -------------------------------------------------------------------------
def test_the_alarm_state() -> None:
    """Block 1 written over block 0's unread answer: block 0's answer stays readable, then
    the alarm response; in the alarm state every block is refused (F1 00, ALM) until a
    reset."""
    bus = BusChip()
    for block in BLOCKS[:2]:
        bus.read_csr()
        for register, value in bus_writes(block):
            bus.write(register, value)
    assert bus.alarm == 0x01
    assert [(w.kind, w.response.hex(" "), w.block) for w in bus.waiting] == [
        ("command", "03 03 01 00 03", 0), ("alarm", "23 02 f4 01", 1)]

    def read_one() -> bytes:
        bus.read("RCR")
        size = 0x40 - bus.read("RAR")
        return bytes(reversed([bus.read("DRR") for _ in range(size)]))

    assert read_one() == bytes.fromhex("03 03 01 00 03")
    assert bus.read_csr() & 0x04 == 0  # MREF 0: the alarm still waits
    assert read_one() == bytes.fromhex("23 02 F4 01")
    assert bus.read_csr() == 0x04      # MREF 1: nothing waits; MWEF 0
    for register, value in bus_writes(BLOCKS[2]):
        bus.write(register, value)
    assert read_one() == bytes.fromhex("03 04 F1 00 11 00")  # state error: ALM | INI
    bus.reset()
    assert bus.alarm is None and not bus.waiting and not bus.issued
    for register, value in bus_writes(BLOCKS[0]):
        bus.write(register, value)
    assert read_one() == bytes.fromhex("03 03 01 00 03")


def test_an_alarm_over_an_unread_alarm_keeps_the_first() -> None:
    bus = BusChip()
    for block in BLOCKS[:4]:
        bus.read_csr()
        for register, value in bus_writes(block):
            bus.write(register, value)
    assert [w.kind for w in bus.waiting] == ["command", "alarm"]
    assert bus.issued == BLOCKS[:4]


def test_the_manuals_read_example_order() -> None:
    """§5-8: the position-read answer 03 06 42 00 12 34 56 78 is read 78 56 34 12 00 42
    06 03, lowest parameter first, the header last."""
    assert answer_reads(bytes.fromhex("03 06 42 00 12 34 56 78")) == [
        "WAIT CSR.MREF 0", "RCR --", "RAR 38", "DRR 78", "DRR 56", "DRR 34", "DRR 12",
        "DRR 00", "DRR 42", "DRR 06", "DRR 03"]
    with pytest.raises(DecodeError, match="0 bytes cannot be read"):
        answer_reads(b"")


def test_read_bus_script_lines() -> None:
    lines = read_bus_script("# c\nWAIT CSR.MWEF 0  # x\nWCR 20\nRCR --\nDRR 0a\n")
    assert [(b.number, b.op, b.value, b.bit) for b in lines] == [
        (2, "WAIT", 0, "MWEF"), (3, "WCR", 0x20, ""), (4, "RCR", None, ""),
        (5, "DRR", 0x0A, "")]


# --- the bus format reads the answers back ------------------------------------------------------
@pytest.mark.parametrize(("change", "error", "says"), [
    (lambda ls: ls[:9] + ls[10:], DecodeError,
     r"line 10: an answer is read as WAIT CSR.MREF 0, RCR --, RAR XX"),      # no RCR
    (lambda ls: ls[:14] + ls[15:], DecodeError,
     r"line 11: RAR 3B says 5 DRR reads follow; found 4"),                   # a DRR dropped
    (lambda ls: [*ls[:13], "DRR 02", *ls[14:]], CorruptedError,
     r"line 9: the file expects the answer 03 03 02 00 03 to block 0, the chip "
     r"answers 03 03 01 00 03"),                                             # a byte changed
    (lambda ls: [*ls[:read_groups(ls)[1]], *ls[read_groups(ls)[1] + 8:]], CorruptedError,
     r"block 1 has no expected answer"),                                     # a read skipped
])
def test_the_bus_format_checks_its_answers(change: object, error: type[Exception],
                                           says: str) -> None:
    assert callable(change)
    with pytest.raises(error, match=says):
        parse("\n".join(change(list(SCRIPT))).encode())
