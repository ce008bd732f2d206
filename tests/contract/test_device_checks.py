"""`stepramp check`, `mc200 decode` and `alink read` on MC-200 stream and A-Link settings
files: the device is told by content, the file's check and the device's rules become
findings, and PPMC-312 files are judged exactly as before."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles import alink as A
from profiles import mc200 as M
from profiles.formats import RenderOptions
from profiles.mc200.formats import render as render_stream
from tests.support.file_checks import alink_file, rules_of
from tests.support.mc200_replies import SHORT_STREAM, packets_of
from tests.support.paths import ROOT
from verify.check_file import check_file
from verify.cli import main
from verify.devices import detect

SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])

SETTINGS_COMMANDS = A.settings_commands(A.quantise_settings(500, 10000, 20))


# --- check: MC-200 -------------------------------------------------------------------------------
def test_check_a_planned_stream_in_every_format(tmp_path: Path) -> None:
    for fmt in ("hex", "json", "c", "ihex", "bin"):
        path = tmp_path / f"s.{fmt}"
        path.write_bytes(render_stream(packets_of(SHORT_STREAM), fmt))
        assert detect(path.read_bytes()).name == "mc200"
        want = [("warning", "mc200-unchecked")] if fmt == "bin" else []
        assert rules_of(path) == want, fmt
        assert main(["check", str(path)]) == 0


def test_check_reports_what_the_driver_makes_of_a_stream(tmp_path: Path) -> None:
    path = tmp_path / "s.bin"
    flipped = bytearray(SHORT_STREAM)
    flipped[12 * 60 + 3] ^= 0x80  # position ±128: passes the packet checksum
    path.write_bytes(bytes(flipped))
    assert rules_of(path) == [("warning", "mc200-unchecked"),
                              ("warning", "mc200-position-reversal")]

    flipped[12 * 61 + 4] ^= 0x01  # a flip the packet checksum sees
    path.write_bytes(bytes(flipped))
    assert ("error", "mc200-packet") in rules_of(path)
    assert main(["check", str(path)]) == 1

    path.write_bytes(SHORT_STREAM[:-12 * 8])  # the hold cut short
    assert rules_of(path) == [("warning", "mc200-unchecked"), ("error", "mc200-hold")]

    broken = (SHORT_STREAM[:12 * 3] + M.mode_switch(0, "position")[0].encode()
              + SHORT_STREAM[12 * 5:])
    path.write_bytes(broken)  # the second magic packet missing: SPI error
    rules = rules_of(path)
    assert ("error", "mc200-spi-error") in rules and ("error", "mc200-hold") in rules

    from dataclasses import replace

    path.write_bytes(b"".join(replace(p, servo=False).encode()  # servo bit never set
                              for p in M.decode_stream(SHORT_STREAM)))
    assert rules_of(path) == [("warning", "mc200-unchecked"), ("error", "mc200-servo"),
                              ("warning", "mc200-servo-off"), ("error", "mc200-hold")]


def test_check_settings_files(tmp_path: Path) -> None:
    for fmt in ("text", "json", "hex", "c"):
        path = alink_file(tmp_path, f"a.{fmt}", SETTINGS_COMMANDS, fmt)
        assert detect(path.read_bytes()).name == "alink"
        assert rules_of(path) == [], fmt
    w = A.CommandWriter()
    nak = [w.put(A.Cmd.MAX_SPEED, 1, 5000), w.put(A.Cmd.MODE, 0, 5),
           w.put(A.Cmd.H_SPEED, 1, 8000), w.put(A.Cmd.L_SPEED, 1, 9000),
           w.put(A.Cmd.UP_TIME, 2, 2001)]
    assert rules_of(alink_file(tmp_path, "nak.hex", nak)) == [("error", "alink-nak"),
                                                             ("warning", "alink-corrected")]
    w = A.CommandWriter()
    over = [w.put(A.Cmd.MAX_SPEED, 1, 5000), w.put(A.Cmd.MODE, 0, 4),
            w.put(A.Cmd.H_SPEED, 1, 8000), w.put(A.Cmd.L_SPEED, 1, 500),
            w.put(A.Cmd.UP_TIME, 2, 2000)]
    assert rules_of(alink_file(tmp_path, "over.hex", over)) == [("error", "alink-mode"),
                                                               ("error", "alink-nak")]
    w = A.CommandWriter()
    part = [w.put(A.Cmd.H_SPEED, 1, 200_000)]
    assert rules_of(alink_file(tmp_path, "part.hex", part)) == [("warning", "alink-incomplete")]
    w = A.CommandWriter()
    rng = [w.put(A.Cmd.H_SPEED, 1, 200_000), w.put(A.Cmd.L_SPEED, 1, 500),
           w.put(A.Cmd.UP_TIME, 2, 2000)]
    assert ("error", "alink-range") in rules_of(alink_file(tmp_path, "range.hex", rng))


@pytest.mark.parametrize(("func", "rules"), [(0, [("error", "alink-range")]),
                                             (1, [("warning", "alink-func")]),
                                             (3, [("error", "alink-range")])])
def test_up_time_func_is_the_rate_or_the_para(tmp_path: Path, func: int,
                                              rules: list[tuple[str, str]]) -> None:
    """UP_TIME's nn: 1 (the legacy rate: a warning, stepramp cannot convert it) or 2 (0.01
    ms per 1000 pps); anything else is an error."""
    w = A.CommandWriter()
    commands = [w.put(A.Cmd.MAX_SPEED, 1, 5000), w.put(A.Cmd.MODE, 0, 5),
                w.put(A.Cmd.H_SPEED, 1, 4000), w.put(A.Cmd.L_SPEED, 1, 500),
                w.put(A.Cmd.UP_TIME, func, 2000)]
    assert rules_of(alink_file(tmp_path, f"f{func}.hex", commands)) == rules


def test_check_pair_codes(tmp_path: Path) -> None:
    first, second = SETTINGS_COMMANDS[:2]
    repeat = A.Command(second.name, second.cmd, second.func, second.para,
                       tuple(w & 0x3FFF | first.pair << 14 for w in second.words),  # type: ignore[arg-type]
                       first.pair)
    noop = A.Command(second.name, second.cmd, second.func, second.para,
                     tuple(w & 0x3FFF for w in second.words), 0)  # type: ignore[arg-type]
    assert rules_of(alink_file(tmp_path, "r.hex", [first, repeat])) == [
        ("error", "alink-pair-code"), ("warning", "alink-incomplete")]
    assert rules_of(alink_file(tmp_path, "n.hex", [first, noop]))[0] == (
        "error", "alink-pair-code")


# --- PPMC-312 files keep priority --------------------------------------------------------------
@SETTINGS
@given(st.lists(st.integers(0, 0xFFFF), min_size=2, max_size=20),
       st.sampled_from(["text", "bin", "ihex", "c", "json", "bus"]), st.integers(3, 30))
def test_ppmc312_uploads_are_never_claimed(rates: list[int], fmt: str, max_data: int) -> None:
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.formats import render
    from profiles.ppmc312.table import FreeCurveTable
    from profiles.ppmc312.upload import encode_free_curve

    table = FreeCurveTable(Clock.internal("8MHz"), tuple(rates), tuple(range(1, len(rates) + 1)))
    data = render(encode_free_curve(table, max_data=max_data), fmt,
                  RenderOptions(name="axis"))
    assert detect(data).name == "ppmc312"


def test_examples_are_told_apart() -> None:
    root = ROOT / "examples"
    for path in root.iterdir():
        want = ("mc200" if ".mc200." in path.name else "alink" if ".alink." in path.name
                else "ppmc312")
        assert detect(path.read_bytes()).name == want, path


@pytest.mark.slow
def test_a_stream_file_may_be_longer_than_other_inputs(tmp_path: Path) -> None:
    """A long move's stream passes the 16 MiB every other input is held to (a 4 M-pulse
    packet stream is 144 MB of hex); any other file that long is still refused."""
    from profiles.reading import MAX_INPUT_BYTES

    hold = SHORT_STREAM[-12:]
    path = tmp_path / "long.mc200.bin"
    path.write_bytes(SHORT_STREAM + hold * ((MAX_INPUT_BYTES - len(SHORT_STREAM)) // 12 + 10))
    assert rules_of(path) == [("warning", "mc200-unchecked")]
    other = tmp_path / "long.txt"
    other.write_bytes(b"02 03 01 00 03\n" * (MAX_INPUT_BYTES // 15 + 1))
    assert "more than the" in (check_file(str(other)).error or "")


@pytest.mark.parametrize("kind", ["table", "upload", "stream"])
def test_check_reads_stdin_once(kind: str, monkeypatch: pytest.MonkeyPatch,
                                capsys: pytest.CaptureFixture[str]) -> None:
    # every file is read once, device detection included: stdin cannot be read twice
    import io
    import sys

    root = ROOT / "examples"
    data = {"table": (root / "free-curve-nema17.json").read_bytes(),
            "upload": (root / "free-curve-nema17.json").read_bytes(),
            "stream": render_stream(packets_of(SHORT_STREAM), "hex")}[kind]
    if kind == "upload":
        from profiles.ppmc312.formats import render
        from profiles.ppmc312.table import table_from_json
        from profiles.ppmc312.upload import encode_free_curve

        data = render(encode_free_curve(table_from_json(json.loads(data))), "text")

    class Stdin:
        buffer = io.BytesIO(data)

    monkeypatch.setattr(sys, "stdin", Stdin())
    assert main(["check", "-"]) == 0, capsys.readouterr()
    out = capsys.readouterr().out
    assert "1 ok" in out and ("MC-200 stream file" in out) == (kind == "stream")


# --- the PPMC-312 block size (REV 1.3, manual §5-5) ----------------------------------
def _nema17_upload(tmp_path: Path, max_data: int | None, fmt: str = "text") -> Path:
    from profiles.ppmc312.formats import render as render_upload
    from profiles.ppmc312.table import load_table
    from profiles.ppmc312.upload import encode_free_curve

    table = load_table(ROOT / "examples"
                       / "free-curve-nema17.json")
    blocks = (encode_free_curve(table) if max_data is None
              else encode_free_curve(table, max_data=max_data))
    path = tmp_path / f"nema17-{max_data}-{fmt}.upload"
    path.write_bytes(render_upload(blocks, fmt))
    return path


def test_a_rev11_sized_upload_is_warned_naming_the_manual(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    old = _nema17_upload(tmp_path, 30)
    found = [f for f in check_file(str(old)).findings if f.rule == "upload-block-size"]
    assert len(found) == 1 and found[0].severity == "warning"
    assert "§5-5" in found[0].message and "up to 30" in found[0].message
    # 26 rates and 26 counts: 30 + 22 and 30 + 30 + 18 data bytes, every one over 14
    assert "5 block(s)" in found[0].message and "blocks 1, 2, 3, 4, 5)" in found[0].message
    assert main(["check", str(old)]) == 0  # a warning: chips that take REV 1.1 blocks exist
    assert "upload-block-size" in capsys.readouterr().out


@pytest.mark.parametrize("max_data", [None, 14, 7])
def test_rev13_sized_uploads_draw_no_block_size_finding(tmp_path: Path,
                                                        max_data: int | None) -> None:
    result = check_file(str(_nema17_upload(tmp_path, max_data)))
    assert result.ok and not [f for f in result.findings if f.rule == "upload-block-size"]


@pytest.mark.parametrize("fmt", ["text", "bin", "ihex", "c", "json", "bus"])
def test_every_format_carries_rev13_blocks_and_is_judged_by_them(tmp_path: Path,
                                                                 fmt: str) -> None:
    from profiles.ppmc312.formats import parse

    fresh = _nema17_upload(tmp_path, None, fmt)
    blocks = parse(fresh.read_bytes()).items
    assert max(len(b) - 2 for b in blocks) == 14 and len(blocks) == 12
    assert not [f for f in check_file(str(fresh)).findings if f.rule == "upload-block-size"]
    old = _nema17_upload(tmp_path, 30, fmt)
    assert [f.rule for f in check_file(str(old)).findings if f.severity == "warning"
            and f.rule == "upload-block-size"] == ["upload-block-size"]


def test_one_block_of_15_is_over_the_limit(tmp_path: Path) -> None:
    found = [f for f in check_file(str(_nema17_upload(tmp_path, 15))).findings
             if f.rule == "upload-block-size"]
    assert len(found) == 1 and "up to 15" in found[0].message


def test_an_upload_without_its_answers_is_noted(tmp_path: Path) -> None:
    fresh = _nema17_upload(tmp_path, None)
    assert "# answer:" in fresh.read_text()
    assert not [n for n in check_file(str(fresh)).notes if "expected answers" in n]
    old = tmp_path / "old.upload.hex"  # as stepramp wrote it before the handshake
    old.write_text("".join(line for line in fresh.read_text().splitlines(keepends=True)
                           if not line.startswith("# answer:")))
    result = check_file(str(old))
    assert result.ok
    assert [n for n in result.notes if "F4 01" in n and "re-export" in n]
