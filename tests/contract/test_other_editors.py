"""Files from other editors (issue 32 item 7) and JSON with a key twice (item 11): a UTF-8
byte-order mark is read by every reader; UTF-16 text and other tools' JSON/CSV are refused
in one honest line; `motor list` lists motor files only; a name that matches ./NAME.json
says so; a repeated JSON key is refused naming it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from profiles.errors import FormatError
from profiles.motor.catalogue import ENV_VAR, resolve
from profiles.reading import parse_json, read_bytes, utf8_text, wide_text_encoding
from tests.support.cli import run
from tests.support.paths import ROOT

TABLE = ROOT / "examples" / "free-curve-nema17.json"


MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


BOM = b"\xef\xbb\xbf"


def with_bom(src: Path, dst: Path) -> Path:
    dst.write_bytes(BOM + src.read_bytes())
    return dst


def test_a_bom_table_reads_as_without(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                      ) -> None:
    f = with_bom(TABLE, tmp_path / "bom.json")
    for argv in (["check", f], ["show", f], ["export", f, "-o", tmp_path / "b.hex"]):
        code, out, err = run(capsys, *argv)
        plain = run(capsys, *[TABLE if a == f else tmp_path / "p.hex" if str(a).endswith(
            "b.hex") else a for a in argv])
        assert code == plain[0] == 0 and err == "", (argv, err)
        assert out.replace(str(f), "F") == plain[1].replace(str(TABLE), "F")
    assert (tmp_path / "b.hex").read_bytes() == (tmp_path / "p.hex").read_bytes()


def test_a_bom_is_read_by_every_reader(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                       ) -> None:
    motor = with_bom(MOTOR, tmp_path / "m.json")
    assert run(capsys, "motor", "check", motor)[0] == 0
    moves = with_bom(ROOT / "examples" / "duty-cycle.csv", tmp_path / "moves.csv")
    code, _, err = run(capsys, "plan", "--motor", motor, "--moves", moves, "-o",
                       tmp_path / "t.json")
    assert code == 0, err
    curve = with_bom(ROOT / "examples" / "curve-example.csv", tmp_path / "curve.csv")
    code, _, err = run(capsys, "motor", "new", "--rotor-inertia-gcm2", "82", "--curve", curve,
                       "--speed-unit", "rpm", "--torque-unit", "oz-in", "--microstep", "8")
    assert code == 0, err
    assert utf8_text(BOM + b"a", "x") == "a" and read_bytes(motor)[:1] == b"{"


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-16-be", "utf-32"])
def test_wide_text_is_refused_saying_so(encoding: str, tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "t.json"
    f.write_bytes(TABLE.read_text(encoding="utf-8").encode(encoding))
    want = "UTF-32" if encoding == "utf-32" else "UTF-16"
    for command in ("check", "show", "export"):
        out = ["-o", tmp_path / "x.hex"] if command == "export" else []
        code, _, err = run(capsys, command, f, *out)
        assert code == 2 and err == (f"stepramp {command}: {f}: {want} text: save it as UTF-8 "
                                     "(stepramp reads UTF-8 text files)\n"), err
    assert not (tmp_path / "x.hex").exists()


def test_binary_inputs_are_not_wide_text() -> None:
    """A PPMC-312 block starts with its length (≤ 31), an MC-200 packet's reserved bytes
    are 0: neither looks like UTF-16."""
    assert wide_text_encoding(bytes([0x0A, 0x00, 0x41, 0x00, 0x42, 0x00, 0x43, 0x00])) is None
    assert wide_text_encoding(bytes([0x21, 0x00, 0x00, 0x10] + [0] * 8)) is None
    assert wide_text_encoding("{ \n}".encode("utf-16-le")) == "UTF-16"


def test_other_tools_json_and_csv(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    other = tmp_path / "package.json"
    other.write_text('{"name": "x", "version": "1.0"}')
    csv = tmp_path / "log.csv"
    csv.write_text("time,speed\n0,0\n")
    array = tmp_path / "a.json"
    array.write_text("[1, 2]")
    for command in ("check", "show", "export"):
        _, _, err = run(capsys, command, other, *(["-o", tmp_path / "x.hex"]
                                                   if command == "export" else []))
        assert err.endswith(f"{other}: format: expected 'stepramp.table/1', got no \"format\" "
                            "key (JSON from another tool? its keys: 'name, version')\n"), err
    for command in ("show", "export"):
        _, _, err = run(capsys, command, csv, "-o", tmp_path / "x.hex")
        assert "it starts 'time,speed', CSV or text, not a JSON document" in err
        assert len(err.splitlines()) == 1
    _, _, err = run(capsys, "check", csv, array)
    assert f"{csv}: not judged: a CSV file that is not one of stepramp's" in err
    assert f"{array}: not judged: a JSON array" in err


def test_motor_list_lists_motor_files_only(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "mixed"
    folder.mkdir()
    (folder / "17hs19.json").write_bytes(BOM + MOTOR.read_bytes())
    (folder / "settings.json").write_text('{"theme": "dark"}')
    (folder / "notes.json").write_text("not even JSON")
    (folder / "broken.json").write_text('{"format": "stepramp.motor/1"}')
    monkeypatch.setenv(ENV_VAR, str(folder))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    code, out, _ = run(capsys, "motor", "list")
    names = [line.split()[0] for line in out.splitlines()[1:]]
    assert code == 0 and "settings" not in names and "notes" not in names
    assert "17hs19" in names and "broken" in names  # a broken motor file says why
    assert "unreadable: missing key(s)" in out


def test_a_name_matching_a_local_file_says_so(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    (tmp_path / "17hs19.json").write_bytes(MOTOR.read_bytes())
    with pytest.raises(FormatError, match=r"did you mean \./17hs19\.json\?"):
        resolve("17hs19")
    code, _, err = run(capsys, "plan", "--motor", "17hs19", "--pulses", "1000")
    assert code == 2 and "did you mean ./17hs19.json?" in err and len(err.splitlines()) == 1


# --- a key twice ---------------------------------------------------------------------------
def test_a_repeated_key_is_refused_naming_it(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    """The last value won before: a second "clock": "1MHz" checked OK and exported 8×
    slower."""
    text = TABLE.read_text(encoding="utf-8").rstrip().removesuffix("}") + ', "clock": "1MHz"}'
    f = tmp_path / "dup.json"
    f.write_text(text)
    for argv in (["check", f], ["show", f], ["export", f, "-o", tmp_path / "x.hex"]):
        code, _, err = run(capsys, *argv)
        assert code == 2 and f"{f}: key 'clock' appears twice in one object" in err, err
    assert not (tmp_path / "x.hex").exists()
    nested = json.dumps({"format": "stepramp.motor/1"})[:-1] + ', "sources": {"a": 1, "a": 2}}'
    with pytest.raises(FormatError, match="key 'a' appears twice"):
        parse_json(nested.encode(), "m.json")
    m = tmp_path / "m.json"
    m.write_text(MOTOR.read_text(encoding="utf-8").rstrip().removesuffix("}")
                 + ', "safety_factor": 1.0}')
    code, _, err = run(capsys, "motor", "check", m)
    assert code == 2 and "key 'safety_factor' appears twice" in err
