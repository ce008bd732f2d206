"""Synchronised axes (issue 11): axes files, time and line synchronisation, ruckig.

Finish spread and line deviation are recomputed here independently of the library:
each axis's pulse instants are rebuilt from its table's execution segments in pure
Python (no pulse_times_s / searchsorted), positions at each instant counted with
Execution.position_at (the segment model), and the distance to the line taken as the
2-D cross product |x·N_y − y·N_x| / |N| (the library projects onto the line).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles.axes import FORMAT, axes_from_json
from profiles.errors import FieldRangeError, FormatError, StepRampError, SyncError
from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.execution import Execution, simulate_move
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.sync import (
    cap_top,
    line_deviation,
    pad_to_ticks,
    plan_line_sync,
    plan_time_sync,
    spread_tolerance_s,
)
from profiles.ppmc312.upload import decode_move
from tests.support.paths import ROOT
from verify.criterion import check_stall
from verify.devices import axes_entries, load_axes
from verify.sync import ruckig_sync, sync_report

SCHEMA = json.loads((ROOT / "profiles" / "data" / "axes.schema.json").read_text("utf-8"))
MOTORS = [load_motor(p) for p in bundled_motor_paths()]
NEMA17, NEMA23, PK566 = MOTORS


# --------------------------------------------------------------------------- recomputation
def pulse_instants(e: Execution) -> list[float]:
    """Every pulse's instant from the segments, one by one (ticks, then seconds)."""
    out = []
    tick = 0
    for s in e.segments:
        for _ in range(s.pulses):
            tick += s.rate
            out.append(tick / e.clock.hz)
    return out


def independent_spread(executions: list[Execution]) -> float:
    ends = [pulse_instants(e)[-1] for e in executions]
    return max(ends) - min(ends)


def independent_deviation(a: Execution, b: Execution) -> float:
    """Largest distance of the 2-D joint path from the line, at every pulse instant."""
    t = np.array(sorted(set(pulse_instants(a)) | set(pulse_instants(b))))
    x = np.asarray(a.position_at(t), dtype=float)
    y = np.asarray(b.position_at(t), dtype=float)
    nx, ny = a.pulses, b.pulses
    return float(np.max(np.abs(x * ny - y * nx)) / math.hypot(nx, ny))


# --------------------------------------------------------------------------- axes file
def axes_doc(**over: object) -> dict:
    doc = {"format": FORMAT, "mode": "time",
           "axes": [{"name": "x", "motor": "m.json", "pulses": 1200},
                    {"name": "y", "motor": "m.json", "pulses": -700}]}
    doc.update(over)
    return doc


@pytest.fixture
def motor_dir(tmp_path: Path) -> Path:
    (tmp_path / "m.json").write_text(json.dumps(NEMA17.to_json()))
    return tmp_path


def test_axes_file_loads_with_paths_relative_to_it(motor_dir: Path) -> None:
    (motor_dir / "axes.json").write_text(json.dumps(axes_doc(device="ppmc312")))
    axes = load_axes(motor_dir / "axes.json")
    assert axes.mode == "time" and axes.device == "ppmc312"
    assert [a.name for a in axes.axes] == ["x", "y"]
    assert [a.pulses for a in axes.axes] == [1200, -700]
    assert axes.axes[1].ccw and axes.axes[1].distance == 700
    assert axes.axes[0].motor_path == motor_dir / "m.json"
    assert axes.axes[0].motor is not None and axes.axes[0].motor.name == NEMA17.name


def test_defaults_mode_time_device_ppmc312(motor_dir: Path) -> None:
    doc = axes_doc()
    del doc["mode"]
    axes = axes_from_json(doc, axes_entries(), motor_dir)
    assert (axes.mode, axes.device) == ("time", "ppmc312")


BAD = [
    ({"format": "stepramp.axes/2"}, "format"),
    ({"mode": "diagonal"}, "mode"),
    ({"device": "mc200"}, "device"),
    ({"axes": []}, "axes"),
    ({"extra": 1}, "unknown key"),
    ({"axes": [{"name": "x", "motor": "m.json", "pulses": 0}]}, "pulses"),
    ({"axes": [{"name": "x", "motor": "m.json", "pulses": 1.5}]}, "pulses"),
    ({"axes": [{"name": "x", "motor": "m.json", "pulses": 2**32}]}, "pulses"),
    ({"axes": [{"name": "1x", "motor": "m.json", "pulses": 10}]}, "name"),
    ({"axes": [{"name": "x", "pulses": 10}]}, "exactly one of motor"),
    ({"axes": [{"name": "x", "motor": "m.json", "table": "t.json", "pulses": 10}]},
     "exactly one of motor"),
    ({"axes": [{"name": "x", "motor": "m.json", "pulses": 10},
               {"name": "X", "motor": "m.json", "pulses": 10}]}, "used twice"),
    ({"axes": [{"name": "x", "motor": "m.json", "pulses": 10, "speed": 3}]}, "unknown key"),
    ({"axes": [{"name": "x", "motor": "", "pulses": 10}]}, "expected a file path"),
    ({"axes": [{"name": "x", "motor": 7, "pulses": 10}]}, "expected a file path"),
    ({"axes": [{"name": "x", "table": "", "pulses": 10}]}, "expected a file path"),
    ({"device": "alink", "axes": [{"name": n, "motor": "m.json", "pulses": 10}
                                  for n in "abc"]}, "axes"),
    ({"device": "alink", "axes": [{"name": "a", "motor": "m.json", "pulses": 2**27}]},
     "pulses"),
]


@pytest.mark.parametrize(("over", "word"), BAD)
def test_bad_axes_files_give_one_line_errors(motor_dir: Path, over: dict, word: str) -> None:
    with pytest.raises(StepRampError) as err:
        axes_from_json(axes_doc(**over), axes_entries(), motor_dir)
    assert word in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(("over", "word"), [b for b in BAD if b[1] != "used twice"])
def test_schema_refuses_what_the_loader_refuses(over: dict, word: str) -> None:
    import jsonschema
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(axes_doc(**over), SCHEMA)


def test_names_differing_only_in_case_pass_the_schema_and_the_loader_refuses_them(
        motor_dir: Path) -> None:
    # JSON Schema cannot state case-insensitive uniqueness (uniqueItems compares whole
    # items): the loader is the judge of that rule, and says so in one line.
    import jsonschema
    doc = axes_doc(axes=[{"name": "x", "motor": "m.json", "pulses": 10},
                         {"name": "X", "motor": "m.json", "pulses": 10}])
    jsonschema.validate(doc, SCHEMA)
    with pytest.raises(StepRampError, match="used twice"):
        axes_from_json(doc, axes_entries(), motor_dir)


def test_schema_accepts_the_examples() -> None:
    import jsonschema
    for path in sorted((ROOT / "examples").glob("axes-*.json")):
        doc = json.loads(path.read_text("utf-8"))
        jsonschema.validate(doc, SCHEMA)
        assert load_axes(path).axes


def test_missing_motor_file_names_the_axis(tmp_path: Path) -> None:
    (tmp_path / "axes.json").write_text(json.dumps(axes_doc()))
    with pytest.raises(FormatError, match=r"axes\[0\]\.motor: .*no such file"):
        load_axes(tmp_path / "axes.json")


# --------------------------------------------------------------------------- time mode
@pytest.fixture(scope="module")
def time_plan():
    return plan_time_sync([("x", NEMA17, 12_000), ("y", PK566, -5_000), ("z", NEMA23, 900)])


@pytest.mark.slow  # a three-axis time sync (~7 s); CI runs it
def test_time_mode_finishes_together(time_plan) -> None:
    exes = [a.execution for a in time_plan.axes]
    spread = independent_spread(exes)
    assert spread == pytest.approx(time_plan.spread_s, abs=1e-12)
    assert spread <= spread_tolerance_s(time_plan.duration_s)
    report = sync_report(time_plan, device="ppmc312")
    assert report["finish_spread_s"] == pytest.approx(spread, abs=1e-12)
    for a, item in zip(time_plan.axes, report["axes"], strict=True):
        assert item["duration_s"] == simulate_move(a.table, abs(a.pulses)).duration_s
        assert item["duration_s"] == pytest.approx(pulse_instants(a.execution)[-1], abs=1e-12)


@pytest.mark.slow  # shares that plan
def test_time_mode_slowest_keeps_its_fastest_table_others_slowed_safely(time_plan) -> None:
    from profiles.motor.angles import AIM_DEG
    from profiles.ppmc312.load_angle import worst_load_angle

    slowest = max(time_plan.axes, key=lambda a: a.fastest_s)
    # the table `stepramp plan` makes: the criterion and the load angle within the aim
    assert slowest.table == plan_free_curve(slowest.motor, pulses=abs(slowest.pulses),
                                            load_angle_deg=AIM_DEG).table
    for a in time_plan.axes:
        assert not check_stall(a.table, a.motor), a.name
        assert worst_load_angle(a.table, a.motor).worst_angle_deg <= AIM_DEG, a.name
        assert a.duration_s >= a.fastest_s - 1e-12
        assert a.execution.shape == "trapezoid"   # same first-pulse latency on every chip
    assert time_plan.duration_s == pytest.approx(time_plan.unsynchronised_s, abs=1e-12)


def test_padding_lands_within_a_tick_step_and_only_grows_counts() -> None:
    table = plan_free_curve(NEMA17, pulses=8000).table
    base = simulate_move(table, 8000)
    target = base.ticks + 123_457
    padded = pad_to_ticks(table, 8000, target)
    run = simulate_move(padded, 8000)
    assert run.ticks <= target and target - run.ticks < padded.rates[1] - padded.rates[0] + 1
    assert all(p >= q for p, q in zip(padded.accel_pulses, table.accel_pulses, strict=True))
    assert padded.rates == table.rates
    sym = pad_to_ticks(table, 8000, target, symmetric=True)
    assert sym.accel_pulses == sym.decel or sym.decel_pulses is not None


def test_cap_top_never_asks_more() -> None:
    table = plan_free_curve(PK566, pulses=6000).table
    capped = cap_top(table, table.rates[0] + 7)
    assert capped.rates[0] == table.rates[0] + 7
    assert not check_stall(capped, PK566, pulses=[6000])


def test_too_short_an_axis_is_refused() -> None:
    with pytest.raises(SyncError, match="at least 8"):
        plan_time_sync([("x", NEMA17, 1000), ("y", NEMA17, 5)])


def _time_property(nx: int, ratio: float, sign: int) -> None:
    ny = max(8, round(nx * ratio))
    plan = plan_time_sync([("x", NEMA17, nx), ("y", PK566, sign * ny)])
    exes = [a.execution for a in plan.axes]
    assert independent_spread(exes) == pytest.approx(plan.spread_s, abs=1e-12)
    assert plan.spread_s <= spread_tolerance_s(plan.duration_s)
    assert plan.duration_s == pytest.approx(plan.unsynchronised_s, abs=1e-12)
    for a in plan.axes:
        assert not check_stall(a.table, a.motor)


@pytest.mark.slow  # property over planned axes; CI runs it
@settings(max_examples=3, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(nx=st.integers(200, 4_000), ratio=st.floats(0.02, 1.0), sign=st.sampled_from([1, -1]))
def test_time_mode_property_over_pulse_ratios(nx: int, ratio: float, sign: int) -> None:
    _time_property(nx, ratio, sign)


@pytest.mark.slow
@settings(max_examples=10, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(nx=st.integers(200, 40_000), ratio=st.floats(0.005, 1.0), sign=st.sampled_from([1, -1]))
def test_time_mode_property_over_pulse_ratios_wide(nx: int, ratio: float, sign: int) -> None:
    _time_property(nx, ratio, sign)


# --------------------------------------------------------------------------- line mode
@pytest.fixture(scope="module")
def line_plan():
    return plan_line_sync([("x", NEMA17, 12_000), ("y", NEMA17, -7_001)])


@pytest.mark.slow  # a line sync (~2 s); CI runs it
def test_line_deviation_recomputed_equals_the_report(line_plan) -> None:
    a, b = (x.execution for x in line_plan.axes)
    ours = independent_deviation(a, b)
    report = sync_report(line_plan, device="ppmc312")
    assert report["max_line_deviation_pulses"] == pytest.approx(ours, rel=1e-9, abs=1e-9)
    assert report["finish_spread_s"] == pytest.approx(independent_spread([a, b]), abs=1e-12)


@pytest.mark.slow  # shares that plan
def test_line_mode_stays_near_the_line_finishes_together_and_is_safe(line_plan) -> None:
    dev = line_deviation([a.execution for a in line_plan.axes])[0]
    assert dev < 3.0   # a few pulses at most, where naive rounding drifts by several
    assert line_plan.spread_s <= spread_tolerance_s(line_plan.duration_s)
    for a in line_plan.axes:
        assert not check_stall(a.table, a.motor)
    assert line_plan.duration_s >= line_plan.unsynchronised_s


def test_line_deviation_is_zero_for_identical_axes() -> None:
    run = simulate_move(plan_free_curve(NEMA17, pulses=3000).table, 3000)
    assert line_deviation([run, run])[0] == pytest.approx(0.0, abs=1e-9)


def test_line_deviation_of_a_known_path() -> None:
    # x runs all its pulses before y starts: at (Nx, 0) the distance is Nx·Ny/|N|
    fast = simulate_move(plan_free_curve(NEMA17, pulses=400).table, 400)
    late = Execution(shape=fast.shape, status=0, segments=[
        type(fast.segments[0])("cruise", 10_000_000, 1, 0),
        type(fast.segments[0])("cruise", 8000, 299, 10_000_000)],
        pulses=300, clock=fast.clock, high_rate=8000, high_rate_given=False)
    assert line_deviation([fast, late])[0] == pytest.approx(400 * 300 / math.hypot(400, 300),
                                                           rel=1e-12)


@pytest.mark.slow
@settings(max_examples=4, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(nx=st.integers(1000, 15_000), ratio=st.floats(0.05, 1.0))
def test_line_mode_property_over_pulse_ratios(nx: int, ratio: float) -> None:
    ny = max(8, round(nx * ratio))
    plan = plan_line_sync([("x", NEMA17, nx), ("y", PK566, ny)])
    a, b = (x.execution for x in plan.axes)
    assert line_deviation([a, b])[0] == pytest.approx(independent_deviation(a, b), rel=1e-9,
                                                      abs=1e-9)
    assert plan.spread_s <= spread_tolerance_s(plan.duration_s)
    for x in plan.axes:
        assert not check_stall(x.table, x.motor)


# --------------------------------------------------------------------------- ruckig
def test_ruckig_synchronised_durations_bracket_and_order() -> None:
    from verify.references import ruckig_reference

    rk = ruckig_sync([NEMA17, PK566], [12_000, -5_000])
    alone = [ruckig_reference(m, n).duration_s for m, n in ((NEMA17, 12_000), (PK566, 5_000))]
    # synchronising never makes the slowest axis faster than it is alone
    assert rk.time_feasible_s >= max(alone) * (1 - 1e-6)
    assert rk.phase_feasible_s >= rk.time_feasible_s * (1 - 1e-6)
    assert rk.time_optimistic_s <= rk.time_feasible_s
    _, x, _ = rk.trajectories["phase"]
    # phase synchronisation keeps the axes proportional: a straight line
    assert np.allclose(x[:, 1] / 5_000, x[:, 0] / 12_000, atol=1e-6)


@pytest.mark.slow  # shares the three-axis time sync
def test_move_commands_carry_the_trigger(time_plan) -> None:
    from profiles.ppmc312.sync import move_command

    for a in time_plan.axes:
        cmd = decode_move(move_command(a))
        assert cmd == {"pulses": abs(a.pulses), "ccw": a.pulses < 0, "high_rate": 0,
                       "override": True, "trigger": 1}


def test_bad_pulses_for_the_chip_are_refused() -> None:
    with pytest.raises(FieldRangeError):
        axes_from_json(axes_doc(axes=[{"name": "x", "motor": "m.json", "pulses": -2**32}]),
                       axes_entries(), None, load_motors=False)


def test_line_mode_falls_back_below_the_peak_and_says_so(monkeypatch: pytest.MonkeyPatch
                                                         ) -> None:
    """Where no line-synchronised set keeps the load angle within the aim, sync takes
    one below the 90° peak, and its info says so; another judge's failure stands."""
    import profiles.ppmc312.sync as sync

    calls = []

    def fake(axes, *, accept):  # type: ignore[no-untyped-def]
        calls.append(accept)
        if accept is not sync.accepted_below_peak:
            raise SyncError("nothing this judge passes")
        return sync.SyncPlan("line", (), "line: leader x")

    monkeypatch.setattr(sync, "plan_line_sync", fake)
    plan = sync.plan_sync([("x", NEMA17, 1000)], "line")
    assert calls == [sync.accepted, sync.accepted_below_peak]
    assert "no set within the 75° load-angle aim" in plan.info
    with pytest.raises(SyncError):  # a caller's own judge gets no fallback
        sync.plan_sync([("x", NEMA17, 1000)], "line", accept=lambda t, m: True)
    assert len(calls) == 3  # tried once, no fallback


def test_the_envelope_ends_where_the_axes_can_no_longer_accelerate_together() -> None:
    """A braked axis (friction eating its torque at speed) caps the line's top speed where
    it stops accelerating, below its own curve's end."""
    from dataclasses import replace

    from profiles.motor.envelope import envelope_motor

    free = load_motor(next(p for p in bundled_motor_paths() if "nema17" in p.name))
    braked = replace(free, friction_torque_nm=0.1)
    env = envelope_motor([braked, free], [1.0, 0.5])
    assert env.top_pps < braked.top_pps
    assert braked.a_acc_pps2(env.top_pps) <= 0 < braked.a_acc_pps2(0.99 * env.top_pps)
    assert env.a_acc_pps2(0.99 * env.top_pps) > 0


@pytest.mark.parametrize(("items", "bound"), [
    ((("x", "nema17-1600", 12000), ("y", "pk566-5phase-half", -5000)), 2.0),
    ((("x", "nema17-1600", 3000), ("y", "nema17-1600", 2999)), 1.0),
])
def test_every_line_candidate_stays_on_the_line(items: tuple, bound: float) -> None:
    """Not only the chosen set: every candidate line mode builds (each capped top rate, LE=1
    and LE=0, followers stage by stage or spanning stages) keeps the joint path within a
    pulse or two of the line, so a candidate generator that drifts cannot hide behind the
    choice. The tops start at the envelope plan's own and slow down from there."""
    from profiles.motor.envelope import envelope_motor
    from profiles.ppmc312.planner import plan_free_curve
    from profiles.ppmc312.sync.line_mode import TOP_SLACK, VARIANTS, Axes, line_candidates
    from profiles.ppmc312.sync.moves import axis_distance
    from profiles.ppmc312.sync.time_mode import fastest_table

    axes = [(name, load_motor(motor), pulses) for name, motor, pulses in items]
    dist = [axis_distance(name, pulses) for name, _, pulses in axes]
    lead = dist.index(max(dist))
    motors = [m for _, m, _ in axes]
    ax = Axes(axes, dist, lead, [d / dist[lead] for d in dist],
              [fastest_table(m, d)[1].duration_s for m, d in zip(motors, dist, strict=True)])
    base = plan_free_curve(envelope_motor(motors, ax.scales, margin=0.97), pulses=dist[lead],
                           max_stages=24).table
    found = line_candidates(ax, base, TOP_SLACK)
    tops = sorted({c.top_rate for c in found})
    assert tops[0] == base.rates[0] and len(found) == len(VARIANTS) * len(tops)
    assert max(c.deviation for c in found) <= bound
