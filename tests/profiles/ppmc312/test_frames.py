"""PPMC-312 frame descriptions: layouts, bit fields and response headers."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.errors import DecodeError, FieldChoiceError, FieldRangeError
from profiles.fields import Const, Frame
from profiles.ppmc312 import frames as F

SETTINGS = settings(max_examples=100, deadline=None)


FIXED = [F.INIT_COMMON, F.INIT_SEPARATE, F.FC_COMMAND_COMMON, F.FC_COMMAND_SEPARATE, F.MOVE,
         F.FC_PROGRESS, F.FC_DONE, F.INIT_DONE, F.PARAM_ERROR, F.STATE_ERROR, F.SIZE_ERROR,
         F.TABLE_READ_COMMAND, F.TABLE_READ_FIRST]


@pytest.mark.parametrize("frame", FIXED, ids=lambda f: f.name)
def test_length_byte_counts_every_byte_after_it(frame: Frame) -> None:
    # Fixed frames start header, length: length = size − 2, and fit the bus.
    assert frame.size is not None and frame.size <= F.MAX_BLOCK_BYTES
    length = frame.fields[1]
    assert isinstance(length, Const) and length.value == bytes([frame.size - 2])


@SETTINGS
@given(st.integers(0, 1), st.integers(0, 7), st.integers(0, 0xFFFF), st.integers(0, 0xFFFF),
       st.integers(0, 0xFFFFFF))
def test_init_mode_byte(fo: int, clk: int, start: int, high: int, pulses: int) -> None:
    block = F.INIT_COMMON.encode(fo=fo, clk=clk, start_rate=start, high_rate=high,
                                 accel_pulses=pulses)
    assert block[3] == fo << 3 | clk  # bit4 LE = 0, bits 7-5 zero
    assert block[4:6] == start.to_bytes(2, "big") and block[8:11] == pulses.to_bytes(3, "big")
    assert F.INIT_COMMON.decode(block) == {"fo": fo, "clk": clk, "start_rate": start,
                                           "high_rate": high, "accel_pulses": pulses}
    sep = F.INIT_SEPARATE.encode(fo=fo, clk=clk, start_rate=start, stop_rate=start,
                                 high_rate=high, accel_pulses=pulses, decel_pulses=pulses)
    assert sep[3] == 0x10 | fo << 3 | clk


def test_free_curve_command_layouts() -> None:
    assert F.FC_COMMAND_COMMON.encode(clk=3, accel_stages=0x7F).hex(" ") == "02 03 01 03 7f"
    assert F.FC_COMMAND_SEPARATE.encode(clk=0, accel_stages=2, decel_stages=9).hex(" ") == \
        "02 04 01 10 02 09"
    with pytest.raises(FieldRangeError, match="accel_stages"):
        F.FC_COMMAND_COMMON.encode(clk=0, accel_stages=0)
    with pytest.raises(DecodeError, match="unexpected bits"):
        F.FC_COMMAND_COMMON.decode(bytes.fromhex("02 03 01 08 02"))  # bit3 (FO) is x here


@SETTINGS
@given(st.sampled_from([F.RATE_BLOCK, F.ACCEL_BLOCK, F.DECEL_BLOCK]), st.booleans(),
       st.data())
def test_parameter_blocks(frame: Frame, last: bool, data: st.DataObject) -> None:
    item = frame.fields[-1].item  # type: ignore[union-attr]
    items = data.draw(st.lists(st.integers(0, item.max), min_size=1,
                               max_size=F.MAX_BLOCK_DATA // item.size))
    block = frame.encode(last=int(last), length=len(items) * item.size, items=items)
    assert block[0] == int(last) and block[1] == len(block) - 2 <= F.MAX_BLOCK_DATA
    assert block[2:] == b"".join(v.to_bytes(item.size, "big") for v in items)
    assert frame.decode(block)["items"] == items


def test_move_mode_bits() -> None:
    block = F.MOVE.encode(dir=1, ov=1, trg=3, high_rate=0x0102, pulses=0xFFFFFFFF)
    assert block.hex(" ") == "03 08 82 47 01 02 ff ff ff ff"
    with pytest.raises(DecodeError, match="unexpected bits"):
        F.MOVE.decode(bytes.fromhex("03 08 82 80 00 00 00 00 00 01"))


@pytest.mark.parametrize(("byte", "bits"), [
    (0x03, {"cmr": 0, "resp": 0, "pal": 1, "next": 1}),   # every bus answer we emit
    (0x02, {"cmr": 0, "resp": 0, "pal": 1, "next": 0}),   # table read, first block
    (0x01, {"cmr": 0, "resp": 0, "pal": 0, "next": 1}),   # table read, last item block
    (0x3B, {"cmr": 1, "resp": 3, "pal": 1, "next": 1}),   # non-command, from override
])
def test_response_header_bits(byte: int, bits: dict[str, int]) -> None:
    assert F.RESPONSE_HEADER.unpack_int(byte, 0) == bits
    assert F.RESPONSE_HEADER.pack_int(bits, "header") == byte
    with pytest.raises(DecodeError):
        F.RESPONSE_HEADER.unpack_int(byte | 0x04, 0)  # bit 2 is always 0


def test_responses() -> None:
    assert F.FC_DONE.encode(accel_total=0x12345, decel_total=0xFFFFF).hex(" ") == \
        "03 08 01 0f 01 23 45 0f ff ff"
    assert F.PARAM_ERROR.encode(error=0x19, command=1).hex(" ") == "03 03 f0 19 01"
    assert F.FC_PROGRESS.decode(bytes.fromhex("03 03 01 02 05")) == {"status": 2,
                                                                      "remaining": 5}
    with pytest.raises(DecodeError, match="status"):
        F.FC_PROGRESS.decode(bytes.fromhex("03 03 01 03 05"))


def test_table_read_item_blocks_carry_a_kind_byte() -> None:
    block = F.READ_ACCEL.encode(next=1, length=7, items=[5, 0x10203])
    assert block.hex(" ") == "01 07 02 00 00 05 01 02 03"
    with pytest.raises(DecodeError, match="kind"):
        F.READ_RATES.decode(block)


def test_check_length_byte_and_choice_error() -> None:
    assert F.check_length_byte(bytes.fromhex("00 02 0a 0b"), 1) == 2
    with pytest.raises(DecodeError, match="carries 1") as err:
        F.check_length_byte(bytes.fromhex("00 02 0a"), 4)
    assert (err.value.block, err.value.byte) == (4, 1)
    with pytest.raises(DecodeError, match="no length byte"):
        F.check_length_byte(b"\x00", 0)
    err2 = FieldChoiceError("trigger", 2, (1, 3))
    assert str(err2) == "trigger: 2 is not one of the allowed values 1, 3"
    assert isinstance(err2, FieldRangeError)
    assert (err2.field, err2.value, err2.lo, err2.hi) == ("trigger", 2, 1, 3)


# --- golden bytes of every fixed frame, written out by hand from the manual -----------------
@pytest.mark.parametrize("frame, fields, hexed", [
    (F.INIT_COMMON, dict(fo=1, clk=2, start_rate=0x1234, high_rate=0x0056,
                         accel_pulses=0x0789AB), "03 09 00 0a 12 34 00 56 07 89 ab"),
    (F.INIT_SEPARATE, dict(fo=0, clk=7, start_rate=0x1000, stop_rate=0x2000, high_rate=0x0100,
                           accel_pulses=0x000300, decel_pulses=0x0FFFFF),
     "03 0e 00 17 10 00 20 00 01 00 00 03 00 0f ff ff"),
    (F.FC_COMMAND_COMMON, dict(clk=5, accel_stages=2), "02 03 01 05 02"),
    (F.FC_COMMAND_SEPARATE, dict(clk=6, accel_stages=127, decel_stages=1), "02 04 01 16 7f 01"),
    (F.MOVE, dict(dir=0, ov=0, trg=0, high_rate=0, pulses=1), "03 08 82 00 00 00 00 00 00 01"),
    (F.FC_PROGRESS, dict(status=F.STATUS_ACCEL, remaining=0x7E), "03 03 01 01 7e"),
    (F.FC_DONE, dict(accel_total=1, decel_total=0x100), "03 08 01 0f 00 00 01 00 01 00"),
    (F.INIT_DONE, {}, "03 01 00"),
    (F.PARAM_ERROR, dict(error=0x05, command=0), "03 03 f0 05 00"),
    (F.STATE_ERROR, dict(status=2, state=0x3F, command=0x82), "03 04 f1 02 3f 82"),
    (F.SIZE_ERROR, dict(length_written=0x1F), "03 02 f6 1f"),
    (F.TABLE_READ_COMMAND, {}, "03 01 41"),
    (F.TABLE_READ_FIRST, dict(rate_stages=3, accel_stages=3, decel_stages=2,
                              accel_total=0x010203, decel_total=0x0A0B0C),
     "02 0a 41 03 03 02 01 02 03 0a 0b 0c"),
], ids=lambda v: v.name if isinstance(v, Frame) else None)
def test_fixed_frame_golden_bytes(frame: Frame, fields: dict[str, int], hexed: str) -> None:
    assert frame.encode(**fields).hex(" ") == hexed
    assert frame.decode(bytes.fromhex(hexed)) == fields


@pytest.mark.parametrize("frame, kind", [(F.READ_RATES, "01"), (F.READ_ACCEL, "02"),
                                         (F.READ_DECEL, "03")])
def test_table_read_item_golden_bytes(frame: Frame, kind: str) -> None:
    size = frame.fields[-1].item.size  # type: ignore[union-attr]
    block = frame.encode(next=0, length=1 + size, items=[0x0102])
    assert block.hex(" ") == f"00 {1 + size:02x} {kind} " + ("01 02" if size == 2
                                                              else "00 01 02")
    for other in {"01", "02", "03"} - {kind}:  # the kind byte is fixed per block kind
        with pytest.raises(DecodeError, match="kind"):
            frame.decode(bytes.fromhex(f"00 {1 + size:02x} {other} " + "00 " * size))


def test_constants_of_the_bus() -> None:
    # manual §5-5/§5-6: a block is at most 32 bytes (WAR = 0x20 − size), 30 data bytes;
    # a length byte of 31 or more is refused (0x15); a read block at most 0x40 − 2 after
    # its length; a read item block carries 13 data bytes.
    assert (F.MAX_BLOCK_BYTES, F.MAX_BLOCK_DATA, F.REFUSED_LENGTH) == (32, 30, 31)
    assert (F.MAX_READ_LENGTH, F.READ_DATA_BYTES) == (62, 13)
    assert (F.HDR_CODE_MORE, F.HDR_CODE_EXEC) == (2, 3)
    assert (F.CODE_INIT, F.CODE_FREE_CURVE, F.CODE_TABLE_READ, F.CODE_ACCEL_MOVE) == (
        0x00, 0x01, 0x41, 0x82)
    assert (F.RESP_PARAM_ERROR, F.RESP_STATE_ERROR, F.RESP_SIZE_ERROR) == (0xF0, 0xF1, 0xF6)
    assert (F.STATUS_RATES, F.STATUS_ACCEL, F.STATUS_DECEL, F.STATUS_DONE) == (0, 1, 2, 0x0F)
    assert (F.ITEM_KIND_RATES, F.ITEM_KIND_ACCEL, F.ITEM_KIND_DECEL) == (1, 2, 3)
    assert F.OVERRIDE_TRIGGERS == (1, 3) and (F.RATE_SIZE, F.PULSES_SIZE) == (2, 3)


@pytest.mark.parametrize("frame", [F.RATE_BLOCK, F.ACCEL_BLOCK, F.DECEL_BLOCK, F.READ_RATES,
                                   F.READ_ACCEL, F.READ_DECEL], ids=lambda f: f.name)
def test_a_block_carries_at_least_one_entry(frame: Frame) -> None:
    head = {"last": 0} if frame in (F.RATE_BLOCK, F.ACCEL_BLOCK, F.DECEL_BLOCK) else {"next": 0}
    size = frame.fields[-1].item.size  # type: ignore[union-attr]
    length = size + (1 if "next" in head else 0)  # the entries (and a read block's kind byte)
    with pytest.raises(FieldRangeError, match="item count"):
        frame.encode(**head, length=length, items=[])
    if "last" in head:
        with pytest.raises(DecodeError, match="0 items"):
            frame.decode(bytes.fromhex("00 01"))


def test_parameter_error_texts_by_code() -> None:
    # manual §11-6: every code the chip answers in F0, each with what it means
    words = {0x00: "length", 0x01: "a rate is out of range", 0x02: "slower",
             0x03: "not above", 0x04: "no table", 0x05: "≤ 2 pulses", 0x10: "command header",
             0x11: "stage count", 0x15: "31 or more", 0x16: "more data", 0x17: "block header",
             0x18: "rate ≤ 1", 0x19: "pulse count ≤ 1", 0x1A: "total above 0xFFFFF",
             0x20: "rate outside", 0x21: "position trigger", 0x23: "pulse count",
             0x24: "no event registered", 0x25: "length byte", 0x26: "range of 0",
             0x27: "range of 0"}
    assert sorted(F.PARAM_ERRORS) == sorted(words)
    for code, word in words.items():
        assert word in F.PARAM_ERRORS[code], code
    prefixes = {0x20: "move", 0x21: "override", 0x23: "move", 0x24: "event read",
                0x25: "event setting", 0x26: "in-position setting", 0x27: "encoder setting"}
    for code, text in F.PARAM_ERRORS.items():
        prefix = "init" if code < 0x10 else "free curve" if code < 0x20 else prefixes[code]
        assert text.startswith(prefix + ": "), code
    # 「パルスレートのデータが範囲外です」: 01 is the init's rates only, never a pulse count
    assert "pulse" not in F.PARAM_ERRORS[0x01]


def test_a_length_byte_above_the_limit_names_byte_1() -> None:
    with pytest.raises(DecodeError, match="above the limit 0x1E") as e:
        F.check_length_byte(bytes([0, 31]) + bytes(31), 3)
    assert (e.value.block, e.value.byte) == (3, 1)
    assert F.check_length_byte(bytes([0, 30]) + bytes(30), 3) == 30


# --- limits at their exact boundary, both sides (found by tools/mutation.py) --------------
def test_mode_bits_name_the_le_bit() -> None:
    # bit 4 is LE: an LE=1 init read as LE=0 names it; bit 5 is simply never set
    with pytest.raises(DecodeError, match=r"mode\.le is 1, expected 0"):
        F.INIT_COMMON.decode(bytes.fromhex("03 09 00 10 00 00 00 00 00 00 00"))
    with pytest.raises(DecodeError, match="unexpected bits set: 0x20"):
        F.INIT_COMMON.decode(bytes.fromhex("03 09 00 20 00 00 00 00 00 00 00"))
    with pytest.raises(DecodeError, match=r"mode\.le is 0, expected 1"):
        F.INIT_SEPARATE.decode(bytes.fromhex("03 0e 00 00" + " 00" * 12))


def test_free_curve_stage_counts_start_at_one() -> None:
    assert F.FC_COMMAND_COMMON.encode(clk=0, accel_stages=1).hex(" ") == "02 03 01 00 01"
    assert F.FC_COMMAND_SEPARATE.encode(clk=0, accel_stages=1, decel_stages=1).hex(" ") == \
        "02 04 01 10 01 01"
    for stages in ({"accel_stages": 0, "decel_stages": 1}, {"accel_stages": 1, "decel_stages": 0}):
        with pytest.raises(FieldRangeError) as e:
            F.FC_COMMAND_SEPARATE.encode(clk=0, **stages)
        assert (e.value.value, e.value.lo) == (0, 1)


def test_state_error_fields_at_their_limits() -> None:
    # status 0..2 and the six state bits (RUN ALM FIX ACC NOR INI): 0x3F is the most
    assert F.STATE_ERROR.decode(bytes.fromhex("03 04 f1 02 3f 00")) == {
        "status": 2, "state": 0x3F, "command": 0}
    with pytest.raises(DecodeError, match="status"):
        F.STATE_ERROR.decode(bytes.fromhex("03 04 f1 03 3f 00"))
    with pytest.raises(DecodeError, match="state"):
        F.STATE_ERROR.decode(bytes.fromhex("03 04 f1 02 40 00"))


@pytest.mark.parametrize("frame", [F.READ_RATES, F.READ_ACCEL, F.READ_DECEL],
                         ids=lambda f: f.name)
def test_a_read_block_length_covers_the_kind_byte_and_one_item(frame: Frame) -> None:
    size = frame.fields[-1].item.size  # type: ignore[union-attr]
    with pytest.raises(FieldRangeError) as e:
        frame.encode(next=0, length=size, items=[1])
    assert (e.value.value, e.value.lo, e.value.hi) == (size, 1 + size, F.MAX_READ_LENGTH)
    assert frame.encode(next=0, length=1 + size, items=[1])[1] == 1 + size
