"""The PPMC-312 ASCII command frames of the manual's figures (§13), a frame built by hand
from §13-2/§13-4 alone, the `stepramp move` command line that writes a command, and
`check`'s reading of a file of commands."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def by_hand(address: int, payload_hex: str) -> bytes:
    """An ASCII command frame built by §13-2/§13-4 alone: control 0x90 + address, the
    payload as uppercase hex characters, the checksum of control + characters, inverted,
    bit 7 cleared, as two characters."""
    control = 0x90 + address
    chars = payload_hex.replace(" ", "").upper().encode("ascii")
    check = (~(control + sum(chars))) & 0x7F
    return bytes([control]) + chars + f"{check:02X}".encode("ascii")


# (command, parameters, the block the figure draws, the serial payload §16 draws)
FIGURES: list[tuple[str, dict[str, Any], str, str | None]] = [
    # §8-1 / §16-1: `03 06|02 80 mode [stop position(4)]`, mode `x x x x x OV TRG`
    ("stop", {}, "03 02 80 00", "80"),
    ("stop", {"override_at": 0x12345678}, "03 06 80 04 12 34 56 78", "8B 12345678"),
    ("stop", {"on": "evt1"}, "03 02 80 05", "9B"),
    ("stop", {"on": "evt2"}, "03 02 80 07", "BB"),
    # §8-2 / §16-2: the same with 81 (decel start position)
    ("decel-stop", {}, "03 02 81 00", "81"),
    ("decel-stop", {"override_at": 0}, "03 06 81 04 00 00 00 00", "8C 00000000"),
    ("decel-stop", {"on": "evt1"}, "03 02 81 05", "9C"),
    ("decel-stop", {"on": "evt2"}, "03 02 81 07", "BC"),
    # §8-3 / §16-3: `03 08 82 mode high-rate(2) pulses(4)`; serial `1 0 DIR 0 0011`
    ("accel", {"pulses": 0x12345678, "ccw": True}, "03 08 82 40 00 00 12 34 56 78",
     "A3 0000 12345678"),
    ("accel", {"pulses": 5, "rate": 0x1234}, "03 08 82 00 12 34 00 00 00 05",
     "83 1234 00000005"),
    ("accel", {"pulses": 5, "rate": 0x1234, "on": "evt2"}, "03 08 82 07 12 34 00 00 00 05",
     None),
    # §8-4 (layout of 82; §16-4 `1 0 DIR 0 0100` rate(2) pulses(4))
    ("constant", {"rate": 400, "pulses": 300, "ccw": True}, "03 08 83 40 01 90 00 00 01 2C",
     "A4 0190 0000012C"),
    ("constant", {"pulses": 1, "on": "evt1"}, "03 08 83 05 00 00 00 00 00 01", None),
    ("constant", {"pulses": 1}, "03 08 83 00 00 00 00 00 00 01", "84 0000 00000001"),
    # §8-5 / §16-5: `03 02 84 mode`, mode `× DIR × × × × × ×`; serial `1 0 DIR 0 0010`
    ("step", {}, "03 02 84 00", "82"),
    ("step", {"ccw": True}, "03 02 84 40", "A2"),
    # §8-6 / §16-6: `03 04 85 mode rate(2)`; serial `1 0 DIR 0 0110`
    ("continuous", {}, "03 04 85 00 00 00", "86 0000"),
    ("continuous", {"rate": 500, "ccw": True, "on": "evt2"}, "03 04 85 47 01 F4", None),
    ("continuous", {"rate": 500, "ccw": True}, "03 04 85 40 01 F4", "A6 01F4"),
    # §8-7 / §16-7: `03 04 86 mode rate(2)` (0xa~0xffff); serial `1 0 DIR 0 0101`
    ("continuous-constant", {"rate": 0xA}, "03 04 86 00 00 0A", "85 000A"),
    ("continuous-constant", {"ccw": True, "on": "evt1"}, "03 04 86 45 00 00", None),
    ("continuous-constant", {"ccw": True}, "03 04 86 40 00 00", "A5 0000"),
    # §8-8 / §16-8: `03 04|08 87 mode rate(2) [position(4)]`; serial 89 8E 9E BE
    ("change-speed", {"rate": 200}, "03 04 87 00 00 C8", "89 00C8"),
    ("change-speed", {"rate": 200, "override_at": 0x10000}, "03 08 87 04 00 C8 00 01 00 00",
     "8E 00C8 00010000"),
    ("change-speed", {"rate": 200, "on": "evt1"}, "03 04 87 05 00 C8", "9E 00C8"),
    ("change-speed", {"rate": 200, "on": "evt2"}, "03 04 87 07 00 C8", "BE 00C8"),
    # §8-9 / §16-9: the same with 88; serial 88 8D 9D BD
    ("set-speed", {"rate": 0xFFFF}, "03 04 88 00 FF FF", "88 FFFF"),
    ("set-speed", {"rate": 2, "override_at": 0xA}, "03 08 88 04 00 02 00 00 00 0A",
     "8D 0002 0000000A"),
    ("set-speed", {"rate": 2, "on": "evt1"}, "03 04 88 05 00 02", "9D 0002"),
    ("set-speed", {"rate": 2, "on": "evt2"}, "03 04 88 07 00 02", "BD 0002"),
    # §8-10 / §16-10: `03 04 10 mode rate(2)`, mode `× DIR × × × × × IDX`;
    # serial `1 0 DIR IDX 0 1 1 1`
    ("origin-search", {"rate": 4000}, "03 04 10 00 0F A0", "87 0FA0"),
    ("origin-search", {"rate": 4000, "index": True}, "03 04 10 01 0F A0", "97 0FA0"),
    ("origin-search", {"rate": 4000, "ccw": True}, "03 04 10 40 0F A0", "A7 0FA0"),
    ("origin-search", {"rate": 2, "ccw": True, "index": True}, "03 04 10 41 00 02",
     "B7 0002"),
    # §8-11 (layout of §8-10) / §16-11 REV 1.3: `1 0 DIR IDX 1 0 1 0`
    ("origin-return", {}, "03 04 11 00 00 00", "8A 0000"),
    ("origin-return", {"rate": 300, "index": True}, "03 04 11 01 01 2C", "9A 012C"),
    ("origin-return", {"rate": 300, "ccw": True, "index": True}, "03 04 11 41 01 2C",
     "BA 012C"),
    # §7-6 / §15-5: `03 03 05 rate(2)`; serial 47 rate(2)
    ("high-speed-limit", {"rate": 500}, "03 03 05 01 F4", "47 01F4"),
]


OPTION = {"rate": "--rate", "pulses": "--pulses", "override_at": "--override-at",
          "on": "--on"}
FLAG = {"ccw": "--ccw", "index": "--index"}


def move_argv(name: str, params: dict[str, Any]) -> list[str]:
    """`stepramp move --command NAME` with `params` (a FIGURES row's) as its options."""
    out = ["move", "--command", name]
    for key, value in params.items():
        out += [FLAG[key]] if key in FLAG else [OPTION[key], str(value)]
    return out


def judge(tmp_path: Path, items: list[bytes]) -> Any:
    """`check_file`'s result for `items` (command blocks or frames) written as a text file
    in `tmp_path` (read without error)."""
    from profiles.ppmc312.formats import render
    from verify.check_file import check_file

    path = tmp_path / "cmd.hex"
    path.write_bytes(render(items, "text"))
    result = check_file(str(path))
    assert result.error is None
    return result
