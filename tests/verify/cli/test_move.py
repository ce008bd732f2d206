"""`stepramp move --command NAME` (every PPMC-312 motion command, verify/cli/move.py) and
`stepramp check` on the files it writes (verify/command_rules.py): the figures' bytes
from the command line, every format, options a command does not take refused naming
them, and the chip's parameter errors as findings with its codes."""

from __future__ import annotations

from typing import Any

import pytest

from profiles.ppmc312.upload import decode_move, encode_move
from tests.support.ascii_frames import FIGURES, by_hand, move_argv
from tests.support.cli import run


@pytest.mark.parametrize(("name", "params", "block", "serial"), FIGURES)
def test_move_writes_every_figure(capsys: pytest.CaptureFixture[str], name: str,
                                  params: dict[str, Any], block: str, serial: str | None
                                  ) -> None:
    code, out, err = run(capsys, *move_argv(name, params))
    assert (code, err) == (0, "")
    assert bytes.fromhex(out.splitlines()[0]) == bytes.fromhex(block)
    code, out, err = run(capsys, *move_argv(name, params), "--to", "ascii", "--address", "5")
    if serial is None:
        assert code == 2 and err.count("\n") == 1 and "no serial form" in err
    else:
        assert (code, err) == (0, "")
        assert bytes.fromhex(out.splitlines()[0]) == by_hand(5, serial)


def test_the_default_is_todays_accel_move(capsys: pytest.CaptureFixture[str]) -> None:
    for extra, kw in (([], {}), (["--high-rate", "300"], {"high_rate": 300}),
                      (["--override", "3"], {"override": True, "trigger": 3}),
                      (["--rate", "300", "--on", "evt1"],
                       {"high_rate": 300, "override": True, "trigger": 1})):
        code, out, _ = run(capsys, "move", "--pulses", "0x12345678", "--ccw", *extra)
        assert code == 0
        assert bytes.fromhex(out.splitlines()[0]) == encode_move(0x12345678, ccw=True, **kw)
        assert run(capsys, "move", "--command", "accel", "--pulses", "0x12345678", "--ccw",
                   *extra)[1] == out


@pytest.mark.parametrize(("args", "line"), [
    ([], "the following arguments are required: --pulses (see stepramp move --help)"),
    (["--command", "constant"],
     "the following arguments are required by --command constant: --pulses (see stepramp "
     "move --help)"),
    (["--command", "origin-search"],
     "the following arguments are required by --command origin-search: --rate (see "
     "stepramp move --help)"),
    (["--command", "stop", "--pulses", "5"],
     "--pulses: stop (80) does not take it (it takes --override-at, --on)"),
    (["--command", "step", "--rate", "5"], "--rate: step (84) does not take it (it takes "
                                           "--ccw)"),
    (["--command", "high-speed-limit", "--rate", "5", "--ccw"],
     "--ccw: high-speed-limit (05) does not take it (it takes --rate)"),
    (["--command", "accel", "--pulses", "5", "--index"],
     "--index: accel (82) does not take it (it takes --rate, --pulses, --ccw, --on)"),
    (["--command", "accel", "--pulses", "5", "--override-at", "9"],
     "--override-at: accel (82) does not take it (it takes --rate, --pulses, --ccw, --on)"),
    (["--command", "continuous", "--high-rate", "5"],
     "--high-rate: continuous (85) does not take it (it takes --rate, --ccw, --on)"),
    (["--pulses", "5", "--rate", "3", "--high-rate", "4"],
     "--high-rate: give --rate or --high-rate, not both"),
    (["--command", "stop", "--override-at", "4", "--on", "evt1"],
     "--on: give --override-at or --on, not both"),
    (["--command", "change-speed", "--rate", "0"],
     "--rate: 0 is outside the allowed range 2..65535 (0xFFFF)"),
    (["--command", "continuous-constant", "--rate", "9"],
     "--rate: 9 is outside the allowed range 10 (0xA)..65535 (0xFFFF), or 0 (the table's "
     "high rate)"),
    (["--pulses", "5", "--high-rate", "1"],
     "--high-rate: 1 is outside the allowed range 2..65535 (0xFFFF), or 0 (the table's high "
     "rate)"),
    (["--command", "set-speed", "--rate", "9", "--override-at", "9"],
     "--override-at: 9 is outside the allowed range 10 (0xA)..4294967295 (0xFFFFFFFF)"),
    (["--command", "stop", "--to", "ascii", "--address", "16"],
     "--address: 16 (0x10) is outside the allowed range 0..15 (0xF)"),
    (["--pulses", "0x100000000"],
     "--pulses: 4294967296 (0x100000000) is outside the allowed range 1..4294967295 "
     "(0xFFFFFFFF)"),
    (["--command", "continuous", "--on", "evt2", "--to", "ascii"],
     "continuous (85) has no serial form started by an event (evt2) (§16-6: no OV/TRG); "
     "the parallel bus only"),
])
def test_refusals_are_one_line_naming_the_option(capsys: pytest.CaptureFixture[str],
                                                 args: list[str], line: str) -> None:
    code, out, err = run(capsys, "move", *args)
    assert (code, out) == (2, "")
    assert err.splitlines() == [f"stepramp move: {line}"]


def test_move_command_bytes(capsys: pytest.CaptureFixture[str]) -> None:
    from profiles.ppmc312.ascii import decode_serial_move

    code, out, _ = run(capsys, "move", "--pulses", "0x12345678", "--ccw", "--format", "bus")
    assert code == 0
    # the manual's bus example order (§5-6): last byte first, header last
    assert out.splitlines()[-5:-1] == ["DWR 40", "DWR 82", "DWR 08", "DWR 03"]
    code, out, _ = run(capsys, "move", "--pulses", "5000", "--high-rate", "300")
    assert decode_move(bytes.fromhex(out.splitlines()[0])) == {
        "pulses": 5000, "ccw": False, "high_rate": 300, "override": False, "trigger": 0}
    code, out, _ = run(capsys, "move", "--pulses", "5000", "--to", "ascii", "--address", "2")
    assert decode_serial_move(bytes.fromhex(out.splitlines()[0]))["pulses"] == 5000
    assert run(capsys, "move", "--pulses", "0")[0] == 2
    assert run(capsys, "move", "--pulses", "9", "--to", "ascii", "--override", "1")[0] == 2


@pytest.mark.parametrize(("trg", "code"), [("1", 0), ("3", 0), ("0", 2), ("2", 2)])
def test_move_override_takes_the_triggers_the_chip_accepts(
        capsys: pytest.CaptureFixture[str], trg: str, code: int) -> None:
    """SPEC §1: with OV = 1, TRG 01 and 11 register; 00 and 10 are a parameter error."""
    got, out, err = run(capsys, "move", "--pulses", "9", "--override", trg)
    assert got == code
    if code == 0:
        assert decode_move(bytes.fromhex(out.splitlines()[0]))["trigger"] == int(trg)
    else:
        assert "--override: invalid choice" in err
