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
from verify import cli

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
NEMA17 = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


def motor_file(folder: Path, file_name: str, name: str = "", steps: int = 400) -> Path:
    obj = json.loads(NEMA17.read_text(encoding="utf-8"))
    obj.update(name=name or file_name, steps_per_rev=steps)
    del obj["holding_torque_nm"]  # `motor list` falls back on the curve at 0 pps
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / file_name
    path.write_text(json.dumps(obj), encoding="utf-8")
    return path


@pytest.fixture
def folders(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path, Path]:
    """Two STEPRAMP_MOTORS folders and the XDG config folder's motors, all empty."""
    env_a, env_b, config = tmp_path / "env-a", tmp_path / "env-b", tmp_path / "config"
    monkeypatch.setenv(ENV_VAR, f"{env_a}:{env_b}")
    monkeypatch.setenv("XDG_CONFIG_HOME", str(config))
    monkeypatch.chdir(tmp_path)
    return env_a, env_b, config / "stepramp" / "motors"


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


def test_motor_list_text_and_json(folders: tuple[Path, Path, Path],
                                  capsys: pytest.CaptureFixture[str]) -> None:
    env_a, env_b, config = folders
    motor_file(env_a, "nema17-1600.json", name="my NEMA17")
    (config / "broken.json").parent.mkdir(parents=True)
    (config / "broken.json").write_text('{"format": "stepramp.motor/2"}')
    (config / "settings.json").write_text('{"editor.tabSize": 4}')  # another tool's: unlisted
    assert cli.main(["motor", "list"]) == 0
    out, err = capsys.readouterr()
    assert err == f"stepramp motor: warning: {ENV_VAR} folder {env_b} is not a folder\n"
    lines = out.splitlines()
    assert lines[0].split() == ["name", "steps/rev", "holding", "[N·m]", "top", "[pps]",
                                "[rpm]", "source", "description"]
    rows = {(line.split()[0], line.split()[5]): line for line in lines[1:]}
    assert rows[("nema17-1600", ENV_VAR)].split()[1:5] == ["400", "≈0.4", "48000", "7200"]
    assert "bundled (shadowed by STEPRAMP_MOTORS)" in rows[("nema17-1600", "bundled")]
    assert rows[("nema17-1600", "bundled")].split()[1:5] == ["1600", "0.45", "48000", "1800"]
    assert "unreadable: format: expected" in next(v for k, v in rows.items() if k[0] == "broken")
    assert not any(k[0] == "settings" for k in rows)
    assert lines[-1].startswith("≈: the pull-out torque at 0 pps")
    for column in ("steps/rev", "holding [N·m]", "top [pps]", "[rpm]"):  # numbers: right
        end = lines[0].index(column) + len(column)
        assert all(line[end - 1] != " " and line[end] == " " for line in lines[1:-1]), column
    assert cli.main(["motor", "list", "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    first = doc["motors"][0]
    assert (first["name"], first["source"], first["steps_per_rev"]) == ("nema17-1600", ENV_VAR,
                                                                        400)
    assert first["holding_from"] == "pullout_torque at 0 pps"


def test_motor_show_text(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["motor", "show", "nema23-heavy"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "nema23-heavy: NEMA23 1.9 N·m, half step, heavy rotary table"
    assert lines[1].startswith("file: ") and lines[1].endswith("motor-nema23-heavy.json "
                                                                "(bundled)")
    assert lines[4] == ("axis: rotary (no travel_mm_per_rev): lengths in rev, speeds in rpm; "
                        "top 1800 rpm")
    assert lines[5].split() == ["speed", "[pps]", "[rpm]", "pull-out", "[N·m]", "×", "0.6",
                                "[N·m]", "a_acc", "[pps²]", "a_dec", "[pps²]"]
    motor = load_motor("nema23-heavy")
    rows = [line.split() for line in lines[6:]]
    assert [float(r[0]) for r in rows] == list(motor.curve_speed_pps)
    # a_acc(0) = (0.6·1.9 − 0.2) / 4.8e-4 · 400 / 2π = 124 680 pps²
    assert float(rows[0][4]) == pytest.approx(124_680, rel=1e-3)
    assert float(rows[-1][1]) == pytest.approx(12000 * 60 / 400)


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
