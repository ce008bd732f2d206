"""PPMC-312 upload codec: free curve, init, move, table read, bus writes."""

from __future__ import annotations

import re

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from profiles.errors import (
    DecodeError,
    FieldRangeError,
    FormatError,
    StepRampError,
    UnsupportedError,
)
from profiles.ppmc312 import ascii as serial
from profiles.ppmc312.clock import INTERNAL_HZ, Clock
from profiles.ppmc312.table import FreeCurveTable, InitTable
from profiles.ppmc312.upload import (
    bus_writes,
    decode_free_curve,
    decode_init,
    decode_move,
    decode_table_read,
    decode_upload,
    encode_free_curve,
    encode_init,
    encode_move,
    encode_table,
    encode_table_read_response,
)

SETTINGS = settings(max_examples=150, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


clocks = st.one_of(
    st.sampled_from(list(INTERNAL_HZ)).map(Clock.internal),
    st.builds(Clock.extck, st.integers(1, 20_000_000).map(float),
              st.sampled_from(["rising", "falling"])),
)


@st.composite
def free_curves(draw: st.DrawFn, lo: int = 2, hi: int = 127) -> FreeCurveTable:
    """Any table the wire carries: 2..127 stages, LE 0/1 with unequal counts, any values."""
    clock = draw(clocks)
    n_acc = draw(st.integers(lo, hi))
    pulses = st.integers(0, 0xFFFFFF)
    accel = draw(st.lists(pulses, min_size=n_acc, max_size=n_acc))
    decel = None
    if draw(st.booleans()):
        n_dec = draw(st.integers(lo, hi))
        decel = draw(st.lists(pulses, min_size=n_dec, max_size=n_dec))
    n_rates = max(n_acc, len(decel or ()))
    rates = draw(st.lists(st.integers(0, 0xFFFF), min_size=n_rates, max_size=n_rates))
    return FreeCurveTable(clock, tuple(rates), tuple(accel),
                          None if decel is None else tuple(decel))


@st.composite
def init_tables(draw: st.DrawFn, separate: bool | None = None) -> InitTable:
    clock = draw(clocks)
    le = draw(st.booleans()) if separate is None else separate
    rate, pulses = st.integers(0, 0xFFFF), st.integers(0, 0xFFFFFF)
    return InitTable(clock, draw(st.sampled_from(["linear", "s_curve"])), draw(rate),
                     draw(rate), draw(pulses), draw(rate) if le else None,
                     draw(pulses) if le else None)


def _hz(table: FreeCurveTable | InitTable) -> float | None:
    return table.clock.hz if table.clock.external else None


def _sections(table: FreeCurveTable) -> list[tuple[int, int]]:
    """(entry count, entry size) per section, computed from the table itself."""
    out = [(len(table.rates), 2), (len(table.accel_pulses), 3)]
    if table.separate:
        out.append((len(table.decel), 3))
    return out


# --- free curve ---------------------------------------------------------------------
@SETTINGS
@given(free_curves(), st.integers(3, 30))
def test_free_curve_round_trip(table: FreeCurveTable, max_data: int) -> None:
    blocks = encode_free_curve(table, max_data=max_data)
    assert decode_free_curve(blocks, extck_hz=_hz(table)) == table


@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
@SETTINGS
@given(free_curves(), st.integers(3, 30))
def test_free_curve_blocks_obey_the_bus_rules(table: FreeCurveTable, max_data: int) -> None:
    blocks = encode_free_curve(table, max_data=max_data)
    command = blocks[0]
    assert command[0] == 0x02 and command[2] == 0x01
    assert command[1] == len(command) - 2 == (4 if table.separate else 3)
    assert command[3] == (0x10 if table.separate else 0) | table.clock.code
    assert command[4] == len(table.accel_pulses)
    # Walk the sections independently: each block's data lies in one section
    # and holds whole entries; headers are 00 … 00 01.
    sections = _sections(table)
    section, used = 0, 0
    for k, block in enumerate(blocks[1:], start=1):
        assert len(block) <= 32
        assert block[0] == (0x01 if k == len(blocks) - 1 else 0x00)
        assert block[1] == len(block) - 2 <= max_data
        count, size = sections[section]
        assert (len(block) - 2) % size == 0
        used += (len(block) - 2) // size
        assert used <= count
        if used == count:
            section, used = section + 1, 0
    assert section == len(sections)


def test_free_curve_layout_by_hand() -> None:
    # 4 rates (2 B), accel 3 × 3 B, decel 4 × 3 B; 7 data bytes a block → 3 rates,
    # then 1; 2 accel counts, then 1; 2 decel, then 2.
    table = FreeCurveTable(Clock.internal("1MHz"), (100, 200, 300, 400), (10, 20, 30),
                           (5, 6, 7, 8))
    assert [b.hex(" ") for b in encode_free_curve(table, max_data=7)] == [
        "02 04 01 11 03 04",
        "00 06 00 64 00 c8 01 2c", "00 02 01 90",
        "00 06 00 00 0a 00 00 14", "00 03 00 00 1e",
        "00 06 00 00 05 00 00 06", "01 06 00 00 07 00 00 08"]


@pytest.mark.parametrize("max_data", [2, 31, 0, -1, True, 3.0])
def test_max_data_outside_3_to_30_is_refused(max_data: object) -> None:
    table = FreeCurveTable(Clock.internal("8MHz"), (10, 20), (5, 5))
    with pytest.raises(FieldRangeError, match="max_data"):
        encode_free_curve(table, max_data=max_data)  # type: ignore[arg-type]


def test_free_curve_extck_needs_its_frequency() -> None:
    table = FreeCurveTable(Clock.extck(4e6), (10, 20), (5, 5))
    blocks = encode_free_curve(table)
    with pytest.raises(FormatError, match="extck"):
        decode_free_curve(blocks)
    assert decode_free_curve(blocks, extck_hz=4e6) == table


GOOD = [bytes.fromhex("02 03 01 00 02"), bytes.fromhex("00 04 00 0a 00 14"),
        bytes.fromhex("01 06 00 00 05 00 00 06")]


@pytest.mark.parametrize(("blocks", "block", "byte", "words"), [
    ([], None, None, "empty upload"),
    ([bytes.fromhex("03 03 01 00 02"), *GOOD[1:]], 0, 0, "header"),
    ([bytes.fromhex("02 05 01 00 02"), *GOOD[1:]], 0, 1, "length byte"),
    ([bytes.fromhex("02 03 01 20 02"), *GOOD[1:]], 0, 3, "unexpected bits"),
    ([GOOD[0], bytes.fromhex("04 04 00 0a 00 14"), GOOD[2]], 1, 0, "header"),
    ([GOOD[0], bytes.fromhex("00 05 00 0a 00 14"), GOOD[2]], 1, 1, "length byte"),
    ([GOOD[0], bytes.fromhex("00 03 00 0a 00"), bytes.fromhex("00 01 14"), GOOD[2]],
     1, 4, "split"),
    ([GOOD[0], bytes.fromhex("00 06 00 0a 00 14 00 1e"), GOOD[2]], 1, 6, "only 2 more"),
    ([GOOD[0], bytes.fromhex("00 02 00 0a"), bytes.fromhex("01 02 00 14"), GOOD[2]],
     2, 0, "still missing"),
    ([GOOD[0], GOOD[1], bytes.fromhex("00 06 00 00 05 00 00 06")], 2, 0, "expected 01"),
    (GOOD[:2], 2, 0, "missing"),
    ([*GOOD, bytes.fromhex("01 02 00 0a")], 3, 0, "after the last block"),
    ([GOOD[0], bytes.fromhex("00 00"), *GOOD[1:]], 1, 1, "no data"),
    ([GOOD[0], b"", *GOOD[1:]], 1, 0, "empty"),
    ([b"\x02", *GOOD[1:]], 0, 1, "byte"),
])
def test_free_curve_decode_errors_name_block_and_byte(
        blocks: list[bytes], block: int | None, byte: int | None, words: str) -> None:
    assert decode_free_curve(GOOD) == FreeCurveTable(Clock.internal("8MHz"), (10, 20), (5, 6))
    with pytest.raises(DecodeError, match=words) as err:
        decode_free_curve(blocks)
    assert (err.value.block, err.value.byte) == (block, byte)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("blocks", [b"\x02\x03\x01\x00\x02", "02 03", None, [1, 2]])
def test_free_curve_decode_refuses_non_block_lists(blocks: object) -> None:
    with pytest.raises(DecodeError):
        decode_free_curve(blocks)


@st.composite
def mutated_uploads(draw: st.DrawFn) -> list[bytes]:
    table = draw(free_curves(hi=20))
    blocks = [bytearray(b) for b in encode_free_curve(table, max_data=draw(st.integers(3, 30)))]
    how = draw(st.sampled_from(["flip_header", "truncate", "length", "drop_last", "junk",
                                "byte", "swap"]))
    k = draw(st.integers(0, len(blocks) - 1))
    if how == "flip_header":
        blocks[k][0] ^= draw(st.sampled_from([0x01, 0x02, 0x04, 0x80]))
    elif how == "truncate":
        blocks[k] = blocks[k][:draw(st.integers(0, len(blocks[k]) - 1))]
    elif how == "length":
        blocks[k][1] = (blocks[k][1] + draw(st.integers(1, 255))) % 256
    elif how == "drop_last":
        blocks.pop()
    elif how == "junk":
        blocks.append(bytearray(draw(st.binary(min_size=0, max_size=40))))
    elif how == "byte":
        i = draw(st.integers(0, min(3, len(blocks[k]) - 1)))
        blocks[k][i] ^= draw(st.integers(1, 255))
    else:
        j = draw(st.integers(0, len(blocks) - 1))
        blocks[j], blocks[k] = blocks[k], blocks[j]  # equal blocks: the upload is unchanged
    return [bytes(b) for b in blocks]


@SETTINGS
@given(mutated_uploads())
@example([bytes.fromhex("020401100f02"), bytes([0, 18]) + bytes(18), bytes([0, 12]) + bytes(12),
          bytes([0, 9]) + bytes(9), bytes([0, 18]) + bytes(18), bytes([0, 18]) + bytes(18),
          bytes([1, 6]) + bytes(6)])  # two blocks of one section swapped: a valid repacking
def test_mutated_uploads_give_a_decode_error_never_a_crash(blocks: list[bytes]) -> None:
    try:
        table = decode_free_curve(blocks, extck_hz=1e6)
    except DecodeError as e:
        assert "\n" not in str(e)
        return
    # A few mutations stay valid (a data byte, or swapping two all-equal data blocks of
    # one section, which repacks it): the chip takes any packing that keeps entries
    # whole, so the command block and the data carried, in order, must be exactly the
    # table's own encoding.
    def carried(bs: list[bytes]) -> tuple[bytes, bytes]:
        return bs[0], b"".join(b[2:] for b in bs[1:])

    assert carried(encode_free_curve(table)) == carried(blocks)
    assert [b[0] for b in blocks[1:]] == [0] * (len(blocks) - 2) + [1]


@SETTINGS
@given(st.lists(st.binary(max_size=34), max_size=6))
def test_random_bytes_never_crash_the_decoders(blocks: list[bytes]) -> None:
    for decode in (decode_free_curve, decode_upload):
        try:
            decode(blocks, extck_hz=1e6)
        except DecodeError:
            pass


# --- init ---------------------------------------------------------------------------
@SETTINGS
@given(init_tables())
def test_init_round_trip(table: InitTable) -> None:
    block = encode_init(table)
    assert len(block) == 2 + block[1] == (16 if table.separate else 11)
    assert decode_init(block, extck_hz=_hz(table)) == table
    assert decode_upload([block], extck_hz=_hz(table)) == table
    assert encode_table(table) == [block]


@SETTINGS
@given(init_tables(separate=False), st.integers(0, 15))
def test_init_ascii_round_trip(table: InitTable, address: int) -> None:
    if table.clock.code == 7:
        with pytest.raises(UnsupportedError, match="falling"):
            encode_table(table, to="ascii", address=address)
        return
    [frame] = encode_table(table, to="ascii", address=address)
    assert frame[0] == 0x90 + address
    assert decode_upload([frame], extck_hz=_hz(table)) == table


def test_init_manual_example_bytes() -> None:
    # §13-4 example values (CLK 8 MHz, linear, start 1122, high 5566, pulses ABCDEF)
    # in the parallel §7-1 layout.
    table = InitTable(Clock.internal("8MHz"), "linear", 0x1122, 0x5566, 0xABCDEF)
    assert encode_init(table).hex(" ") == "03 09 00 00 11 22 55 66 ab cd ef"
    separate = InitTable(Clock.internal("62.5kHz"), "s_curve", 0x1000, 0x0100, 0x200,
                         0x2000, 0x300)
    assert encode_init(separate).hex(" ") == "03 0e 00 1c 10 00 20 00 01 00 00 02 00 00 03 00"


def test_init_le1_has_no_serial_form() -> None:
    table = InitTable(Clock.internal("8MHz"), "linear", 0x1000, 0x100, 0x200, 0x1000, 0x200)
    with pytest.raises(UnsupportedError, match="LE=1"):
        encode_table(table, to="ascii")


@pytest.mark.parametrize(("block", "byte"), [
    ("03 0a 00 00 11 22 55 66 ab cd ef", 1),      # length byte neither 09 nor 0E
    ("03 09 00 10 11 22 55 66 ab cd ef", 3),      # LE=1 bit in a 9-byte block
    ("03 09 00 80 11 22 55 66 ab cd ef", 3),      # an x bit set
    ("02 09 00 00 11 22 55 66 ab cd ef", 0),      # header 02
    ("03 09 00 00 11 22 55 66 ab cd", 10),        # one byte short
])
def test_init_decode_errors(block: str, byte: int) -> None:
    with pytest.raises(DecodeError) as err:
        decode_init(bytes.fromhex(block))
    assert err.value.byte == byte


# --- move ---------------------------------------------------------------------------
@SETTINGS
@given(st.integers(1, 0xFFFFFFFF), st.booleans(), st.integers(0, 0xFFFF), st.booleans(),
       st.integers(0, 3))
def test_move_round_trip(pulses: int, ccw: bool, high_rate: int, override: bool,
                         trigger: int) -> None:
    if override and trigger in (0, 2):
        with pytest.raises(FieldRangeError, match="trigger"):
            encode_move(pulses, ccw=ccw, high_rate=high_rate, override=override,
                        trigger=trigger)
        return
    block = encode_move(pulses, ccw=ccw, high_rate=high_rate, override=override,
                        trigger=trigger)
    assert block[:3] == b"\x03\x08\x82" and len(block) == 10
    assert int.from_bytes(block[6:], "big") == pulses
    assert decode_move(block) == {"pulses": pulses, "ccw": ccw, "high_rate": high_rate,
                                  "override": override, "trigger": trigger}


def test_move_layout_and_ranges() -> None:
    assert encode_move(0x12345678, ccw=True).hex(" ") == "03 08 82 40 00 00 12 34 56 78"
    assert encode_move(5, high_rate=0x1234, override=True, trigger=3).hex(" ") == \
        "03 08 82 07 12 34 00 00 00 05"
    for bad in (0, 0x1_0000_0000, -1):
        with pytest.raises(FieldRangeError, match="pulses"):
            encode_move(bad)
    with pytest.raises(FieldRangeError, match="high_rate"):
        encode_move(10, high_rate=0x10000)
    with pytest.raises(DecodeError, match="pulses"):
        decode_move(bytes.fromhex("03 08 82 00 00 00 00 00 00 00"))
    with pytest.raises(DecodeError, match="TRG"):
        decode_move(bytes.fromhex("03 08 82 04 00 00 00 00 00 01"))


# --- encode_table / decode_upload ---------------------------------------------------
def test_free_curve_has_no_serial_form() -> None:
    table = FreeCurveTable(Clock.internal("8MHz"), (10, 20), (5, 5))
    with pytest.raises(StepRampError, match="no serial"):
        encode_table(table, to="ascii")
    with pytest.raises(FormatError, match="to"):
        encode_table(table, to="usb")


@SETTINGS
@given(free_curves(), st.integers(3, 30))
def test_decode_upload_recognises_free_curves(table: FreeCurveTable, max_data: int) -> None:
    blocks = encode_table(table, max_data=max_data)
    assert decode_upload(blocks, extck_hz=_hz(table)) == table


def test_decode_upload_refuses_other_commands() -> None:
    with pytest.raises(DecodeError, match="not a table upload"):
        decode_upload([encode_move(100)])
    init = encode_init(InitTable(Clock.internal("8MHz"), "linear", 0x1000, 0x100, 0x200))
    with pytest.raises(DecodeError, match="one block") as err:
        decode_upload([init, init])
    assert err.value.block == 1
    frame = serial.encode_serial_move(1, 100)
    with pytest.raises(DecodeError, match="block 0"):
        decode_upload([frame])


# --- table read ---------------------------------------------------------------------
@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
@SETTINGS
@given(free_curves())
def test_table_read_round_trip(table: FreeCurveTable) -> None:
    if table.accel_total > 0xFFFFFF or table.decel_total > 0xFFFFFF:
        with pytest.raises(FieldRangeError, match="total"):
            encode_table_read_response(table)
        return
    blocks = encode_table_read_response(table)
    first = blocks[0]
    assert first[:3] == b"\x02\x0a\x41"  # PAL 1, NEXT 0
    assert list(first[3:6]) == [len(table.rates), len(table.accel_pulses),
                                len(table.decel_pulses or ())]
    assert int.from_bytes(first[6:9], "big") == table.accel_total
    assert int.from_bytes(first[9:12], "big") == table.decel_total
    kinds = [b[2] for b in blocks[1:]]
    assert kinds == sorted(kinds)  # one item kind per block, in order 01, 02, 03
    assert [b[0] for b in blocks[1:]] == [0] * (len(blocks) - 2) + [1]
    assert all(b[1] == len(b) - 2 <= 14 for b in blocks[1:])
    assert decode_table_read(blocks, clock=table.clock) == table


def test_table_read_cross_checks_totals_and_next() -> None:
    table = FreeCurveTable(Clock.internal("8MHz"), (10, 20, 30), (5, 6, 7))
    blocks = encode_table_read_response(table)
    bad_total = bytearray(blocks[0])
    bad_total[8] += 1
    with pytest.raises(DecodeError, match="accel total") as err:
        decode_table_read([bytes(bad_total), *blocks[1:]], clock=table.clock)
    assert (err.value.block, err.value.byte) == (0, 6)
    no_next = bytearray(blocks[-1])
    no_next[0] = 0
    with pytest.raises(DecodeError, match="NEXT"):
        decode_table_read([*blocks[:-1], bytes(no_next)], clock=table.clock)
    with pytest.raises(DecodeError, match="item kind"):
        decode_table_read([blocks[0], blocks[2], blocks[1]], clock=table.clock)
    with pytest.raises(UnsupportedError):
        encode_table_read_response(InitTable(table.clock, "linear", 0x1000, 0x100, 0x200))


# --- bus writes ---------------------------------------------------------------------
def test_bus_writes_manual_example_order() -> None:
    # §5-6: accel move CCW 0x12345678 in the manual's old layout (length 06).
    writes = bus_writes(bytes.fromhex("03 06 82 40 12 34 56 78"))
    assert writes[:2] == [("WCR", 0x20), ("WAR", 0x20 - 8)]
    assert [v for r, v in writes[2:] if r == "DWR"] == [0x78, 0x56, 0x34, 0x12, 0x40, 0x82,
                                                         0x06, 0x03]
    assert len(writes) == 10


@SETTINGS
@given(st.binary(min_size=1, max_size=32).filter(lambda b: b[0] < 0x80))
def test_bus_writes_reverse_any_block(block: bytes) -> None:
    writes = bus_writes(block)
    assert writes[1] == ("WAR", 0x20 - len(block))
    assert bytes(v for _r, v in writes[2:]) == block[::-1]


def test_bus_writes_refuse_oversize_blocks() -> None:
    with pytest.raises(FieldRangeError, match="block size"):
        bus_writes(bytes(33))
    with pytest.raises(FieldRangeError, match="block size"):
        bus_writes(b"")


C8, C1 = Clock.internal("8MHz"), Clock.internal("1MHz")


GOLDEN_FREE_CURVES: list[tuple[str, FreeCurveTable, int, list[str]]] = [
    ("LE=0 8MHz", FreeCurveTable(C8, (400, 500), (100, 200)), 30,
     ["02 03 01 00 02", "00 04 01 90 01 f4", "01 06 00 00 64 00 00 c8"]),
    ("LE=1 1MHz", FreeCurveTable(C1, (400, 500, 600), (100, 200, 300), (10, 20)), 30,
     ["02 04 01 11 03 02", "00 06 01 90 01 f4 02 58", "00 09 00 00 64 00 00 c8 00 01 2c",
      "01 06 00 00 0a 00 00 14"]),
    ("LE=1 decel longer", FreeCurveTable(C1, (400, 500, 600), (7, 8), (1, 2, 3)), 30,
     ["02 04 01 11 02 03", "00 06 01 90 01 f4 02 58", "00 06 00 00 07 00 00 08",
      "01 09 00 00 01 00 00 02 00 00 03"]),
    ("3 data bytes a block", FreeCurveTable(C8, (400, 500), (100, 200)), 3,
     ["02 03 01 00 02", "00 02 01 90", "00 02 01 f4", "00 03 00 00 64", "01 03 00 00 c8"]),
    ("4 data bytes a block", FreeCurveTable(C8, (400, 500, 600), (1, 2, 3)), 4,
     ["02 03 01 00 03", "00 04 01 90 01 f4", "00 02 02 58", "00 03 00 00 01", "00 03 00 00 02",
      "01 03 00 00 03"]),
    ("EXTCK falling", FreeCurveTable(Clock.extck(1e6, "falling"), (2, 3), (2, 2)), 30,
     ["02 03 01 07 02", "00 04 00 02 00 03", "01 06 00 00 02 00 00 02"]),
]


@pytest.mark.parametrize("table, max_data, blocks", [c[1:] for c in GOLDEN_FREE_CURVES],
                         ids=[c[0] for c in GOLDEN_FREE_CURVES])
def test_free_curve_golden_bytes(table: FreeCurveTable, max_data: int, blocks: list[str]) -> None:
    assert [b.hex(" ") for b in encode_free_curve(table, max_data=max_data)] == blocks
    wire = [bytes.fromhex(b) for b in blocks]
    assert decode_free_curve(wire, extck_hz=1e6) == table
    assert decode_upload(wire, extck_hz=1e6) == table


def test_full_30_byte_parameter_block_is_32_bytes_on_the_bus() -> None:
    table = FreeCurveTable(C8, tuple(range(400, 415)), (100,) * 15)
    blocks = encode_free_curve(table, max_data=30)
    assert [len(b) for b in blocks] == [5, 32, 32, 17]
    assert blocks[1][:4].hex(" ") == "00 1e 01 90" and blocks[2][:2].hex(" ") == "00 1e"
    assert blocks[3][:2].hex(" ") == "01 0f"
    assert decode_free_curve(blocks) == table
    writes = bus_writes(blocks[1])  # a full block: WAR 0
    assert writes[:2] == [("WCR", 0x20), ("WAR", 0x00)] and len(writes) == 34
    assert bus_writes(b"\x03")[:2] == [("WCR", 0x20), ("WAR", 0x1F)]  # the smallest block
    with pytest.raises(FieldRangeError, match="block size"):
        bus_writes(b"")
    with pytest.raises(FieldRangeError, match="block size"):
        bus_writes(bytes(33))


GOLDEN_INIT: list[tuple[str, InitTable, str]] = [
    ("LE=0 linear 8MHz", InitTable(C8, "linear", 1000, 100, 0x1000),
     "03 09 00 00 03 e8 00 64 00 10 00"),
    ("LE=0 s-curve 1MHz", InitTable(C1, "s_curve", 0xFFFF, 2, 0xFFFFF),
     "03 09 00 09 ff ff 00 02 0f ff ff"),
    ("LE=1 s-curve 15.625kHz", InitTable(Clock.internal("15.625kHz"), "s_curve", 0x1234, 0x0056,
                                         0x000789, 0x0abc, 0x0def0),
     "03 0e 00 1d 12 34 0a bc 00 56 00 07 89 00 de f0"),
]


@pytest.mark.parametrize("table, hexed", [c[1:] for c in GOLDEN_INIT],
                         ids=[c[0] for c in GOLDEN_INIT])
def test_init_golden_bytes(table: InitTable, hexed: str) -> None:
    assert encode_init(table).hex(" ") == hexed
    assert decode_init(bytes.fromhex(hexed)) == table
    assert decode_upload([bytes.fromhex(hexed)]) == table


@pytest.mark.parametrize("kw, hexed", [
    (dict(pulses=1), "03 08 82 00 00 00 00 00 00 01"),
    (dict(pulses=0x01020304, ccw=True, high_rate=0x0506), "03 08 82 40 05 06 01 02 03 04"),
    (dict(pulses=5, override=True, trigger=1), "03 08 82 05 00 00 00 00 00 05"),
    (dict(pulses=5, ccw=True, override=True, trigger=3), "03 08 82 47 00 00 00 00 00 05"),
])
def test_move_golden_bytes(kw: dict[str, object], hexed: str) -> None:
    assert encode_move(**kw).hex(" ") == hexed  # type: ignore[arg-type]
    back = decode_move(bytes.fromhex(hexed))
    assert back["pulses"] == kw["pulses"] and back["ccw"] == kw.get("ccw", False)


GOLDEN_TABLE_READ: list[tuple[str, FreeCurveTable, list[str]]] = [
    ("LE=0", FreeCurveTable(C8, (400, 500), (100, 200)),
     ["02 0a 41 02 02 00 00 01 2c 00 01 2c", "00 05 01 01 90 01 f4",
      "01 07 02 00 00 64 00 00 c8"]),
    ("LE=1, 7 rates", FreeCurveTable(C8, tuple(range(1, 8)), (1, 2), tuple(range(10, 17))),
     ["02 0a 41 07 02 07 00 00 03 00 00 5b", "00 0d 01 00 01 00 02 00 03 00 04 00 05 00 06",
      "00 03 01 00 07", "00 07 02 00 00 01 00 00 02",
      "00 0d 03 00 00 0a 00 00 0b 00 00 0c 00 00 0d", "01 0a 03 00 00 0e 00 00 0f 00 00 10"]),
]


@pytest.mark.parametrize("table, blocks", [c[1:] for c in GOLDEN_TABLE_READ],
                         ids=[c[0] for c in GOLDEN_TABLE_READ])
def test_table_read_golden_bytes(table: FreeCurveTable, blocks: list[str]) -> None:
    assert [b.hex(" ") for b in encode_table_read_response(table)] == blocks
    assert decode_table_read([bytes.fromhex(b) for b in blocks], clock=table.clock) == table


def test_an_ascii_frame_followed_by_blocks_is_refused() -> None:
    frame = serial.encode_serial_init(InitTable(C8, "linear", 1000, 100, 0x1000), 0)
    assert decode_upload([frame]).kind == "init"
    with pytest.raises(DecodeError, match="one frame; more follow") as e:
        decode_upload([frame, b"\x00\x02\x01\x90"])
    assert (e.value.block, e.value.byte) == (1, 0)


@pytest.mark.parametrize("block, says, byte", [
    ("02", "the command block is 1 byte(s)", 1),
    ("02 03", "is 2 bytes, expected 5", 2),   # a length byte: judged by the frame
    ("02 05", "length byte 0x05", 1),
    ("02 04 01 10 02", "is 5 bytes, expected 6", 5),
])
def test_short_command_blocks(block: str, says: str, byte: int) -> None:
    with pytest.raises(DecodeError, match=re.escape(says)) as e:
        decode_free_curve([bytes.fromhex(block)])
    assert (e.value.block, e.value.byte) == (0, byte)


# --- every decode error names its block and byte (table read, upload dispatch) ----------
def _read(blocks: list[str]) -> list[bytes]:
    return [bytes.fromhex(b) for b in blocks]


READ_LE1 = GOLDEN_TABLE_READ[1][2]


@pytest.mark.parametrize("blocks, says, where", [
    ([READ_LE1[0].replace("02 07 00 00 03", "00 07 00 00 03"), *READ_LE1[1:]],
     "accel stage count 0", (0, 4)),
    ([READ_LE1[0].replace("00 00 03 00 00 5b", "00 00 04 00 00 5b"), *READ_LE1[1:]],
     "accel total 4 but the stages sum to 3", (0, 6)),
    ([READ_LE1[0].replace("00 00 03 00 00 5b", "00 00 03 00 00 5c"), *READ_LE1[1:]],
     "decel total 92 but the stages sum to 91", (0, 9)),
    ([*READ_LE1, "01 03 01 00 07"], "data after the last block", (6, 0)),
    ([READ_LE1[0], "00 01 07", *READ_LE1[2:]], "item kind 0x07, expected 0x01", (1, 2)),
    ([READ_LE1[0], "00 05 07 00 01 00 02", *READ_LE1[2:]], "item kind 0x07, expected 0x01",
     (1, 2)),
    ([READ_LE1[0], READ_LE1[1], "00 05 01 00 07 00 08", *READ_LE1[3:]],
     "2 rate entries, only 1 more are due", (2, 3)),
])
def test_table_read_errors_name_block_and_byte(blocks: list[str], says: str,
                                              where: tuple[int, int]) -> None:
    with pytest.raises(DecodeError, match=re.escape(says)) as e:
        decode_table_read(_read(blocks), clock=C8)
    assert (e.value.block, e.value.byte) == where


@pytest.mark.parametrize("blocks, says, where", [
    (["02 03"], "no command code", (0, 2)),
    (["03 01 41"], "is not a table upload", (0, 0)),
    ([""], "empty block", (0, 0)),
])
def test_upload_dispatch_errors_name_block_and_byte(blocks: list[str], says: str,
                                                    where: tuple[int, int]) -> None:
    with pytest.raises(DecodeError, match=re.escape(says)) as e:
        decode_upload(_read(blocks))
    assert (e.value.block, e.value.byte) == where


def test_encode_table_ascii_defaults_to_address_0() -> None:
    table = InitTable(C8, "linear", 1000, 100, 0x1000)
    assert encode_table(table, to="ascii") == [serial.encode_serial_init(table, 0)]


def _outcome(fn: object, *args: object) -> object:
    try:
        return fn(*args)  # type: ignore[operator]
    except StepRampError as e:
        return (type(e).__name__, str(e))


@SETTINGS
@given(mutated_uploads())
def test_bulk_decode_equals_the_block_by_block_walk(blocks: list[bytes]) -> None:
    """The bulk path (sections unpacked at once) and the block-by-block walk it falls
    back to agree on every upload: the same table or the same error."""
    from unittest import mock

    from profiles.ppmc312 import upload

    fast = _outcome(decode_free_curve, blocks)
    with mock.patch.object(upload, "_decode_sections", return_value=None):
        slow = _outcome(decode_free_curve, blocks)
    assert fast == slow


@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
@SETTINGS
@given(free_curves(), st.integers(3, 30))
def test_bulk_encode_equals_the_block_by_block_path(table: FreeCurveTable, max_data: int
                                                    ) -> None:
    from unittest import mock

    from profiles.ppmc312 import upload

    fast = encode_free_curve(table, max_data=max_data)
    with mock.patch.object(upload, "_encode_sections", return_value=None):
        assert encode_free_curve(table, max_data=max_data) == fast


@pytest.mark.parametrize("table, max_data, blocks", [c[1:] for c in GOLDEN_FREE_CURVES],
                         ids=[c[0] for c in GOLDEN_FREE_CURVES])
def test_well_formed_uploads_take_the_bulk_path(table: FreeCurveTable, max_data: int,
                                                blocks: list[str]) -> None:
    """The bulk paths are the ones that run on every well-formed upload: the block-by-block
    walk (which checks each block's header with `_param_header`) is only for errors."""
    from unittest import mock

    from profiles.ppmc312 import upload

    fast = upload._encode_sections(table, max_data)
    assert fast is not None and [b.hex(" ") for b in fast] == blocks[1:]
    wire = [bytes.fromhex(b) for b in blocks]
    with mock.patch.object(upload, "_param_header", side_effect=AssertionError("slow path")):
        assert decode_free_curve(wire, extck_hz=1e6) == table


# --- where each error points, at the boundaries (found by tools/mutation.py) ---------------
@pytest.mark.parametrize(("block", "says", "byte"), [
    ("03", "the init block is 1 byte(s)", 1),
    ("03 09", "init (LE=0) is 2 bytes, expected 11", 2),  # the frame's own check
])
def test_short_init_blocks(block: str, says: str, byte: int | None) -> None:
    with pytest.raises(DecodeError, match=re.escape(says)) as err:
        decode_init(bytes.fromhex(block))
    if byte is not None:
        assert err.value.byte == byte


def test_override_trigger_error_points_at_the_mode_byte() -> None:
    with pytest.raises(DecodeError, match="TRG 10 with override") as err:
        decode_move(bytes.fromhex("03 08 82 06 00 00 00 00 00 01"))  # OV=1, TRG=10
    assert err.value.byte == 3


@pytest.mark.parametrize("blocks, says, where", [
    (["02 09 00 00 11 22 55 66 ab cd ef"], "header 02 with command code 00", (0, 0)),
    (["03 03 01 00 02"], "header 03 with command code 01", (0, 0)),
    (["03 09 00 00 11 22 55 66 ab cd ef", "00 02 00 01"], "an init upload is one block", (1, 0)),
    (["03 09 00 10 11 22 55 66 ab cd ef"], "mode.le is 1, expected 0", (0, 3)),
])
def test_upload_dispatch_by_header_and_code(blocks: list[str], says: str,
                                            where: tuple[int, int]) -> None:
    with pytest.raises(DecodeError) as e:
        decode_upload(_read(blocks))
    assert says in str(e.value) and (e.value.block, e.value.byte) == where
    assert str(e.value) == f"block {where[0]}, byte {where[1]}: " + str(e.value).split(": ", 1)[1]
    assert str(e.value).count("byte") == 1  # the init decoder's location is not repeated


READ_LE0 = GOLDEN_TABLE_READ[0][2]


@pytest.mark.parametrize("blocks, says, where", [
    (["02 0a 41 02 02 00 00 01 2c 00 01"], "is 11 bytes, expected 12", (0, 11)),
    ([READ_LE0[0].replace("41 02 02", "41 03 02"), *READ_LE0[1:]],
     "3 rate stages, expected 2", (0, 3)),
    ([READ_LE0[0], READ_LE0[1], "00 07 02 00 00 64 00 00"], "carries 6", (2, 1)),
    ([READ_LE0[0], READ_LE0[1], "00 00"], "is 2 bytes, needs at least 3", (2, 2)),
    ([READ_LE0[0], READ_LE0[1].replace("00 05", "01 05"), READ_LE0[2]],
     "NEXT bit set before the last block", (1, 0)),
    ([READ_LE0[0], READ_LE0[1], READ_LE0[2].replace("01 07", "00 07")],
     "NEXT bit missing on the last block", (2, 0)),
    (READ_LE0[:2], "the answer ends with accel entries missing", (2, 0)),
])
def test_table_read_errors_at_the_edges(blocks: list[str], says: str,
                                        where: tuple[int, int | None] | None) -> None:
    with pytest.raises(DecodeError, match=re.escape(says)) as e:
        decode_table_read(_read(blocks), clock=C8)
    if where is not None:
        assert e.value.block == where[0]
        if where[1] is not None:
            assert e.value.byte == where[1]


def test_bus_writes_range_names_1_to_32_bytes() -> None:
    with pytest.raises(FieldRangeError) as e:
        bus_writes(b"")
    assert (e.value.lo, e.value.hi) == (1, 32)
    assert bus_writes(b"\x05") == [("WCR", 0x20), ("WAR", 0x1F), ("DWR", 5)]


@pytest.mark.parametrize("table, max_data, blocks", [c[1:] for c in GOLDEN_FREE_CURVES],
                         ids=[c[0] for c in GOLDEN_FREE_CURVES])
def test_the_block_by_block_walk_decodes_every_golden_upload(
        table: FreeCurveTable, max_data: int, blocks: list[str]) -> None:
    """The walk the bulk path falls back to reads a well-formed upload to the same table
    (LE=0 without a decel list, LE=1 with one)."""
    from unittest import mock

    from profiles.ppmc312 import upload

    with mock.patch.object(upload, "_decode_sections", return_value=None):
        assert decode_free_curve([bytes.fromhex(b) for b in blocks], extck_hz=1e6) == table


def test_encode_free_curve_refuses_an_init_table() -> None:
    # An init table has no stage lists: encoding it as a free curve would send the chip a
    # command block with no parameter blocks. Refused, naming what was given.
    init = InitTable(Clock.internal("8MHz"), "linear", 0x1122, 0x5566, 0xABCDEF)
    with pytest.raises(FormatError, match="needs a free-curve table, got InitTable"):
        encode_free_curve(init)  # type: ignore[arg-type]


# --- REV 1.3 block size (manual §5-5: code and parameters [0]–[12]) -------------------
def test_default_blocks_are_rev13_sized_by_hand() -> None:
    # 15 rates: 7 + 7 + 1 (14, 14, 2 bytes); 15 accel counts: 4 + 4 + 4 + 3 (12 … 9 bytes).
    table = FreeCurveTable(C8, tuple(range(400, 415)), (100,) * 15)
    blocks = encode_free_curve(table)
    assert [len(b) - 2 for b in blocks[1:]] == [14, 14, 2, 12, 12, 12, 9]
    assert [b[0] for b in blocks[1:]] == [0, 0, 0, 0, 0, 0, 1]
    assert encode_table(table) == blocks


@SETTINGS
@given(free_curves())
def test_default_blocks_never_pass_14_data_bytes(table: FreeCurveTable) -> None:
    blocks = encode_free_curve(table)
    assert all(len(b) - 2 <= 14 for b in blocks)
    # as full as whole entries allow: 7 rates or 4 pulse counts, a section's last may be short
    sizes = [len(b) - 2 for b in blocks[1:]]
    assert max(sizes) == (14 if len(table.rates) >= 7 else 12 if len(table.accel_pulses) >= 4
                          else max(sizes))
    assert decode_free_curve(blocks, extck_hz=_hz(table)) == table


def test_export_default_is_the_rev13_size() -> None:
    import argparse

    from profiles.ppmc312.frames import REV13_BLOCK_DATA
    from verify.cli import export

    parser = argparse.ArgumentParser()
    export.add_subparser(parser.add_subparsers())
    args = parser.parse_args(["export", "t.json"])
    assert args.max_block_data == REV13_BLOCK_DATA == 14
