"""`stepramp answer`: PPMC-312 answers decoded on the command line, in-process through
`verify.cli.main`; bad input is one line on stderr and exit 2."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from profiles.ppmc312.ascii import encode_frame
from profiles.ppmc312.replies import REPLY_TO
from verify import cli
from verify.cli import answer as answer_cli


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = cli.main(["answer", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_one_answer_as_text(capsys: pytest.CaptureFixture[str]) -> None:
    assert run(capsys, "23", "06", "E0", "48", "00", "00", "12", "34") == (0, (
        "pulse output stopped (E0), manual §11-1\n"
        "  header 23: CMR 1 (a report the chip raises itself), from the bus, PAL 1, NEXT 1 "
        "(the last block)\n"
        "  cause 48: NOS (normal end at the output stop position), DEC (stopped by the "
        "decelerate-stop command)\n"
        "  position 4660 (0x00001234)\n"), "")


def test_a_capture_is_one_block_per_answer(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "03 03 01 00 05", "0303010104", "03 08 01 0F 00 01 00 00 01 00")
    assert (code, err) == (0, "")
    blocks = out.split("\n\n")
    assert [b.splitlines()[0] for b in blocks] == [
        "free-curve answer, in progress (01), manual §7-2",
        "free-curve answer, in progress (01), manual §7-2",
        "free-curve answer, done (01), manual §7-2"]
    assert blocks[1].splitlines()[2:] == ["  status 01: accel stages still to send",
                                          "  stages to send 4"]


def test_json_is_one_object(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "03 06 42 00 12 34 56 78", "03 02 F5 99", "--format", "json")
    assert (code, err) == (0, "")
    doc = json.loads(out)
    assert [a["key"] for a in doc["answers"]] == ["42", "F5"]
    assert doc["answers"][0]["fields"] == {"counter": 0, "position": 0x12345678}
    assert doc["answers"][1]["meanings"] == {"command": "no command code of the manual"}


def test_a_capture_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    capture = tmp_path / "capture.hex"
    capture.write_text("# read from DRR, header first\n03 02 82 10   # triangle\n"
                       "23 06 E0 40 00 00 13 88\n", encoding="utf-8")
    code, out, err = run(capsys, "--file", str(capture))
    assert (code, err) == (0, "")
    assert "  status 10: triangle, pulse output started" in out.splitlines()
    assert "  position 5000 (0x00001388)" in out.splitlines()
    bad = tmp_path / "bad.hex"
    bad.write_text("03 01 00\n03 0\n", encoding="utf-8")
    assert run(capsys, "--file", str(bad)) == (
        2, "", f"stepramp answer: {bad}, line 2, column 4: '0' has an odd number of hex "
               "digits (two a byte)\n")


@pytest.mark.parametrize("argv, line", [
    (["03", "0"], "HEX, column 4: '0' has an odd number of hex digits (two a byte)"),
    (["03", "01", "77"], "byte 2: response code 0x77 is no answer of the manual (§7–§11)"
                         .replace("byte 2", "block 0, byte 2")),
    (["03 06 42 00 12"], "block 0, byte 1: length byte 0x06 says 6 bytes follow, only 3 do"),
    (["03 02 82 00 03 01"], "block 1, byte 1: length byte 0x01 says 1 bytes follow, only 0 "
                            "do"),
    (["83 01 00"], "block 0, byte 0: header 0x83 has bit 7 set: not an answer header "
                   "(0 0 CMR RESP(2) 0 PAL NEXT, §5-7.1)"),
    (["13 01 00"], "block 0, byte 0: header 0x13 has RESP = 10, which §5-7.1 says cannot "
                   "occur"),
    (["03 02 F1 00"], "block 0, byte 1: state error (F1): length byte 0x02, the manual's "
                      "figure (§11-7) gives 0x04"),
    (["xy"], "HEX, column 1: 'x' is not a hex digit"),
    ([], "give the answer's bytes as HEX (e.g. 03 01 00) or --file PATH"),
    (["03 01 00", "--file", "x.hex"], "give the bytes as HEX or with --file, not both"),
    (["03 01 00", "--reply-to", "poll"], "--reply-to is for --serial replies (a parallel "
                                         "answer carries its response code)"),
    (["--read-order", "--serial", "A5 33 38 36 46"], "--read-order is for parallel answers "
                                                     "read from DRR (a serial reply comes on "
                                                     "the line in its own order)"),
    # read order: a capture that starts inside an answer is named at its start
    (["--read-order", "34 12 00 42 06 03"], "block 0, byte 4: length byte 0x06 says 6 bytes "
                                            "were read before it, only 4 were"),
    (["--read-order", "03"], "block 0, byte 0: 0x03 with no length byte read before it (read "
                             "from DRR, an answer ends with its length byte and its header, "
                             "§5-8)"),
    # header first pasted as if read: 0x78 is taken for the header, 0x56 for its length
    (["--read-order", "03 06 42 00 12 34 56 78"], "block 0, byte 6: length byte 0x56 says 86 "
                                                  "bytes were read before it, only 6 were"),
    # a value the figure does not give, named at its byte as read (03 02 82 05 read back)
    (["--read-order", "00 01 03", "05 82 02 03"], "block 1, byte 0: accel/decel move answer "
                                                  "(82): status 0x05 is none of the manual's "
                                                  "(00, 01, 10, 11, 20, 21, 40, 41, §8-3)"),
])
def test_bad_input_is_one_line_and_exit_2(argv: list[str], line: str,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    assert run(capsys, *argv) == (2, "", f"stepramp answer: {line}\n")


def test_the_manuals_read_order_example(capsys: pytest.CaptureFixture[str]) -> None:
    # §5-8: the position answer as DRR gives it, 「パラメータの下位から読み出します」
    code, out, err = run(capsys, "--read-order", "78 56 34 12 00 42 06 03")
    assert (code, err) == (0, "")
    assert out.splitlines() == [
        "position read answer (42), manual §10-2",
        "  header 03: CMR 0 (the answer to a command), from the bus, PAL 1, NEXT 1 (the last "
        "block)",
        "  counter 00: pulse position",
        "  position 305419896 (0x12345678)"]
    assert out == run(capsys, "03 06 42 00 12 34 56 78")[1]  # the same answer, header first


def test_a_read_order_capture_is_the_answers_oldest_first(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # two answers read one after the other, each header last: a DRR capture in a file
    capture = tmp_path / "drr.hex"
    capture.write_text("# DRR reads\n05 00 01 03 03   # block 0's answer\n"
                       "00 00 00 0F 00 00 0F 01 08 03\n", encoding="utf-8")
    code, out, err = run(capsys, "--read-order", "--file", str(capture), "--format", "json")
    assert (code, err) == (0, "")
    answers = json.loads(out)["answers"]
    assert [a["bytes"] for a in answers] == ["03 03 01 00 05", "03 08 01 0F 00 00 0F 00 00 00"]
    assert [a["key"] for a in answers] == ["01 progress", "01 done"]


def test_serial_replies(capsys: pytest.CaptureFixture[str]) -> None:
    stop = encode_frame("data", 5, b"\x38").hex(" ")
    assert stop == "a5 33 38 36 46"
    code, out, err = run(capsys, "--serial", stop)
    assert (code, err) == (0, "")
    assert out.splitlines() == ["pulse output stopped (A0+a), manual §19-14",
                                "  control A5: data reply from slave 5",
                                "  end code 38: normal stop at the commanded position"]
    version = encode_frame("ready", 5, b"\x12").hex()
    assert run(capsys, "--serial", version)[2] == (
        "stepramp answer: block 0, byte 1: a ready reply with one data byte answers version "
        "read (§18-4) or error code read (§18-10): say which (reply to version or "
        "error-code)\n")
    code, out, _ = run(capsys, "--serial", version, "--reply-to", "version")
    assert code == 0 and out.splitlines()[-1] == "  version 18 (0x12)"
    assert run(capsys, "--serial", stop[:-1] + "7")[0] == 2  # checksum


def test_the_cli_lists_every_command_a_reply_answers() -> None:
    assert answer_cli.REPLY_TO == tuple(REPLY_TO)
