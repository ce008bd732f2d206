"""Motors by name (profiles/motor/catalogue.py): where names come from, which wins, and
every command taking a name where it takes a motor file."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from profiles.errors import FormatError
from profiles.motor import bundled_motor_paths, load_motor
from profiles.motor.catalogue import (
    BUNDLED,
    ENV_VAR,
    USER_CONFIG,
    entries,
    find,
    motor_name,
    resolve,
)
from tests.support.motor_folders import NEMA17, motor_file, motor_folders
from tests.support.paths import ROOT
from verify import cli

EXAMPLES = ROOT / "examples"


def test_names_from_file_names() -> None:
    assert motor_name(Path("motor-nema17-1600.json")) == "nema17-1600"
    assert motor_name(Path("x-axis.motor.json")) == "x-axis"
    assert motor_name(Path("lift.json")) == "lift"
    assert motor_name(Path("motor-.json")) == "motor-"  # no empty name
    assert [motor_name(p) for p in bundled_motor_paths()] == [
        "nema17-1600", "nema23-heavy", "pk566-5phase-half"]


def test_bundled_motors_by_name() -> None:
    assert resolve("nema17-1600") == NEMA17
    assert load_motor("nema17-1600").to_json() == load_motor(NEMA17).to_json()
    assert {e.source for e in entries()} == {BUNDLED}  # conftest: no user folders


@pytest.fixture
def folders(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path, Path]:
    return motor_folders(tmp_path, monkeypatch)


def test_lookup_order_and_shadowing(folders: tuple[Path, Path, Path]) -> None:
    env_a, env_b, config = folders
    in_b = motor_file(env_b, "nema17-1600.json", steps=800)
    in_config = motor_file(config, "motor-nema17-1600.json", steps=1000)
    motor_file(config, "lift.motor.json")
    in_a = motor_file(env_a, "lift.json", steps=200)
    # the first folder of STEPRAMP_MOTORS, then the next, then the config folder, then bundled
    assert resolve("nema17-1600") == in_b
    assert load_motor("nema17-1600").steps_per_rev == 800
    assert resolve("lift") == in_a
    listed = [(e.name, e.path, e.source, e.shadowed_by) for e in entries()]
    assert listed[:2] == [("lift", in_a, ENV_VAR, None), ("nema17-1600", in_b, ENV_VAR, None)]
    assert ("nema17-1600", in_config, USER_CONFIG, ENV_VAR) in listed
    assert ("lift", config / "lift.motor.json", USER_CONFIG, ENV_VAR) in listed
    assert ("nema17-1600", NEMA17, BUNDLED, ENV_VAR) in listed
    in_b.unlink()
    assert find("nema17-1600") is not None and resolve("nema17-1600") == in_config


def test_a_path_always_wins(folders: tuple[Path, Path, Path]) -> None:
    env_a, _, _ = folders
    motor_file(env_a, "lift.json")
    local = motor_file(Path.cwd(), "lift", steps=3200)  # a file named like the motor
    assert resolve("lift") == "lift" and load_motor("lift").steps_per_rev == 3200
    local.unlink()
    assert resolve("lift") == env_a / "lift.json"
    # looks like a path: stays one even when missing, so the error names the file
    assert resolve("motors/lift") == "motors/lift"
    assert resolve("lift.json") == "lift.json"
    with pytest.raises(FormatError, match="an empty file name"):
        load_motor("")
    with pytest.raises(FormatError, match=r"lift\.json: no such file"):
        load_motor("lift.json")


def test_unknown_name_lists_close_ones() -> None:
    with pytest.raises(FormatError) as e:
        load_motor("nema17")
    assert str(e.value) == ("motor 'nema17': no such file and no motor of that name (close "
                            "names: nema17-1600; `stepramp motor list` lists them)")
    with pytest.raises(FormatError, match=r"3 known: nema17-1600, nema23-heavy, pk566"):
        load_motor("zzz")


@pytest.mark.parametrize("argv", [
    ["motor", "show", "nema17"],
    ["check", str(EXAMPLES / "free-curve-nema17.json"), "--motor", "nema17"],
    ["plan", "--motor", "nema17"],
    ["compare", str(EXAMPLES / "free-curve-nema17.json"), "--motor", "nema17", "--pulses", "9"],
    ["sweep", "--motors", "nema17", "--pulses", "9", "-o", "x.csv"],
    ["alink", "settings", "--motor", "nema17"],
    ["mc200", "stream", "--motor", "nema17", "--pulses", "9", "--period-us", "1000"],
    ["show", str(EXAMPLES / "free-curve-nema17.json"), "--motor", "nema17"],
    ["export", str(EXAMPLES / "free-curve-nema17.json"), "--motor", "nema17"],
    ["motor", "check", "nema17"],
])
def test_every_motor_argument_resolves_names(argv: list[str], tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    code = cli.main(argv)
    out, err = capsys.readouterr()
    if argv[:2] == ["motor", "check"]:  # motor check reports each file on stdout
        assert code == 2 and "close names: nema17-1600" in out
        return
    assert code == 2 and len(err.splitlines()) == 1, err
    assert "motor 'nema17': no such file and no motor of that name (close names: nema17-1600" \
        in err
    assert not list(tmp_path.iterdir())  # nothing written


def test_names_work_in_commands(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    table = str(EXAMPLES / "free-curve-nema17.json")
    assert cli.main(["check", table, "--motor", "nema17-1600", "--no-physics"]) == 0
    assert cli.main(["check", table, "--motor", "nema23-heavy", "--no-physics"]) == 1
    assert cli.main(["show", table, "--motor", "nema17-1600"]) == 0
    assert "rpm" in capsys.readouterr().out
    assert cli.main(["motor", "check", "pk566-5phase-half", str(NEMA17)]) == 0
    assert capsys.readouterr().out == f"pk566-5phase-half: ok\n{NEMA17}: ok\n"


def test_axes_files_take_names(tmp_path: Path) -> None:
    from verify.devices import load_axes

    shutil.copy(NEMA17, tmp_path / "local.json")
    (tmp_path / "axes.json").write_text(json.dumps({
        "format": "stepramp.axes/1", "mode": "time",
        "axes": [{"name": "x", "motor": "nema23-heavy", "pulses": 100},
                 {"name": "y", "motor": "local.json", "pulses": -100}]}))
    axes = load_axes(tmp_path / "axes.json")
    assert axes.axes[0].motor is not None
    assert axes.axes[0].motor.to_json() == load_motor("nema23-heavy").to_json()
    assert axes.axes[1].motor_path == tmp_path / "local.json"
    assert axes.to_json()["axes"][0]["motor"] == "nema23-heavy"  # written back as a name
    (tmp_path / "axes.json").write_text(json.dumps({
        "format": "stepramp.axes/1", "mode": "time",
        "axes": [{"name": "x", "motor": "nema17", "pulses": 100}]}))
    with pytest.raises(FormatError, match=r"axes\[0\]\.motor: motor 'nema17': no such file"):
        load_axes(tmp_path / "axes.json")
