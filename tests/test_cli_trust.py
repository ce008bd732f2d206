"""Item 5 of issue 10, "a CLI people trust": --version, help and units on every
option, clock names in any case, `show`, `plan --kind`, messages in option/field
terms, progress bars on a terminal only."""

from __future__ import annotations

import argparse
import csv
import io
import json
import re
import sys
from importlib.metadata import version
from pathlib import Path

import pytest

from profiles.ppmc312.ascii import decode_serial_init
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.init_model import expand_init
from profiles.ppmc312.table import FreeCurveTable, InitTable, load_table
from verify import cli
from verify.cli import _common

ROOT = Path(__file__).resolve().parent.parent
MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"
INIT = ROOT / "examples" / "init-linear.json"


def run(capsys: pytest.CaptureFixture[str], *argv: str | Path) -> tuple[int, str, str]:
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


# --- --version, help, units ------------------------------------------------------------------

def test_version_is_the_package_metadata(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "--version")
    assert code == 0 and out == f"stepramp {version('stepramp')}\n"


def _parsers(parser: argparse.ArgumentParser, name: str = "stepramp"
             ) -> list[tuple[str, argparse.ArgumentParser]]:
    out = [(name, parser)]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                out += _parsers(sub, f"{name} {sub_name}")
    return out


def _arguments() -> list[tuple[str, argparse.Action]]:
    return [(name, a) for name, p in _parsers(cli.build_parser()) for a in p._actions
            if not isinstance(a, argparse._SubParsersAction | argparse._HelpAction)]


def test_every_option_and_argument_has_help() -> None:
    missing = [f"{name} {a.option_strings or a.dest}" for name, a in _arguments()
               if not a.help or a.help == argparse.SUPPRESS]
    assert not missing, f"arguments without help: {missing}"
    assert len(_arguments()) > 60  # the walk found the sub-commands' options


# motor new's datasheet options add N·m, A, Ω, mH, V, g·cm², ° and [1] (a ratio); mc200
# stream's torque constant N·m/A
UNIT = re.compile(r"\[(pps|pps²|pps³|s|ms|µs|Hz|pulses|N·m|N·m/A|N·cm|A|Ω|mH|V|g·cm²|°|1|mm|rev)\]")


def test_every_quantity_option_names_its_unit() -> None:
    # Number-typed options and those named for a unit are quantities: their help
    # says the unit in brackets, spelled one way.
    quantity = [(name, a) for name, a in _arguments()
                if a.type is _common.number
                or any(re.search(r"(pps|-us|-hz|pulses)$", o) for o in a.option_strings)]
    assert len(quantity) >= 10
    lacking = [f"{name} {a.option_strings}" for name, a in quantity
               if not UNIT.search(a.help or "")]
    assert not lacking, f"quantity options whose help has no [unit]: {lacking}"


def test_units_are_spelled_one_way_in_help() -> None:
    text = " ".join(a.help or "" for _, a in _arguments())
    for wrong in ("pps/s", "pps/s²", "pps^2", "a_pps2]", " sec"):
        assert wrong not in text


# --- clocks in any case -------------------------------------------------------------------

@pytest.mark.parametrize("typed", ["8mhz", "8MHZ", "62.5khz", "15.625 kHz"])
def test_clock_names_any_case(typed: str) -> None:
    assert Clock.named(typed) == Clock.internal(
        next(n for n in ("8MHz", "62.5kHz", "15.625kHz") if n.lower() == typed.replace(
            " ", "").lower()))


def test_cli_clock_any_case_and_error_lists_names(capsys: pytest.CaptureFixture[str],
                                                  tmp_path: Path) -> None:
    out = tmp_path / "t.json"
    code, _, _ = run(capsys, "plan", "--motor", MOTOR, "--clock", "8mhz", "--max-stages", "20",
                     "-o", out)
    assert code == 0 and load_table(out).clock == Clock.internal("8MHz")
    code, _, err = run(capsys, "plan", "--motor", MOTOR, "--clock", "9mhz")
    assert code == 2
    assert all(n in err for n in ("8MHz", "1MHz", "500kHz", "250kHz", "62.5kHz", "15.625kHz"))
    assert "Traceback" not in err


def test_decode_table_read_clock_any_case(capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path) -> None:
    read = ROOT / "examples" / "free-curve-nema17.read.hex"
    code, out, _ = run(capsys, "decode", read, "--table-read", "--clock", "8mhz")
    assert code == 0 and '"8MHz"' in out
    code, _, err = run(capsys, "decode", read, "--table-read", "--clock", "extck")
    assert code == 2 and "--extck-hz" in err


# --- show --------------------------------------------------------------------------------------

# 1 MHz, rates 100..400 (10 000 .. 2 500 pps); accel 10/20/30/40 pulses, decel 5/5/5 on
# the three fastest stages. By hand: accel stage k lasts pulses × rate µs.
SHOWN = FreeCurveTable(Clock.internal("1MHz"), (100, 200, 300, 400), (10, 20, 30, 40),
                       (5, 5, 5))
BY_HAND = [  # slowest first: stage, speed_pps, accel ms, accel cum ms, decel ms, decel cum ms
    (3, 2500.0, 16.0, 16.0, None, None),
    (2, 1e6 / 300, 9.0, 25.0, 1.5, 1.5),
    (1, 5000.0, 4.0, 29.0, 1.0, 2.5),
    (0, 10000.0, 1.0, 30.0, 0.5, 3.0),
]


def _shown_file(tmp_path: Path) -> Path:
    path = tmp_path / "shown.json"
    path.write_text(json.dumps(SHOWN.to_json()))
    return path


def test_show_json_matches_hand_numbers(capsys: pytest.CaptureFixture[str],
                                        tmp_path: Path) -> None:
    code, out, _ = run(capsys, "show", _shown_file(tmp_path), "--format", "json",
                       "--motor", MOTOR)
    assert code == 0
    doc = json.loads(out)
    assert doc["modelled"] is False and doc["kind"] == "free_curve"
    assert doc["accel_s"] == pytest.approx(0.030) and doc["decel_s"] == pytest.approx(0.003)
    rows = doc["stages"]
    assert [r["stage"] for r in rows] == [3, 2, 1, 0]
    for row, (stage, v, acc, acc_cum, dec, dec_cum) in zip(rows, BY_HAND, strict=True):
        assert row["rate"] == SHOWN.rates[stage]
        assert row["speed_pps"] == pytest.approx(v)
        assert row["speed_rpm"] == pytest.approx(v * 60 / 1600)  # nema17: 1600 steps/rev
        assert row["accel_pulses"] == SHOWN.accel_pulses[stage]
        assert row["accel_s"] == pytest.approx(acc / 1e3)
        assert row["accel_cum_s"] == pytest.approx(acc_cum / 1e3)
        if dec is None:
            assert row["decel_pulses"] is None and row["decel_s"] is None
        else:
            assert row["decel_s"] == pytest.approx(dec / 1e3)
            assert row["decel_cum_s"] == pytest.approx(dec_cum / 1e3)


def test_show_json_is_byte_stable() -> None:
    """The listing's JSON text, whole: users keep it in their repositories and diff it in
    CI, so its layout (keys in order, one-space indent, a final newline) is pinned."""
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.listing import list_stages
    from profiles.ppmc312.table import FreeCurveTable

    table = FreeCurveTable(Clock.internal("8MHz"), (4000,), (10,), None)
    fields = ('"stage": 0', '"rate": 4000', '"speed_pps": 2000.0', '"speed_rpm": null',
              '"accel_pulses": 10', '"accel_s": 0.005', '"accel_cum_s": 0.005',
              '"decel_pulses": 10', '"decel_s": 0.005', '"decel_cum_s": 0.005')
    head = ('"kind": "free_curve"', '"modelled": false', '"clock": "8MHz"',
            '"separate_decel": false', '"accel_pulses": 10', '"decel_pulses": 10',
            '"accel_s": 0.005', '"decel_s": 0.005')
    expected = ("{\n" + "".join(f" {f},\n" for f in head) + ' "stages": [\n  {\n'
                + ",\n".join(f"   {f}" for f in fields) + "\n  }\n ]\n}\n")
    assert list_stages(table).render("json") == expected


def test_show_csv_and_text(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = _shown_file(tmp_path)
    code, out, _ = run(capsys, "show", path, "--format", "csv")
    assert code == 0
    rows = list(csv.DictReader(io.StringIO(out)))
    assert [int(r["stage"]) for r in rows] == [3, 2, 1, 0]
    assert rows[0]["speed_rpm"] == "" and rows[0]["decel_pulses"] == ""
    assert float(rows[1]["accel_cum_s"]) == pytest.approx(0.025)
    code, out, _ = run(capsys, "show", path)
    lines = out.splitlines()
    assert "clock 1MHz, 4 stages" in lines[0] and "accel 100 pulses in 30 ms" in lines[0]
    assert "decel 15 pulses in 3 ms" in lines[0]
    assert "speed [pps]" in lines[1] and "accel cum [ms]" in lines[1]
    assert lines[2].split() == ["3", "400", "2500", "40", "16", "16", "-", "-", "-"]
    assert lines[-1].split() == ["0", "100", "10000", "10", "1", "30", "5", "0.5", "3"]


def test_show_accel_time_is_what_the_chip_runs() -> None:
    from profiles.ppmc312.execution import simulate_move
    from profiles.ppmc312.listing import list_stages

    table = load_table(ROOT / "examples" / "free-curve-nema17.json")
    run_ = simulate_move(table, 100_000)  # long enough to cruise: full ramps
    accel_ticks = sum(s.end_tick - s.start_tick for s in run_.segments if s.phase == "accel")
    assert list_stages(table).accel_s == pytest.approx(accel_ticks / table.clock.hz,
                                                       rel=1e-12)


def test_show_init_table_lists_the_model_and_says_so(capsys: pytest.CaptureFixture[str]
                                                     ) -> None:
    code, out, _ = run(capsys, "show", INIT, "--format", "json")
    assert code == 0
    doc = json.loads(out)
    model = expand_init(load_table(INIT))  # type: ignore[arg-type]
    assert doc["modelled"] is True and doc["init"]["shape"] == "linear"
    assert [r["rate"] for r in doc["stages"]] == list(model.rates[::-1])
    _, text, _ = run(capsys, "show", INIT)
    assert "modelled" in text.splitlines()[2]


def test_show_bad_input_is_one_line(capsys: pytest.CaptureFixture[str], tmp_path: Path
                                    ) -> None:
    code, _, err = run(capsys, "show", tmp_path / "none.json")
    assert code == 2 and len(err.strip().splitlines()) == 1


# --- plan --kind ------------------------------------------------------------------------------

@pytest.mark.slow  # plan --kind end-to-end (the init planner's search); CI runs it
@pytest.mark.parametrize(("kind", "shape"), [("linear", "linear"), ("s-curve", "s_curve")])
def test_plan_init_table_exports_as_ascii(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                          kind: str, shape: str) -> None:
    from profiles.ppmc312.execution import simulate_move

    out = tmp_path / "init.json"
    code, summary, _ = run(capsys, "plan", "--motor", MOTOR, "--kind", kind, "--pulses",
                           "4000", "--format", "json", "-o", out)  # with -o: summary on stdout
    assert code == 0
    doc = json.loads(summary)
    table = load_table(out)
    assert isinstance(table, InitTable) and table.shape == shape and not table.separate
    assert doc["kind"] == kind and doc["pulses"] == 4000
    # the summary's time is the modelled move of the written table
    assert doc["move_time_s"] == simulate_move(table, 4000).duration_s
    # the CLI checks it clean with the motor, and exports it as an ASCII init frame
    assert run(capsys, "check", out, "--motor", MOTOR)[0] == 0
    code, frame_hex, _ = run(capsys, "export", out, "--to", "ascii", "--address", "2")
    assert code == 0
    assert decode_serial_init(bytes.fromhex(frame_hex.splitlines()[0])) == table


def test_plan_kind_refusals_name_the_options(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "plan", "--motor", MOTOR, "--kind", "linear")
    assert code == 2 and "--pulses" in err
    code, _, err = run(capsys, "plan", "--motor", MOTOR, "--kind", "s-curve", "--pulses", "9",
                       "--from", "ruckig")
    assert code == 2 and "--from" in err
    code, _, err = run(capsys, "plan", "--motor", MOTOR, "--kind", "linear", "--pulses", "9",
                       "--max-stages", "3")
    assert code == 2 and "--max-stages" in err


# --- messages in option/field terms -----------------------------------------------------------

T = str(ROOT / "examples" / "free-curve-nema17.json")
READ = str(ROOT / "examples" / "free-curve-nema17.read.hex")


@pytest.mark.parametrize(("argv", "option"), [
    (["mc200", "stream", "--vmax", "-1", "--amax", "1", "--jmax", "1", "--pulses", "100",
      "--period-us", "1000"], "--vmax"),
    (["mc200", "stream", "--vmax", "1e3", "--amax", "1e4", "--jmax", "1e5", "--pulses", "100",
      "--period-us", "1"], "--period-us"),
    (["mc200", "stream", "--vmax", "1e3", "--amax", "1e4", "--jmax", "1e5", "--pulses", "100",
      "--period-us", "1000", "--driver-id", "99"], "--driver-id"),
    (["move", "--pulses", "0"], "--pulses"),
    (["move", "--pulses", "5", "--to", "ascii", "--address", "99"], "--address"),
    (["export", T, "--max-block-data", "99"], "--max-block-data"),
    (["simulate", T, "--pulses", "100", "--high-rate", "3"], "--high-rate"),
    (["simulate", T, "--pulses", "0"], "--pulses"),
    (["plan", "--motor", str(MOTOR), "--max-stages", "1"], "--max-stages"),
    (["alink", "settings", "--start-pps", "0", "--high-pps", "100",
      "--accel-ms-per-kpps", "1"], "--start-pps"),
    (["alink", "settings", "--start-pps", "100", "--high-pps", "1000",
      "--accel-ms-per-kpps", "-1"], "--accel-ms-per-kpps"),
    (["alink", "settings", "--motor", str(MOTOR), "--address", "99"], "--address"),
    (["decode", READ, "--table-read", "--clock", "EXTCK", "--extck-hz", "-5"], "--extck-hz"),
])
def test_range_errors_name_the_option_typed(capsys: pytest.CaptureFixture[str],
                                            argv: list[str], option: str) -> None:
    code, _, err = run(capsys, *argv)
    assert code == 2
    [line] = err.strip().splitlines()
    assert line.startswith(f"stepramp {argv[0]}: {option}") and "allowed range" in line


def test_too_many_pulse_times_speaks_of_pulses(capsys: pytest.CaptureFixture[str],
                                               tmp_path: Path) -> None:
    code, _, err = run(capsys, "simulate", ROOT / "examples" / "free-curve-nema17.json",
                       "--pulses", "10000001", "--pulse-times", tmp_path / "p.csv")
    assert code == 2 and "pulses (one CSV row per pulse)" in err
    assert "limit=" not in err and "_s:" not in err
    assert not (tmp_path / "p.csv").exists()


def test_safety_factor_range_in_words(capsys: pytest.CaptureFixture[str],
                                      tmp_path: Path) -> None:
    doc = json.loads(MOTOR.read_text())
    doc["safety_factor"] = 0
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc))
    code, _, err = run(capsys, "show", INIT, "--motor", path)
    assert code == 2
    assert "safety_factor: 0.0 is outside the allowed range above 0 up to 1" in err


# --- progress bars --------------------------------------------------------------------------

class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_only_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_common, "PROGRESS_DELAY_S", 0.0)
    pipe = io.StringIO()
    monkeypatch.setattr(sys, "stderr", pipe)
    with _common.progress_bar("work") as progress:
        assert progress is None
    assert pipe.getvalue() == ""
    tty = _Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    with _common.progress_bar("work", unit="packet") as progress:
        assert progress is not None
        progress(0, 40)
        progress(40, 40)
    assert "work" in tty.getvalue() and "40/40" in tty.getvalue()


def test_mc200_stream_draws_a_bar_on_a_terminal(monkeypatch: pytest.MonkeyPatch,
                                                tmp_path: Path) -> None:
    monkeypatch.setattr(_common, "PROGRESS_DELAY_S", 0.0)
    tty = _Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    out = tmp_path / "s.hex"
    assert cli.main(["mc200", "stream", "--vmax", "20000", "--amax", "2e5", "--jmax", "5e6",
                     "--pulses", "3200", "--period-us", "1000", "-o", str(out)]) == 0
    lines = [line for line in out.read_text().splitlines() if not line.startswith("#")]
    assert "encode packets" in tty.getvalue() and f"{len(lines)}/{len(lines)}" in tty.getvalue()


# --- the package: one module per command, registered once; notebooks openable ----------------

def test_every_command_module_is_registered_and_imports_no_sibling() -> None:
    package = ROOT / "verify" / "cli"
    modules = {f.stem for f in package.glob("*.py") if not f.stem.startswith("_")}
    assert set(cli.COMMANDS) == modules
    for name in modules:
        source = (package / f"{name}.py").read_text(encoding="utf-8")
        siblings = re.findall(r"from (?:verify\.cli)?\.(\w+) import|from verify\.cli import",
                              source)
        assert all(s == "_common" for s in siblings), (name, siblings)
        assert "def add_subparser(sub" in source


def test_dev_install_opens_notebooks() -> None:
    import tomllib

    dev = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["dev"]
    assert any(d.startswith(("jupyterlab", "notebook")) for d in dev)
    assert "jupyter lab notebooks/" in (ROOT / "README.md").read_text(encoding="utf-8")
    import importlib.util

    assert importlib.util.find_spec("jupyterlab") is not None  # installed by the [dev] extra


def _shape(parser: argparse.ArgumentParser) -> list[tuple[str, tuple[str, ...], str | None]]:
    return [(name, tuple(a.option_strings) or (a.dest,), a.help)
            for name, p in _parsers(parser) for a in p._actions]


@pytest.mark.parametrize("command", cli.COMMANDS)
def test_one_commands_parser_is_its_branch_of_the_whole(command: str) -> None:
    # main() builds only the branch its command line names (a cold start pays for one
    # command's imports); that branch must be the whole parser's, option for option
    whole = [row for row in _shape(cli.build_parser())
             if row[0].startswith(f"stepramp {command}")]
    alone = _shape(cli.build_parser(command))
    assert [row for row in alone if row[0] != "stepramp"] == whole
    assert len(whole) > 1


def test_an_unknown_or_missing_command_builds_every_branch() -> None:
    for named in (None, "no-such-command", "--version"):
        [sub] = [a for a in cli.build_parser(named)._actions
                 if isinstance(a, argparse._SubParsersAction)]
        assert tuple(sub.choices) == cli.COMMANDS
    assert cli._command_named(["--debug", "check"]) is None
    assert cli._command_named(["check", "--motor", "x"]) == "check"


@pytest.mark.parametrize(("given", "expected"), [(None, "1"), ("4", "4")])
def test_the_command_starts_openblas_with_one_thread_unless_told(given: str | None,
                                                                 expected: str) -> None:
    import os
    import subprocess

    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if given is not None:
        env["OPENBLAS_NUM_THREADS"] = given
    probe = ("import sys, os; import verify.cli; loaded = 'numpy' in sys.modules; "
             "print(os.environ['OPENBLAS_NUM_THREADS'], loaded)")
    out = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    assert out == [expected, "False"]  # set before any command loads numpy


@pytest.mark.parametrize("debug", [False, True])
def test_an_internal_error_is_one_line_unless_debug_shows_the_traceback(
        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch,
        debug: bool) -> None:
    """A bug (an unexpected exception) is exit 2 and one line naming it, never exit 1;
    `--debug`, anywhere on the command line, adds the Python traceback."""
    from verify.cli import check

    def broken(args: object) -> int:
        raise RuntimeError("a bug")

    real = check.add_subparser

    def add(sub: object) -> None:
        real(sub)
        sub.choices["check"].set_defaults(func=broken)  # type: ignore[attr-defined]

    monkeypatch.setattr(check, "add_subparser", add)
    argv = ["check", str(ROOT / "examples" / "free-curve-nema17.json")]
    code = cli.main([*argv, "--debug"] if debug else argv)
    err = capsys.readouterr().err
    assert code == 2 and "internal error (RuntimeError: a bug)" in err
    assert ("Traceback (most recent call last)" in err) == debug


def test_a_pulse_list_is_every_length_given_in_order() -> None:
    """--pulses N[,M…]: each length kept, spaces allowed, 1..2³²−1 (a move counter)."""
    assert _common.pulse_list("1000, 3000,10000") == [1000, 3000, 10000]
    assert _common.pulse_list("4294967295") == [4294967295]
    for bad in ("0", "4294967296", "1000,", "1000,x"):
        with pytest.raises(argparse.ArgumentTypeError):
            _common.pulse_list(bad)


def test_main_reads_the_command_line_after_the_program_name(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """`stepramp` (the console script) calls main() with no arguments: sys.argv[1:]."""
    monkeypatch.setattr(sys, "argv", ["stepramp", "--version"])
    assert cli.main() == 0
    assert capsys.readouterr().out.strip() == f"stepramp {version('stepramp')}"


def test_top_level_help_lists_debug(capsys: pytest.CaptureFixture[str]) -> None:
    """--debug works anywhere on the line (it is taken out before parsing), and the help
    says it exists."""
    assert cli.main(["--help"]) == 0
    assert "--debug" in capsys.readouterr().out
