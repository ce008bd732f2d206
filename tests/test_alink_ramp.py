"""The A-Link unit's ramp on the load angle (issue 33 items 1–2): the stage model
(profiles/alink/ramp.py) against a plain-Python stepping of the unit, the one verdict
(verify.safety.judge_safety) against the plain-Python rotor oracle on sampled moves, planned
settings within the aim at every move length, and `check SETTINGS --motor`."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from profiles.alink.model import quantise_settings
from profiles.alink.planner import Judgement, tighten_settings
from profiles.alink.ramp import RAMP_HZ, build_ramp, parts, ramp_of, segments
from profiles.errors import PlanError
from profiles.motor import load_motor
from profiles.motor.catalogue import resolve
from profiles.motor.rotor import rotor_of, settle_s
from tests.rotor_oracle import follow
from verify import cli
from verify.safety import judge_safety

DATASHEET = ["motor", "new", "--holding-torque-nm", "0.59", "--rated-current-a", "2",
             "--resistance-ohm", "1.4", "--inductance-mh", "3.0", "--rotor-inertia-gcm2", "82",
             "--supply-v", "24", "--microstep", "8", "--current-a", "1.5",
             "--load", "screw:lead_mm=8,mass_kg=4"]


def stepped(start: float, high: float, accel: float, m: int, shape: str, n: int
            ) -> list[float]:
    """The unit stepped pulse by pulse, independently of the model's arrays: each pulse
    lasts one period of the speed step in force when it begins; a move of n pulses runs
    the first ⌈n/2⌉ pulses of the ramp up and the first ⌊n/2⌋ reversed down (or the
    whole ramp, a cruise at `high`, the ramp reversed). Returns each pulse's speed."""
    steps = int((high - start) // m)
    ramp_s = (high - start) / accel

    def speed(t: float) -> float:
        if shape == "linear":
            k = math.floor(accel * t / m + 1e-9)
        else:
            x = (1 - math.cos(math.pi * min(t, ramp_s) / ramp_s)) / 2 if ramp_s else 1.0
            k = math.floor(x * steps + 1e-9)
        return start + min(k, steps) * m

    ramp: list[float] = []
    t = 0.0
    top = start + steps * m
    while steps and len(ramp) < n:
        v = speed(t)
        if v >= top:
            break
        ramp.append(v)
        t += 1 / v
    if n >= 2 * len(ramp):
        return ramp + [high] * (n - 2 * len(ramp)) + ramp[::-1]
    return ramp[:(n + 1) // 2] + ramp[:n // 2][::-1]


def oracle_deg(motor_path: Path | str, speeds: list[float]) -> float:
    """The worst |load angle| [electrical °] of a pulse train, by the plain-Python rotor."""
    rotor = rotor_of(load_motor(motor_path))
    spans: list[tuple[float, float]] = []
    for v in speeds:
        if spans and spans[-1][1] == v:
            spans[-1] = (spans[-1][0] + 1 / v, v)
        else:
            spans.append((1 / v, v))
    step = rotor.step_s()
    spans.append((settle_s(rotor, step), 0.0))
    trace = follow(rotor, spans, step_s=step)
    return math.degrees(max(abs(x) for x in trace.lag) * rotor.c_e)


@pytest.mark.parametrize("shape", ["linear", "s_curve"])
def test_stages_are_the_stepped_unit(shape: str) -> None:
    """A ramp of at most 250 speed steps: the model's pulses are the stepped unit's, pulse
    for pulse, for triangles, the move just reaching the top and a trapezoid."""
    ramp = build_ramp(400, 2000, 40_000.0, 10, shape)  # 160 steps
    assert ramp.steps == 160
    for n in (1, 2, 7, 30, 2 * ramp.ramp_pulses - 1, 2 * ramp.ramp_pulses,
              2 * ramp.ramp_pulses + 13):
        rate, count, _ = segments(ramp, parts(ramp, "move", np.array([n])))
        model = np.repeat(RAMP_HZ / rate.astype(float), count)
        unit = stepped(400, 2000, 40_000.0, 10, shape, n)
        assert len(model) == n == len(unit)
        np.testing.assert_allclose(model, unit, rtol=1e-6)


def test_decel_stop_runs_the_ramp_down_from_its_stage() -> None:
    ramp = build_ramp(400, 2000, 40_000.0, 10, "linear")
    ends = np.cumsum(ramp.pulses)
    x = int(ends[5]) + 1   # the first pulse of stage 6
    p = parts(ramp, "stop", np.array([x]))
    assert (int(p.up[0]), int(p.middle[0]), int(p.down[0])) == (x, 0, int(ends[6]))


@pytest.mark.parametrize("shape", ["linear", "s_curve"])
def test_verdict_against_the_oracle_on_sampled_moves(shape: str) -> None:
    """judge_safety on the model's moves against the plain-Python stepping and rotor, on
    moves of every shape: exact ramps (≤ 250 steps) agree to 0.5°, a fine ramp judged as
    250 stages to 3° (tests the grouping the model documents)."""
    motor = resolve("nema17-1600")
    cases = [(800, 6000, 150_000.0, 20, (3, 40, 101, 300)),       # 260 → grouped
             (800, 4000, 150_000.0, 20, (5, 64, 200))]            # 160 steps: exact
    for start, high, accel, m, lengths in cases:
        ramp = build_ramp(start, high, accel, m, shape)
        tol = 0.5 if ramp.steps <= 250 else 3.0
        for n in lengths:
            verdict = judge_safety(ramp, load_motor(motor), pulses=[n])
            assert verdict.load_angle is not None
            want = oracle_deg(motor, stepped(start, high, accel, m, shape, n))
            assert verdict.load_angle.worst_deg == pytest.approx(want, abs=tol), (n, ramp)


def run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = cli.main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def datasheet_motor(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("motor") / "m.json"
    assert cli.main([*DATASHEET, "--output", str(path)]) == 0
    return path


@pytest.mark.parametrize(("name", "extra"), [
    ("nema17-1600", ()), ("nema23-heavy", ()), ("pk566-5phase-half", ()), ("datasheet", ()),
    ("datasheet", ("--s-curve",)), ("datasheet", ("--pulses", "400"))])
def test_planned_settings_within_the_aim_at_every_length(
        name: str, extra: tuple[str, ...], datasheet_motor: Path, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    motor = str(datasheet_motor) if name == "datasheet" else name
    out = tmp_path / "s.json"
    code, _, _ = run(capsys, "alink", "settings", "--motor", motor, "--format", "json",
                     "-o", str(out), *extra)
    assert code == 0
    code, report, _ = run(capsys, "check", str(out), "--motor", motor, "--format", "json")
    assert code == 0, report
    safety = json.loads(report)["files"][0]["safety"] if "files" in json.loads(report) \
        else json.loads(report)[0]["safety"]
    assert safety["moves"] == "every" and safety["safe"] and safety["within_aim"]
    assert safety["worst_load_angle_deg"] <= 75.0
    assert "decel-stop" in safety["commands"]


def test_datasheet_settings_lower_the_start_and_say_the_price(
        datasheet_motor: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The issue's case: the untightened start (5 540 pps) leaves short moves past 75°."""
    out = tmp_path / "s.txt"
    code, _, _ = run(capsys, "alink", "settings", "--motor", str(datasheet_motor),
                     "-o", str(out))
    assert code == 0
    text = out.read_text()
    assert "start speed lowered to" in text and "within 75°" in text
    assert "a move of 100 pulses takes" in text


def test_check_motor_exits_1_on_an_unsafe_hand_written_file(
        datasheet_motor: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "hand.txt"
    assert run(capsys, "alink", "settings", "--start-pps", "8000", "--high-pps", "25000",
               "--accel-ms-per-kpps", "0.5", "-o", str(out))[0] == 0
    code, report, _ = run(capsys, "check", str(out), "--motor", str(datasheet_motor))
    assert code == 1
    assert "[stall-start-speed]" in report and "[load-angle]" in report
    code, report, _ = run(capsys, "check", str(out))  # without a motor: the unit's rules only
    assert code == 0 and "load-angle" not in report


def test_nothing_safe_names_what_would_help() -> None:
    motor = load_motor(resolve("nema17-1600"))
    settings = quantise_settings(800, 20000, 5.0)

    def never(_: object) -> Judgement:
        return Judgement(False, 120.0, "start", "a move of 3 pulses")

    with pytest.raises(PlanError, match=r"lower speed limit.*less load inertia.*higher drive"):
        tighten_settings(motor, settings, never, aim_deg=75.0)


def test_ramp_of_settings_uses_the_multiplier() -> None:
    ramp = ramp_of(quantise_settings(800, 20000, 5.0, s_curve=True))
    assert ramp.multiplier == 10 and ramp.shape == "s_curve"
    assert ramp.speeds_pps[0] == 800 and ramp.speeds_pps[-1] < 20000


def test_simulate_settings_shows_the_units_move(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """`simulate SETTINGS --pulses N`: the model's move, its pulse times in the CSV."""
    path = tmp_path / "s.txt"
    assert run(capsys, "alink", "settings", "--start-pps", "800", "--high-pps", "20000",
               "--accel-ms-per-kpps", "5", "-o", str(path))[0] == 0
    times = tmp_path / "t.csv"
    code, out, _ = run(capsys, "simulate", str(path), "--pulses", "101", "--pulse-times",
                       str(times))
    assert code == 0 and "shape: triangle" in out and "up 51" in out and "down 50" in out
    rows = times.read_text().splitlines()
    assert rows[0] == "pulse,time_s" and len(rows) == 102
    speeds = stepped(800, 20000, 200_000.0, 10, "linear", 101)
    # 1920 speed steps judged as 241 stages: the stepped unit's time within 0.1 %
    assert float(rows[-1].split(",")[1]) == pytest.approx(sum(1 / v for v in speeds), rel=1e-3)
    code, out, _ = run(capsys, "simulate", str(path), "--pulses", "5000", "--format", "json")
    doc = json.loads(out)
    assert code == 0 and doc["shape"] == "trapezoid" and doc["peak_pps"] == pytest.approx(20000)
    assert sum(s["pulses"] for s in doc["segments"]) == 5000
    code, _, err = run(capsys, "simulate", str(path), "--pulses", "10", "--samples", "x.csv")
    assert code == 2 and "--samples" in err


def test_check_json_is_the_tables_verdict_shape(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """The same verdict object as a PPMC-312 table's (`--format json`)."""
    path = tmp_path / "s.txt"
    assert run(capsys, "alink", "settings", "--start-pps", "800", "--high-pps", "20000",
               "--accel-ms-per-kpps", "5", "-o", str(path))[0] == 0
    _, report, _ = run(capsys, "check", str(path), "examples/free-curve-nema17.json",
                          "--motor", "nema17-1600", "--format", "json")
    doc = json.loads(report)
    files = doc["files"] if isinstance(doc, dict) else doc
    ramp, table = files[0]["safety"], files[1]["safety"]
    assert set(ramp) == set(table)
    assert ramp["moves"] == "every" and ramp["safe"] in (True, False)


def test_homing_legs_are_judged_and_a_fast_origin_stop_fails() -> None:
    """A search stopping at once from OH far above the self-start speed slips; within it,
    the homing legs are within the aim (the bundled NEMA17: self-start 800 pps)."""
    from profiles.alink.homing import HomingSettings

    motor = load_motor(resolve("nema17-1600"))
    ramp = ramp_of(quantise_settings(800, 20000, 5.0))
    fast = judge_safety(ramp, motor, homing=HomingSettings(1000, 20000, 200))
    rules = {f.rule for f in fast.findings()}
    assert {"stall-start-speed", "alink-homing-load-angle"} <= rules and not fast.safe
    slow = judge_safety(ramp, motor, homing=HomingSettings(200, 800, 200))
    assert dict(slow.commands)["homing"].within_aim and slow.safe


def test_tighten_homing_lowers_oh_until_the_judge_agrees() -> None:
    from profiles.alink.homing import HomingSettings, tighten_homing

    motor = load_motor(resolve("nema17-1600"))

    def below_500(h: HomingSettings) -> Judgement:
        return Judgement(h.oh_pps <= 500, 80.0 if h.oh_pps > 500 else 60.0, "start", "")

    h, verdict, price = tighten_homing(motor, HomingSettings(200, 800, 200), below_500,
                                       aim_deg=75.0)
    assert h.oh_pps <= 500 and h.oh_pps % 20 == 0 and h.ol_pps <= h.oh_pps
    assert verdict.within_aim and "origin high speed lowered to" in price
    with pytest.raises(PlanError, match="higher drive current"):
        tighten_homing(motor, HomingSettings(200, 800, 200),
                       lambda h: Judgement(False, 99.0, "start", ""), aim_deg=75.0)


def test_sync_axis_verdict_carries_the_ramps_verdict() -> None:
    """sync's report on an A-Link axis: the planner's rule and the one verdict's JSON."""
    from types import SimpleNamespace

    from verify.devices.alink import axis_verdict

    motor = load_motor(resolve("nema17-1600"))
    safe, facts = axis_verdict(SimpleNamespace(settings=quantise_settings(800, 20000, 5.0),
                                               motor=motor))
    assert safe and facts["stall_safe"] and facts["safety"]["moves"] == "every"
    fast, facts = axis_verdict(SimpleNamespace(settings=quantise_settings(2000, 40000, 0.1),
                                               motor=motor))
    assert not fast and not facts["safety"]["safe"]


def test_triangle_avoidance_runs_a_third_at_the_speed_reached() -> None:
    ramp = build_ramp(400, 20000, 40_000.0, 10, "linear", triangle_avoidance=True)
    p = parts(ramp, "move", np.array([31, 3 * ramp.ramp_pulses + 5]))
    assert (p.up.tolist(), p.middle.tolist(), p.down.tolist()) == (
        [10, ramp.ramp_pulses], [11, ramp.ramp_pulses + 5], [10, ramp.ramp_pulses])


def test_decel_stop_against_the_oracle() -> None:
    """A decel stop from pulse x of the ramp: the stepped unit's first x pulses, then its
    ramp reversed from the stage x is in, judged as the verdict's stop family is."""
    from verify.alink_safety import motion_angles, nominal_rotors

    motor = resolve("nema17-1600")
    ramp = build_ramp(800, 4000, 150_000.0, 20, "linear")   # 160 steps: exact stages
    ends = np.cumsum(ramp.pulses)
    unit = stepped(800, 4000, 150_000.0, 20, "linear", 2 * ramp.ramp_pulses)
    unit_ramp = unit[:ramp.ramp_pulses]
    for x in (3, int(ends[40]) + 1, ramp.ramp_pulses - 2):
        stage_end = int(ends[np.searchsorted(ends, x)])
        speeds = unit_ramp[:x] + unit_ramp[:stage_end][::-1]
        found = motion_angles(ramp, "stop", nominal_rotors(load_motor(motor)), [x])
        assert float(found.deg.max()) == pytest.approx(oracle_deg(motor, speeds), abs=0.5)


def test_a_cruise_in_a_resonance_band_is_a_dwell() -> None:
    from dataclasses import replace

    motor = replace(load_motor(resolve("nema17-1600")),
                    resonance_bands_pps=((19000.0, 21000.0),))
    inside = judge_safety(ramp_of(quantise_settings(800, 20000, 5.0)), motor,
                          load_angle=False)
    assert [f.rule for f in inside.resonance] == ["resonance-dwell"]
    assert inside.resonance[0].severity == "warning"
    strict = judge_safety(ramp_of(quantise_settings(800, 20000, 5.0)), motor,
                          load_angle=False, strict=True)
    assert not strict.safe
    outside = judge_safety(ramp_of(quantise_settings(800, 25000, 5.0)), motor,
                           load_angle=False)
    assert not outside.resonance   # the ramp crosses the band: no finding
