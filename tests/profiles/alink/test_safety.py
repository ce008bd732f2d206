"""profiles.alink.safety: the A-Link ramp's one verdict against the plain-Python rotor oracle
(tests/support/rotor_oracle.py) on sampled moves and decel stops, and its homing legs."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from profiles.alink.model import quantise_settings
from profiles.alink.ramp import build_ramp, ramp_of
from profiles.motor import load_motor
from profiles.motor.catalogue import resolve
from profiles.motor.rotor import rotor_of, settle_s
from tests.support.alink_oracle import stepped
from tests.support.rotor_oracle import follow
from verify.safety import judge_safety


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


def test_homing_legs_are_judged_and_a_fast_origin_stop_fails() -> None:
    """A search stopping at once from OH far above the self-start speed slips; within it,
    the homing legs are within the aim (the bundled NEMA17: self-start 800 pps)."""
    from profiles.alink.planner.homing import HomingSettings

    motor = load_motor(resolve("nema17-1600"))
    ramp = ramp_of(quantise_settings(800, 20000, 5.0))
    fast = judge_safety(ramp, motor, homing=HomingSettings(1000, 20000, 200))
    rules = {f.rule for f in fast.findings()}
    assert {"stall-start-speed", "alink-homing-load-angle"} <= rules and not fast.safe
    slow = judge_safety(ramp, motor, homing=HomingSettings(200, 800, 200))
    assert dict(slow.commands)["homing"].within_aim and slow.safe


def test_decel_stop_against_the_oracle() -> None:
    """A decel stop from pulse x of the ramp: the stepped unit's first x pulses, then its
    ramp reversed from the stage x is in, judged as the verdict's stop family is."""
    from profiles.alink.safety import motion_angles, nominal_rotors

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


def test_immediate_stops_report_the_fastest_speed_within_the_aim() -> None:
    """STOP 28 (and EL) from every pulse: safe when a stop from L is, its envelope the
    fastest speed whose stops (and every slower one's) stay within the aim, and a stop
    from H still reported; the worst at a speed is the worst of the stops at once up to
    it on the kernel."""
    from profiles.alink.safety import motion_angles, nominal_rotors, stop_envelope

    motor = load_motor(resolve("nema17-1600"))
    ramp = build_ramp(800, 48000, 147_059.0, 20, "linear")
    rot = nominal_rotors(motor)
    v = stop_envelope(ramp, rot, 75.0)
    assert v.safe and v.within_aim and v.top_deg > 90
    fast = v.reach(75.0)
    assert fast is not None and ramp.start_pps <= fast < ramp.high_pps
    assert v.top_deg == pytest.approx(float(motion_angles(ramp, "search", rot).deg.max()))
    env = v.to_json()["envelope"]
    assert env["fastest_pps"] == fast and env["top_pps"] == 48000
    above = [d for s, d in zip(v.speeds_pps, v.degs, strict=True) if s > fast]
    assert above and above[0] > 75.0


def test_change_speed_is_refused_in_s_curve_and_judged_both_readings_in_linear() -> None:
    """CHANGE_SPD: none to judge in S-curve (a Nak); in linear the change from the cruise
    at H to each speed up to the cap (2 × H without MAX_SPEED, else MAX_SPEED), the worse
    of at once and stepped."""
    from profiles.alink.safety import change_envelope, nominal_rotors

    motor = load_motor(resolve("nema17-1600"))
    rot = nominal_rotors(motor)
    s_curve = change_envelope(build_ramp(800, 4000, 20_000.0, 2, "s_curve"), rot, 75.0)
    assert s_curve.safe and s_curve.note and s_curve.executions == 0
    linear = change_envelope(build_ramp(800, 4000, 20_000.0, 2), rot, 75.0)
    assert max(linear.speeds_pps) == 8000 and linear.use_pps == 4000
    capped = change_envelope(build_ramp(800, 4000, 20_000.0, 2, max_pps=5000), rot, 75.0)
    assert max(capped.speeds_pps) == 5000
    j = linear.to_json()["envelope"]
    assert j["lowest_pps"] is not None and j["lowest_pps"] <= 4000 <= j["fastest_pps"]


def test_commands_narrow_the_units_families() -> None:
    """--commands with the unit's command names: the moves alone, STOP's two forms, and an
    unknown name refused before any work."""
    from profiles.errors import FormatError

    motor = load_motor(resolve("nema17-1600"))
    ramp = build_ramp(800, 4000, 20_000.0, 2)
    assert judge_safety(ramp, motor, samples=0, commands=["move-a"]).commands == ()
    names = [n for n, _ in judge_safety(ramp, motor, samples=0, commands=["stop"]).commands]
    assert names == ["decel-stop", "stop"]
    every = [n for n, _ in judge_safety(ramp, motor, samples=0).commands]
    assert every == ["decel-stop", "stop", "change-speed", "limit"]
    with pytest.raises(FormatError, match="accel"):
        judge_safety(ramp, motor, commands=["accel"])


def test_limit_runs_count_every_slower_run_and_fail_from_a_fast_start() -> None:
    """LIMIT at s: the worst of its runs up to s (cumulative); a start speed far above the
    motor's self-start speed leaves no safe limit run (EL stops at once from L)."""
    from profiles.alink.safety import limit_envelope, nominal_rotors

    motor = load_motor(resolve("nema17-1600"))
    rot = nominal_rotors(motor)
    ok = limit_envelope(build_ramp(800, 4000, 20_000.0, 2), rot, 75.0)
    assert list(ok.degs) == sorted(ok.degs) and ok.safe
    bad = limit_envelope(build_ramp(20_000, 22_000, 20_000.0, 20), rot, 75.0)
    assert not bad.safe and bad.findings()[0].rule == "alink-command-envelope"
    assert bad.findings()[0].severity == "error"


def test_limit_reads_the_stops_the_stop_family_judged(monkeypatch: pytest.MonkeyPatch) -> None:
    """In S-curve the limit run's ramp to H is the unit's ramp: with the stop family's memo
    its stops at once are judged once, and the limit verdict is the one judged alone."""
    from profiles.alink import safety as al

    motor = load_motor(resolve("nema17-1600"))
    rot = al.nominal_rotors(motor)
    ramp = build_ramp(800, 4000, 20_000.0, 2, "s_curve")
    calls: list[float] = []
    judged = al.motion_angles

    def counted(r: object, *args: object, **kw: object) -> object:
        calls.append(r.high_pps)  # type: ignore[attr-defined]
        return judged(r, *args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(al, "motion_angles", counted)
    alone = al.limit_envelope(ramp, rot, 75.0)
    n_alone = len(calls)
    memo: dict[tuple[object, ...], al.Angles] = {}
    al.stop_envelope(ramp, rot, 75.0, memo=memo)
    calls.clear()
    shared = al.limit_envelope(ramp, rot, 75.0, memo=memo)
    assert len(calls) == n_alone - 1 and 4000.0 not in calls
    assert shared.degs == alone.degs and shared.speeds_pps == alone.speeds_pps


@pytest.mark.parametrize("triangle_avoidance", [False, True])
def test_the_compiled_assembly_gives_the_kernel_the_model_segments(
        triangle_avoidance: bool) -> None:
    """batch (assembled by the PPMC-312's compiled twin, or by numpy for an avoided
    triangle's middle) hands the kernel the segments the ramp model gives, once
    neighbours of one rate are joined, for every kind of motion."""
    from profiles.alink.ramp import parts, segments
    from profiles.alink.safety import batch
    from profiles.motor.batch_angle import dwells

    ramp = build_ramp(800, 6000, 150_000.0, 20, "s_curve",
                      triangle_avoidance=triangle_avoidance)
    r = ramp.ramp_pulses
    for kind, x in (("move", np.arange(1, 3 * r + 40)), ("stop", np.arange(1, r)),
                    ("search", np.arange(1, r + 40)), ("creep", np.array([1, 5, 300]))):
        got = dwells(batch(ramp, kind, x))
        rate, count, offsets = segments(ramp, parts(ramp, kind, x))
        np.testing.assert_array_equal(got.rate, rate)
        np.testing.assert_array_equal(got.count, count)
        np.testing.assert_array_equal(got.offsets, offsets)


def test_stops_at_once_share_a_slipping_references_ramp() -> None:
    """Stops at once from a fast ramp: the longest (the reference) slips at its stop from
    H, yet its states on the ramp below are shared: judged together, each stop's worst
    angle is the one it has judged alone (from rest), to the rounding of a dwell cut
    alike within its family."""
    from profiles.alink.safety import motion_angles, nominal_rotors

    rot = nominal_rotors(load_motor(resolve("nema17-1600")))
    ramp = build_ramp(800, 30_000, 147_059.0, 20, "linear")
    xs = [3, 150, 400, ramp.ramp_pulses - 5, ramp.ramp_pulses + 300]
    together = motion_angles(ramp, "search", rot, xs)
    assert together.slipped[:, -1].all()
    for k, x in enumerate(xs):
        alone = motion_angles(ramp, "search", rot, [x])
        assert float(alone.deg[0, 0]) == pytest.approx(float(together.deg[0, k]), abs=1e-6)


@pytest.mark.parametrize(("start", "high", "accel", "m", "shape"), [
    (800, 4000, 150_000.0, 20, "linear"), (800, 6000, 150_000.0, 20, "s_curve"),
    (800, 12_000, 60_000.0, 10, "s_curve"), (300, 3000, 9_000.0, 5, "linear")])
def test_stops_sampled_along_the_ramp_find_the_every_pulse_worst(
        start: int, high: int, accel: float, m: int, shape: str) -> None:
    """STOP 31 and the stops at once, sampled along the ramp and refined (the verdict's),
    against every stop judged (the oracle): the same worst within 0.1° where the rotor
    does not slip, and where the first stop past the aim comes."""
    from profiles.alink.safety import motion_angles, nominal_rotors

    rot = nominal_rotors(load_motor(resolve("nema17-1600")))
    ramp = build_ramp(start, high, accel, m, shape)
    for kind in ("stop", "search"):
        got = motion_angles(ramp, kind, rot, aim_deg=75.0)
        every = motion_angles(ramp, kind, rot, every_pulse=True)
        assert got.x.size <= every.x.size   # a slow ramp: a sample every pulse
        want = every.deg.max(axis=0)
        if want.max() < 90:
            assert float(got.deg.max()) == pytest.approx(float(want.max()), abs=0.1)
        past = every.x[want > 75.0]
        past_got = got.x[got.deg.max(axis=0) > 75.0]
        assert (past[0] if len(past) else None) == (past_got[0] if len(past_got) else None)


def test_limit_stops_past_h_and_the_first_slipping_run_change_nothing_read(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """LIMIT's ramps judged only up to H and the first speed whose run passes the peak:
    the envelope's speeds, the use at L and the worst at H are those of judging every
    ramp whole."""
    from profiles.alink import safety as al

    rot = al.nominal_rotors(load_motor(resolve("nema17-1600")))
    ramp = build_ramp(800, 30_000, 94_340.0, 20, "s_curve")
    bounded = al.limit_envelope(ramp, rot, 75.0)
    plain = al._ramp_stops
    monkeypatch.setattr(al, "_ramp_stops", lambda r, rows, aim, memo=None, upto_pps=0.0:
                        plain(r, rows, aim, memo))
    whole = al.limit_envelope(ramp, rot, 75.0)
    assert bounded.executions < whole.executions
    assert bounded.reach(75.0) == whole.reach(75.0)
    assert bounded.reach(90.0) == whole.reach(90.0)
    assert bounded.use_deg == pytest.approx(whole.use_deg, abs=0.1)
    assert bounded.top_deg == pytest.approx(whole.top_deg, abs=0.1)
