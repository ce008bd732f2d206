"""What the device protocols themselves cannot detect (docs/guide.md, "Upload files";
docs/manual-notes.md), shown on the codecs: the claims the docs make, as tests."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import mc200
from profiles.errors import StepRampError


def _flip(data: bytes, byte: int, bit: int) -> bytes:
    return data[:byte] + bytes([data[byte] ^ (1 << bit)]) + data[byte + 1:]


@settings(max_examples=60, deadline=None)
@given(st.integers(-(2**31), 2**31 - 1), st.integers(0, 15), st.booleans())
def test_mc200_checksum_is_blind_to_bit_7_of_bytes_3_and_5(value: int, driver: int,
                                                             servo: bool) -> None:
    """The packet checksum keeps the low 15 bits of the sum of five 16-bit words, so a
    word's bit 15 (bit 7 of bytes 1, 3, 5, 7, 9) never reaches it. Bytes 1 and 9 are
    reserved and byte 7's bit 7 must be 0, so the flips that pass and change the packet
    are exactly bit 7 of bytes 3 and 5: the position off by ±128 or ±8 388 608."""
    packet = mc200.HostPacket(driver, servo, 0, value, "position")
    data = packet.encode()
    changed = {}
    for byte in range(len(data)):
        for bit in range(8):
            try:
                got = mc200.HostPacket.decode(_flip(data, byte, bit))
            except StepRampError:
                continue
            if got != packet:
                changed[(byte, bit)] = got.value - value
    assert set(changed) == {(3, 7), (5, 7)}
    assert abs(changed[(3, 7)]) == 128 and abs(changed[(5, 7)]) == 8_388_608


def test_ascii_frame_checksum_misses_swapped_characters() -> None:
    """The serial frame's check is a sum: two characters swapped (or two changes that
    cancel) pass it and decode to other parameters."""
    from profiles.ppmc312.ascii import decode_serial_init, encode_serial_init
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.table import InitTable

    table = InitTable(Clock.internal("8MHz"), "linear", 0x2710, 0x0190, 0x07D0)
    frame = bytearray(encode_serial_init(table, 3))
    frame[3], frame[5] = frame[5], frame[3]  # two digits of the start rate swapped
    swapped = decode_serial_init(bytes(frame))
    assert swapped != table and swapped.high_rate == table.high_rate


def test_parallel_upload_has_no_check_a_flip_is_another_legal_table() -> None:
    """The parallel bus carries no check at all: bit 0 of the free-curve mode byte turns
    8 MHz into 1 MHz, and the chip model accepts the 8× slower table."""
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.emulator import accept_upload
    from profiles.ppmc312.table import FreeCurveTable
    from profiles.ppmc312.upload import decode_free_curve, encode_free_curve

    table = FreeCurveTable(Clock.internal("8MHz"), (400, 800, 2000), (100, 50, 20))
    blocks = encode_free_curve(table)
    flipped = [_flip(blocks[0], 3, 0), *blocks[1:]]
    assert accept_upload(flipped).ok
    other = decode_free_curve(flipped)
    assert other.clock.name == "1MHz" and other.rates == table.rates


# --- what check and decode say about a file's own check --------------------------------
def test_check_and_decode_report_a_corrupted_file(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.file_verdict import load_checkable
    from profiles.ppmc312.formats import render
    from profiles.ppmc312.table import FreeCurveTable
    from profiles.ppmc312.upload import encode_free_curve
    from verify.check_file import check_file
    from verify.cli import main

    blocks = encode_free_curve(FreeCurveTable(Clock.internal("8MHz"), (400, 800, 2000),
                                              (100, 50, 20)))
    good = render(blocks, "json")
    doc = json.loads(good)
    doc["blocks"][1] = doc["blocks"][1].replace("01 90", "01 91")  # rate 400 → 401
    bad = tmp_path / "bad.upload.json"
    bad.write_text(json.dumps(doc))
    table, findings = load_checkable(str(bad))
    assert table is None and [(f.severity, f.rule) for f in findings] == [
        ("error", "upload-corrupted")]
    assert "corrupted" in findings[0].message
    assert not check_file(str(bad)).ok and check_file(str(bad)).error is None  # exit 1
    assert main(["check", str(bad)]) == 1
    assert main(["decode", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("stepramp decode: corrupted: the crc32 field says CRC-32")
    assert len(err.splitlines()) == 1

    # the same blocks without a check: judged, with the warning
    for name, data in (("hand.upload.json", json.dumps({"blocks": doc["blocks"][:1] + json.loads(
            good)["blocks"][1:]}).encode()), ("raw.upload.bin", render(blocks, "bin"))):
        path = tmp_path / name
        path.write_bytes(data)
        table, findings = load_checkable(str(path))
        assert table is not None
        assert [(f.severity, f.rule) for f in findings] == [("warning", "upload-unchecked")]
        assert main(["check", str(path)]) == 0
