"""The declarative frame layer every codec is built on."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from profiles.errors import DecodeError, FieldRangeError
from profiles.fields import F32, Array, Bit, Bits, Checksum, Const, Frame, Reserved, SInt, UInt


def _sum8(data: bytes) -> int:
    return sum(data) & 0xFF


FRAME = Frame("demo", (
    Const("header", b"\x03"),
    Bits("mode", 1, (Bit("le", 4), Bit("fo", 3), Bit("clk", 0, 3))),
    UInt("rate", 2, lo=2, hi=0xFFEF),
    SInt("pos", 4, "little"),
    Reserved(1),
    F32("amps"),
    Checksum("sum", 1, _sum8),
))


@given(le=st.integers(0, 1), fo=st.integers(0, 1), clk=st.integers(0, 7),
       rate=st.integers(2, 0xFFEF), pos=st.integers(-(2**31), 2**31 - 1),
       amps=st.floats(-1e6, 1e6, width=32))
def test_round_trip(le: int, fo: int, clk: int, rate: int, pos: int, amps: float) -> None:
    values = {"le": le, "fo": fo, "clk": clk, "rate": rate, "pos": pos, "amps": amps}
    data = FRAME.encode(values)
    assert len(data) == FRAME.size == 1 + 1 + 2 + 4 + 1 + 4 + 1
    assert FRAME.decode(data) == values


def test_layout_is_byte_exact() -> None:
    data = FRAME.encode(le=1, fo=0, clk=5, rate=0x1234, pos=-2, amps=1.0)
    assert data[:4] == bytes([0x03, 0x15, 0x12, 0x34])
    assert data[4:8] == b"\xfe\xff\xff\xff"
    assert data[9:13] == b"\x00\x00\x80\x3f"
    assert data[13] == sum(data[:13]) & 0xFF


def test_value_out_of_field_names_field_value_and_range() -> None:
    with pytest.raises(FieldRangeError) as e:
        FRAME.encode(le=0, fo=0, clk=0, rate=1, pos=0, amps=0.0)
    assert "demo.rate" in str(e.value) and "2..65519" in str(e.value)
    with pytest.raises(FieldRangeError, match=r"demo.mode.clk"):
        FRAME.encode(le=0, fo=0, clk=8, rate=2, pos=0, amps=0.0)


def test_decode_errors_name_the_byte() -> None:
    good = FRAME.encode(le=0, fo=0, clk=0, rate=2, pos=0, amps=0.0)
    with pytest.raises(DecodeError, match="byte 0"):
        FRAME.decode(b"\x02" + good[1:])
    bad_sum = good[:-1] + bytes([(good[-1] + 1) & 0xFF])
    with pytest.raises(DecodeError, match="byte 13") as e:
        FRAME.decode(bad_sum, block=4)
    assert "block 4" in str(e.value) and e.value.block == 4
    with pytest.raises(DecodeError, match="expected 14"):
        FRAME.decode(good[:-2])
    with pytest.raises(DecodeError, match="unexpected bits"):
        FRAME.decode(good[:1] + b"\x40" + good[2:])


ARRAY = Frame("items", (UInt("header", 1, hi=1), UInt("length", 1), Array("rates", UInt("rate", 2),
                                                                            max_items=15)))


@given(st.lists(st.integers(0, 0xFFFF), max_size=15))
def test_array_round_trip(rates: list[int]) -> None:
    data = ARRAY.encode(header=1, length=2 * len(rates), rates=rates)
    assert ARRAY.decode(data) == {"header": 1, "length": 2 * len(rates), "rates": rates}


def test_array_refuses_partial_items_and_too_many() -> None:
    with pytest.raises(DecodeError, match="whole number"):
        ARRAY.decode(b"\x01\x03\x00\x01\x02")
    with pytest.raises(FieldRangeError, match="item count"):
        ARRAY.encode(header=0, length=0, rates=[1] * 16)


# --- the compiled path agrees with the interpreter --------------------------------
def _all_frames() -> list[Frame]:
    from profiles import alink, mc200
    from profiles.ppmc312 import ascii as serial
    from profiles.ppmc312 import frames

    found = [v for m in (frames, serial, alink, mc200) for v in vars(m).values()
             if isinstance(v, Frame)]
    found += list(mc200.HOST_FRAMES.values())
    return [*found, FRAME]


FRAMES = _all_frames()


def _outcome(fn: object, *args: object) -> tuple[str, object]:
    try:
        return "ok", repr(fn(*args))  # type: ignore[operator]  # repr: NaN == NaN
    except Exception as e:  # the error class and message must agree too
        return type(e).__name__, str(e)


def test_every_codec_frame_is_compiled() -> None:
    assert len(FRAMES) > 20
    assert all(f._layout is not None for f in FRAMES)


@given(st.sampled_from(FRAMES), st.binary(max_size=40), st.data())
def test_compiled_decode_equals_interpreter(frame: Frame, data: bytes, draw: st.DataObject
                                            ) -> None:
    # Mostly near-valid bytes (a valid frame with one byte changed), else random.
    if frame.size is not None and draw.draw(st.booleans()):
        data = (data + bytes(frame.size))[:frame.size]
    assert _outcome(frame.decode, data) == _outcome(frame._decode, data)


@given(st.sampled_from(FRAMES), st.data())
def test_compiled_encode_equals_interpreter(frame: Frame, draw: st.DataObject) -> None:
    names = [p.name for f in frame.fields if isinstance(f, Bits) for p in f.parts] + [
        f.name for f in frame.fields if not isinstance(f, Bits | Const | Reserved | Checksum)]
    value = st.one_of(st.integers(-3, 300), st.integers(-(2**33), 2**33), st.booleans(),
                      st.floats(allow_nan=False), st.none(),
                      st.lists(st.integers(-1, 0x1000000), max_size=12))
    values = {n: draw.draw(value) for n in names if draw.draw(st.integers(0, 9))}
    assert _outcome(frame.encode, values) == _outcome(frame._encode_slow, values)


@pytest.mark.parametrize("size", [1, 2, 4])
def test_a_signed_field_takes_its_whole_twos_complement_range(size: int) -> None:
    """−2^(8n−1) … 2^(8n−1) − 1, both ends encoded and read back; one past either end
    refused, naming the range."""
    field = SInt("x", size)
    lo, hi = -(1 << (8 * size - 1)), (1 << (8 * size - 1)) - 1
    for value in (lo, hi, -1, 0):
        assert field.unpack(field.pack(value), 0) == value
    for value in (lo - 1, hi + 1):
        with pytest.raises(FieldRangeError, match=rf"x: {value}.* allowed range {lo}\.\.{hi}"):
            field.pack(value)


def test_a_bit_field_left_out_is_zero() -> None:
    """Bits a caller does not name are 0 (the manual's reserved and default-off bits)."""
    frame = Frame("f", (Bits("flags", 1, (Bit("a", 7), Bit("b", 0, 3))),))
    assert frame.encode(a=1) == b"\x80" and frame.encode(b=5) == b"\x05"
