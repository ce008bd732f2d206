"""PPMC-312 acceptance emulator: per-block answers and parameter-error codes."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles.errors import DecodeError
from profiles.ppmc312.clock import INTERNAL_HZ, Clock
from profiles.ppmc312.emulator import ChipEmulator, accept_upload
from profiles.ppmc312.table import FreeCurveTable, InitTable
from profiles.ppmc312.upload import encode_free_curve, encode_init

SETTINGS = settings(max_examples=120, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


CLOCK = Clock.internal("8MHz")


@st.composite
def chip_valid_tables(draw: st.DrawFn) -> FreeCurveTable:
    """Tables the chip accepts: 2..127 stages, rates ≥ 2, pulses ≥ 2, totals ≤ 0xFFFFF."""
    clock = draw(st.sampled_from(list(INTERNAL_HZ)).map(Clock.internal))

    def side(n: int) -> list[int]:
        return draw(st.lists(st.integers(2, 0xFFFFF // n), min_size=n, max_size=n))

    n_acc = draw(st.integers(2, 127))
    accel = side(n_acc)
    decel = side(draw(st.integers(2, 127))) if draw(st.booleans()) else None
    n_rates = max(n_acc, len(decel or ()))
    rates = draw(st.lists(st.integers(2, 0xFFFF), min_size=n_rates, max_size=n_rates))
    return FreeCurveTable(clock, tuple(rates), tuple(accel),
                          None if decel is None else tuple(decel))


def _status(response: bytes) -> tuple[int, int]:
    assert response[:3] == b"\x03\x03\x01"
    return response[3], response[4]


@SETTINGS
@given(chip_valid_tables(), st.integers(3, 30))
def test_every_valid_encoded_table_is_accepted(table: FreeCurveTable, max_data: int) -> None:
    blocks = encode_free_curve(table, max_data=max_data)
    verdict = accept_upload(blocks)
    assert verdict.ok, verdict.message
    assert len(verdict.responses) == len(blocks)
    done = verdict.responses[-1]
    assert done[:4] == b"\x03\x08\x01\x0f"
    assert int.from_bytes(done[4:7], "big") == verdict.accel_total == sum(table.accel_pulses)
    assert int.from_bytes(done[7:10], "big") == verdict.decel_total == sum(table.decel)
    # Per-block progress: remaining stages of the section being written, counted down.
    expected = [(0, len(table.rates))]
    sent = {0: 0, 1: 0, 2: 0}
    counts = {0: len(table.rates), 1: len(table.accel_pulses), 2: len(table.decel)}
    section = 0
    for block in blocks[1:-1]:
        sent[section] += (len(block) - 2) // (2 if section == 0 else 3)
        if sent[section] == counts[section]:
            section += 1
        expected.append((section, counts[section] - sent[section]))
    assert [_status(r) for r in verdict.responses[:-1]] == expected


def test_progress_by_hand() -> None:
    table = FreeCurveTable(CLOCK, (100, 200, 300), (500, 400), (300, 300, 200))
    chip = ChipEmulator()
    answers = [chip.feed(b).hex(" ") for b in encode_free_curve(table, max_data=4)]
    assert answers == [
        "03 03 01 00 03",                  # 3 rates due
        "03 03 01 00 01",                  # 2 rates sent, 1 left
        "03 03 01 01 02",                  # rates done: 2 accel counts due
        "03 03 01 01 01",
        "03 03 01 02 03",                  # accel done: 3 decel counts due
        "03 03 01 02 02",
        "03 03 01 02 01",
        "03 08 01 0f 00 03 84 00 03 20",   # totals 900 and 800
    ]
    assert (chip.accel_total, chip.decel_total, chip.table_kind) == (900, 800, "free_curve")


def test_common_table_reports_the_accel_total_for_decel() -> None:
    verdict = accept_upload(encode_free_curve(FreeCurveTable(CLOCK, (10, 20), (300, 400))))
    assert verdict.ok and verdict.accel_total == verdict.decel_total == 700


def _upload(rates: tuple[int, ...], accel: tuple[int, ...],
            decel: tuple[int, ...] | None = None) -> list[bytes]:
    return encode_free_curve(FreeCurveTable(CLOCK, rates, accel, decel))


CMD = bytes.fromhex("02 03 01 00 02")


@pytest.mark.parametrize(("blocks", "code", "block"), [
    ([bytes.fromhex("03 03 01 00 02")], 0x10, 0),                 # execute header, no data
    ([bytes.fromhex("02 04 01 00 02")], 0x10, 0),                 # length 04 with LE=0
    (_upload((10,), (300,)), 0x11, 0),                            # 1 stage
    (_upload((10,) * 128, (300,) * 128), 0x11, 0),                # 128 stages
    (_upload((10, 20), (300, 400), (300,)), 0x11, 0),             # 1 decel stage
    ([CMD, bytes.fromhex("00 1f") + bytes(10)], 0x15, 1),         # length byte 31
    ([bytes.fromhex("02 1f 01 00 02")], 0x15, 0),
    ([CMD, bytes.fromhex("00 06 00 0a 00 14 00 1e")], 0x16, 1),   # 3 rates for 2 stages
    ([CMD, bytes.fromhex("00 03 00 0a 00")], 0x16, 1),            # half an entry
    ([CMD, bytes.fromhex("02 04 00 0a 00 14")], 0x17, 1),         # header 02 mid-upload
    ([CMD, bytes.fromhex("00 05 00 0a 00 14")], 0x17, 1),         # length ≠ bytes written
    ([CMD, bytes.fromhex("01 04 00 0a 00 14")], 0x17, 1),         # 01 before the end
    ([*_upload((10, 20), (300, 400))[:-1], bytes.fromhex("00 06 00 01 2c 00 01 90")],
     0x17, 2),                                                    # 00 on the completing block
    (_upload((10, 1), (300, 400)), 0x18, 1),                      # rate 1
    (_upload((10, 0), (300, 400)), 0x18, 1),
    (_upload((10, 20), (300, 1)), 0x19, 2),                       # 1 pulse
    (_upload((10, 20), (300, 400), (2, 0)), 0x19, 3),
    (_upload((10, 20), (0x80000, 0x80000)), 0x1A, 2),             # total 0x100000
    (_upload((10, 20), (300, 400), (0xFFFFF, 1 << 20)), 0x1A, 3),
])
def test_parameter_error_codes(blocks: list[bytes], code: int, block: int) -> None:
    verdict = accept_upload(blocks)
    assert not verdict.ok
    assert (verdict.response_code, verdict.error_code, verdict.block) == (0xF0, code, block)
    assert verdict.responses[-1] == bytes([0x03, 0x03, 0xF0, code, 0x01])
    assert f"0x{code:02X}" in verdict.message and "\n" not in verdict.message


def test_data_block_when_idle_is_a_state_error_and_keeps_the_table() -> None:
    blocks = _upload((10, 20), (300, 400))
    chip = ChipEmulator()
    for b in blocks:
        chip.feed(b)
    assert chip.feed(blocks[-1]).hex(" ") == "03 04 f1 01 02 00"  # status 01, NOR state
    assert chip.table_kind == "free_curve"
    verdict = accept_upload([*blocks, blocks[-1]])
    assert (verdict.ok, verdict.response_code, verdict.block) == (False, 0xF1, len(blocks))


def test_refused_upload_destroys_the_table() -> None:
    chip = ChipEmulator()
    for b in _upload((10, 20), (300, 400)):
        chip.feed(b)
    bad = _upload((10, 20), (300, 1))
    assert [chip.feed(b)[2] for b in bad] == [0x01, 0x01, 0xF0]
    assert chip.table_kind is None and chip.accel_total is None


def test_incomplete_upload_is_not_ok() -> None:
    verdict = accept_upload(_upload((10, 20), (300, 400))[:-1])
    assert not verdict.ok and verdict.error_code is None and "waiting" in verdict.message
    assert not accept_upload([]).ok


def _init(start: int, high: int, pulses: int, stop: int | None = None,
          decel: int | None = None) -> bytes:
    return encode_init(InitTable(CLOCK, "linear", start, high, pulses, stop, decel))


@pytest.mark.parametrize(("block", "code"), [
    (_init(0x1000, 0x100, 0x200)[:-1], 0x00),                 # short block
    (b"\x02" + _init(0x1000, 0x100, 0x200)[1:], 0x00),        # header 02
    (bytes.fromhex("03 09 00 10") + _init(0x1000, 0x100, 0x200)[4:], 0x00),  # LE=1, 9 bytes
    (_init(0x10, 0x2, 0x200), 0x01),                          # start below 0x11
    (_init(0x1000, 0x1, 0x200), 0x01),                        # high below 2
    (_init(0x1000, 0xFFF0, 0x200), 0x01),                     # high above FFEF
    (_init(0x17F, 0x100, 0x200), 0x02),                       # gap 127
    (_init(0x17F, 0x100, 0x200, 0x1000, 0x200), 0x04),        # the faster end within 127
    (_init(0x100, 0x100, 0x200, 0x150, 0x200), 0x03),         # start = high: 03 comes first
    (_init(0x1000, 0x100, 0x200, 0x100, 0x200), 0x03),        # stop = high
    (_init(0x80, 0x100, 0x200, 0x1000, 0x200), 0x03),         # start faster than high
])
def test_init_error_codes(block: bytes, code: int) -> None:
    verdict = accept_upload([block])
    assert (verdict.ok, verdict.response_code, verdict.error_code) == (False, 0xF0, code)
    assert verdict.responses == [bytes([0x03, 0x03, 0xF0, code, 0x00])]


@pytest.mark.parametrize("block", [
    _init(0x1000, 0x100, 0xF), _init(0x1000, 0x100, 0x100000),
    _init(0x1000, 0x100, 0x200, 0x1000, 0x100000)])
def test_init_pulse_counts_out_of_range_have_no_chip_code(block: bytes) -> None:
    # The manual's 01 is "rate data out of range"; no code covers pulse counts, so the
    # emulator invents none and the check reports them (same rules, one place).
    from profiles.ppmc312.chip_rules import check_table
    from profiles.ppmc312.upload import decode_init

    assert accept_upload([block]).ok
    errors = [(f.rule, f.chip_code) for f in check_table(decode_init(block))
              if f.severity == "error"]
    assert ("init-pulses-field", None) in errors
    assert 0x01 not in {code for _, code in errors}


def test_init_accepted() -> None:
    for block in (_init(0x180, 0x100, 0x200), _init(0x1000, 0x2, 0x10, 0x11 + 0x80, 0xFFFFF)):
        verdict = accept_upload([block])
        assert verdict.ok and verdict.responses == [bytes.fromhex("03 01 00")]
    # The x bits of the mode byte are ignored by the chip.
    block = bytearray(_init(0x180, 0x100, 0x200))
    block[3] |= 0xE0
    assert accept_upload([bytes(block)]).ok


def test_size_error_and_unmodelled_commands() -> None:
    verdict = accept_upload([bytes.fromhex("03 1f 00") + bytes(29)])
    assert (verdict.response_code, verdict.responses[-1]) == (0xF6, bytes.fromhex("03 02 f6 1f"))
    with pytest.raises(DecodeError, match="0x82 is not modelled") as err:
        accept_upload([bytes.fromhex("03 08 82 40 00 00 12 34 56 78")])
    assert err.value.block == 0
    with pytest.raises(DecodeError, match="at most 32"):
        ChipEmulator().feed(bytes(33))
    with pytest.raises(DecodeError, match="empty"):
        accept_upload([CMD, b""])


@st.composite
def mutated(draw: st.DrawFn) -> list[bytes]:
    blocks = [bytearray(b) for b in
              encode_free_curve(draw(chip_valid_tables()), max_data=draw(st.integers(3, 30)))]
    for _ in range(draw(st.integers(1, 3))):
        k = draw(st.integers(0, len(blocks) - 1))
        how = draw(st.sampled_from(["flip", "truncate", "length", "drop", "junk", "byte"]))
        if how == "flip":
            blocks[k][0] ^= draw(st.sampled_from([1, 2, 4, 0x80]))
        elif how == "truncate" and len(blocks[k]) > 1:
            blocks[k] = blocks[k][:draw(st.integers(1, len(blocks[k]) - 1))]
        elif how == "length" and len(blocks[k]) > 1:  # a 1-byte block has no length byte
            blocks[k][1] = draw(st.integers(0, 255))
        elif how == "drop" and len(blocks) > 1:
            blocks.pop(k)
        elif how == "junk":
            blocks.append(bytearray(draw(st.binary(min_size=1, max_size=32))))
        elif how == "byte":
            i = draw(st.integers(0, len(blocks[k]) - 1))
            blocks[k][i] = draw(st.integers(0, 255))
    return [bytes(b) for b in blocks]


@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
@SETTINGS
@given(mutated())
def test_mutated_uploads_give_a_chip_error_or_decode_error(blocks: list[bytes]) -> None:
    try:
        verdict = accept_upload(blocks)
    except DecodeError as e:
        assert "\n" not in str(e)
        return
    assert len(verdict.responses) <= len(blocks)
    if not verdict.ok:
        assert verdict.error_code is not None or "waiting" in verdict.message
        if verdict.error_code is not None:
            assert verdict.responses[-1][2] in (0xF0, 0xF1, 0xF6)


def test_empty_parameter_block_changes_nothing() -> None:
    blocks = _upload((10, 20), (300, 400))
    chip = ChipEmulator()
    assert chip.feed(blocks[0]).hex(" ") == "03 03 01 00 02"
    assert chip.feed(bytes.fromhex("00 00")).hex(" ") == "03 03 01 00 02"
    assert [chip.feed(b)[3] for b in blocks[1:]] == [0x01, 0x0F]
    # …but an empty block cannot end an upload that still expects data.
    verdict = accept_upload([blocks[0], bytes.fromhex("01 00")])
    assert (verdict.error_code, verdict.block) == (0x17, 1)


def test_a_one_byte_block_is_judged_not_crashed() -> None:
    """The case the `mutated` strategy used to crash on (it set the length byte of a
    block truncated to 1 byte): a lone command byte is a chip answer or one-line error."""
    blocks = encode_free_curve(FreeCurveTable(Clock.internal("8MHz"), (400, 500), (100, 100)))
    for k in range(len(blocks)):
        cut = [*blocks[:k], blocks[k][:1], *blocks[k + 1:]]
        try:
            verdict = accept_upload(cut)
        except DecodeError as e:
            assert "\n" not in str(e)
        else:
            assert not verdict.ok


@pytest.mark.parametrize(("blocks", "words"), [
    (_upload((10, 20, 30, 1), (300,) * 4), "rate 1 at stage 3"),
    (_upload((10, 20, 30), (300, 400, 1)), "accel pulses 1 at stage 2"),
    (_upload((10, 20, 30), (300, 400, 500), (2, 3, 1)), "decel pulses 1 at stage 2"),
])
def test_a_refused_entry_is_named_by_its_stage(blocks: list[bytes], words: str) -> None:
    """The message points at the entry the chip refused: its place in its section."""
    assert accept_upload(blocks).message.endswith(words)


def test_the_alarm_state_refuses_every_block_until_a_reset() -> None:
    """Manual §11-9 and 表 2-1 (異常発生: ほとんどの命令を受け付けられません): the upload in
    progress is dropped; every block draws F1 00 with the ALM bit (0x10), unexecuted."""
    table = FreeCurveTable(CLOCK, (100, 200, 300), (500, 400, 300))
    blocks = encode_free_curve(table, max_data=4)
    chip = ChipEmulator()
    assert chip.feed(blocks[0]).hex(" ") == "03 03 01 00 03"
    chip.raise_alarm(0x01)
    assert not chip.busy and chip.alarm == 0x01
    assert chip.feed(blocks[1]).hex(" ") == "03 04 f1 00 11 00"  # ALM | INI, no command code
    assert chip.feed(blocks[0]).hex(" ") == "03 04 f1 00 11 01"  # the free-curve command
    init = encode_init(InitTable(CLOCK, "linear", 0x2710, 0x190, 0x7D0))
    assert chip.feed(init).hex(" ") == "03 04 f1 00 11 00"
    assert chip.table_kind is None and "alarm state" in chip.last_message
    chip.reset()
    assert chip.alarm is None and chip.feed(init).hex(" ") == "03 01 00"
    chip.raise_alarm(0x01)  # with a table: ALM | NOR; the table is kept
    assert chip.feed(init).hex(" ") == "03 04 f1 00 12 00" and chip.table_kind == "init"
