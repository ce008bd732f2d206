"""`stepramp alink`: what its options refuse, and where the words' range ends."""

from __future__ import annotations

import pytest

from verify import cli


@pytest.mark.parametrize(("word", "code"), [("0xFFFF", 0), ("65535", 0), ("0x10000", 2),
                                            ("-1", 2)])
def test_decode_takes_16_bit_words(word: str, code: int,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["alink", "decode", word, "0", "0"]) == code
    err = capsys.readouterr().err
    if code:
        assert err.startswith(f"stepramp alink: word 0: {int(word, 0)}")
        assert err.rstrip().endswith("is outside the allowed range 0..65535 (0xFFFF)")
    else:
        assert err == ""


@pytest.mark.parametrize("explicit", [["--start-pps", "100"], ["--high-pps", "5000"],
                                      ["--accel-ms-per-kpps", "10"]])
def test_settings_take_a_motor_or_the_speeds_never_both(
        explicit: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    """One given speed beside --motor would be ignored by the plan: refused instead."""
    assert cli.main(["alink", "settings", "--motor", "nema17-1600", "--pulses", "1000",
                     *explicit]) == 2
    assert capsys.readouterr().err == ("stepramp alink: give either --motor or "
                                       "--start-pps/--high-pps/--accel-ms-per-kpps\n")
