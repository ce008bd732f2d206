"""The best stall-safe init tables, the yardstick for what the free curve buys."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from profiles.errors import InitPlanError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from profiles.motor.angles import AIM_DEG
from profiles.motor.tolerance import worst_case_motor
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.init_model import expand_init
from profiles.ppmc312.init_planner import (
    RAMP_FLOOR,
    InitJudgement,
    Levers,
    init_candidates,
    plan_init,
    tighten_init,
    what_would_help,
)
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import FreeCurveTable, InitTable
from tests.support.cli import run
from tests.support.datasheet_motor import datasheet_motor_file
from verify.chip_rules import check_table
from verify.criterion import check_stall
from verify.init_judge import init_judge
from verify.plan_text import LINE_MAX, fix_lines, init_tightening
from verify.safety import judge_safety

MOTORS = [load_motor(p) for p in bundled_motor_paths()]


def staircase_time_s(stages: FreeCurveTable, pulses: int) -> float:
    """The move time of a staircase, computed here from the chip's documented shapes
    (docs/manual-notes.md), not by profiles.ppmc312.execution: a trapezoid runs both sides
    whole and cruises at the fastest rate; a triangle of an LE=0 table splits the pulses
    evenly (accel rounded down) and each side runs its slowest-first pulses."""
    rates, acc, dec = stages.rates, stages.accel_pulses, stages.decel
    total_acc, total_dec = sum(acc), sum(dec)
    if pulses >= total_acc + total_dec:
        ticks = (sum(p * r for p, r in zip(acc, rates, strict=False))
                 + sum(p * r for p, r in zip(dec, rates, strict=False))
                 + (pulses - total_acc - total_dec) * rates[0])
        return ticks / stages.clock.hz
    assert stages.decel_pulses is None, "the triangle here is the LE=0 one"
    a = pulses // 2

    def slowest_first_ticks(k: int) -> int:
        out = 0
        for p, r in reversed(list(zip(acc, rates, strict=False))):
            take = min(p, k)
            out, k = out + take * r, k - take
        return out

    return (slowest_first_ticks(a) + slowest_first_ticks(pulses - a)) / stages.clock.hz


def test_staircase_time_reference_on_a_hand_example() -> None:
    """The reference itself, on numbers worked by hand: rates 100, 200 at 1 MHz, 10 pulses
    each. 40 pulses: 10·200 + 10·100 + 10·100 + 10·200 = 6000 ticks, + 0 cruise; 50 pulses:
    + 10·100 = 7000 ticks; 7 pulses: accel 3 and decel 4 pulses at rate 200 = 1400 ticks;
    30 pulses: accel 15 = 10·200 + 5·100, decel the same: 5000 ticks."""
    t = FreeCurveTable(Clock.internal("1MHz"), (100, 200), (10, 10))
    assert staircase_time_s(t, 40) == 6000e-6
    assert staircase_time_s(t, 50) == 7000e-6
    assert staircase_time_s(t, 7) == 1400e-6
    assert staircase_time_s(t, 30) == 5000e-6


@pytest.mark.slow  # every candidate planned and judged; CI runs it
@pytest.mark.parametrize("motor", MOTORS, ids=lambda m: m.name[:8])
@pytest.mark.parametrize("shape", ["linear", "s_curve"])
def test_init_plans_are_stall_safe_legal_and_best_of_their_candidates(
        motor: Motor, shape: str) -> None:
    for separate in (False, True):
        # (LE=0 with fewer highs: candidates are costly, and the triangles are the point)
        cands = init_candidates(motor, shape, highs=8 if separate else 3,
                                separate_decel=separate)
        for c in cands:
            assert not [f for f in check_table(c.table) if f.severity == "error"]
            assert check_stall(c.stages, motor) == []
        longest = max(sum(c.stages.accel_pulses) + sum(c.stages.decel) for c in cands)
        # LE=1 candidates: only moves every candidate runs as a trapezoid
        for pulses in ((longest, longest + 5000) if separate else (2_000, 20_000, longest)):
            plan = plan_init(motor, shape, pulses, candidates=cands, separate_decel=separate)
            best = min(staircase_time_s(c.stages, pulses) for c in cands)
            assert plan.duration_s == pytest.approx(best, rel=1e-12, abs=0)
            assert plan.duration_s == pytest.approx(
                staircase_time_s(plan.extras["stages"], pulses), rel=1e-12, abs=0)
            if pulses in (2_000, 20_000):
                # The free curve can run any stall-safe staircase, so it is never slower.
                assert (plan_free_curve(motor, pulses=pulses).duration_s
                        <= plan.duration_s * 1.0001)


def test_counts_are_near_minimal() -> None:
    motor = MOTORS[0]
    cand = init_candidates(motor, "linear", highs=3, separate_decel=False)[0]  # fastest high
    smaller = type(cand.table)(cand.table.clock, "linear", cand.table.start_rate,
                               cand.table.high_rate, int(cand.table.accel_pulses * 0.97))
    from profiles.errors import InitBuildError

    try:
        stages = expand_init(smaller)
    except InitBuildError:
        return  # cannot even be built: certainly not a better candidate
    assert check_stall(stages, motor), "3 % fewer pulses should break the criterion"


def test_bad_shape_is_refused() -> None:
    with pytest.raises(InitPlanError, match="shape"):
        init_candidates(MOTORS[0], "cubic")  # type: ignore[arg-type]


PULSES = 4000


@pytest.fixture(scope="module")
def datasheet_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The datasheet NEMA17 on its lead screw (tests/support/datasheet_motor.py)."""
    return datasheet_motor_file(tmp_path_factory.mktemp("motor") / "17hs19.json",
                                "--name", "17hs19")


def test_the_untightened_table_is_past_the_aim(datasheet_path: Path) -> None:
    """What the tightening starts from: the plain table (the criterion's, on the box's worst
    case) fails the verdict on the origin return, so the test above cannot pass on a table
    that never needed tightening."""
    motor = load_motor(datasheet_path)
    plain = plan_init(worst_case_motor(motor), "linear", PULSES, separate_decel=False).table
    before = judge_safety(plain, motor)
    assert not before.within_aim and "origin-return" in before.failed
    assert "origin-return" in init_judge(motor)(plain).failing


@pytest.mark.slow  # eight tables planned and judged several times over
@pytest.mark.parametrize("shape", ["linear", "s_curve"])
@pytest.mark.parametrize("which", ["datasheet", *[p.stem for p in bundled_motor_paths()]])
def test_planned_init_tables_are_within_the_aim_at_every_length(
        which: str, shape: str, datasheet_path: Path) -> None:
    path = datasheet_path if which == "datasheet" else next(
        p for p in bundled_motor_paths() if p.stem == which)
    motor = load_motor(path)
    for separate in (False, True):
        plan = tighten_init(motor, shape, PULSES, init_judge(motor), separate_decel=separate)
        verdict = judge_safety(plan.table, motor)   # asked again, on its own
        assert verdict.moves is None and verdict.safe and verdict.within_aim, \
            verdict.describe()
        assert plan.duration_s >= plan.extras["untightened"].duration_s * (1 - 1e-9) \
            or not plan.extras["levers"].plain


def test_levers_tighten_what_is_blamed_and_the_top_once_the_ramp_is_at_its_floor() -> None:
    j = InitJudgement(False, False, start_deg=100.0, ramp_deg=50.0)
    assert Levers().tightened(j, 75.0) == Levers(start=0.75)
    j = InitJudgement(False, False, start_deg=50.0, ramp_deg=80.0)
    assert Levers().tightened(j, 75.0) == Levers(ramp=75 / 80)
    at_floor = Levers(ramp=RAMP_FLOOR)
    assert at_floor.tightened(j, 75.0) == Levers(ramp=RAMP_FLOOR, top=75 / 80)
    j = InitJudgement(False, False, start_deg=500.0, ramp_deg=0.0)
    assert Levers().tightened(j, 75.0).start == 0.6   # never more than 40 % a round


def test_levers_make_a_gentler_motor(datasheet_path: Path) -> None:
    motor = load_motor(datasheet_path)
    gentle = Levers(0.5, 0.8, 0.9).motor(motor)
    assert gentle.start_pps == pytest.approx(motor.start_pps * 0.5)
    assert gentle.jump_pps == pytest.approx(motor.jump_pps)  # only the start from rest
    assert gentle.safety_factor == pytest.approx(motor.safety_factor * 0.8)
    assert gentle.top_pps == pytest.approx(motor.top_pps * 0.9)
    assert Levers().motor(motor) is motor


def test_what_would_help_names_the_change_by_what_fails(datasheet_path: Path) -> None:
    motor = load_motor(datasheet_path)  # friction planned over a range (tolerances)
    only_11 = InitJudgement(False, False, 120.0, 40.0, ("origin-return",))
    text = what_would_help(only_11, motor, AIM_DEG)
    assert "--commands 80,81,82,83,84,85,86,87,88,10,05 if the machine never runs " \
           "11 (origin-return)" in text
    assert "load inertia or more drive current" in text and "top speed" not in text
    ramp = InitJudgement(False, False, 40.0, 120.0, ("moves",), "corner 1 "
                         "(friction_torque_nm 0.04377)")
    text = what_would_help(ramp, motor, AIM_DEG)
    assert "a lower top speed" in text and "a narrower friction range" in text
    assert "--commands" not in text and "inertia" not in text
    both = InitJudgement(False, False, 120.0, 120.0, ("moves",), "corner 1 "
                         "(friction_torque_nm 0.04377)")
    lines = fix_lines(what_would_help(both, motor, AIM_DEG))   # as the summary shows it
    assert lines[0] == "what would help, any of:" and len(lines) == 4
    assert all(len(line) <= LINE_MAX for line in lines)
    assert fix_lines("a lower top speed") == ["what would help: a lower top speed"]


def _never_within(failing: tuple[str, ...]) -> Any:
    calls: list[InitTable] = []

    def judge(table: InitTable) -> InitJudgement:
        calls.append(table)
        # the start lever helps a little each time, never enough
        return InitJudgement(False, False, 90.0 + 1000.0 / table.start_rate, 40.0, failing)

    return judge, calls


@pytest.mark.slow  # every round plans the candidates again
def test_nothing_within_the_aim_returns_the_closest_with_the_fix() -> None:
    motor = load_motor(next(p for p in bundled_motor_paths() if "nema23" in p.stem))
    judge, calls = _never_within(("origin-return",))
    plan = tighten_init(motor, "linear", PULSES, judge)
    assert len(calls) == plan.extras["plans"] > 2
    closest = min(calls, key=lambda t: 1000.0 / t.start_rate)
    assert plan.table == closest
    assert "11 (origin-return)" in plan.extras["fix"]


def test_the_cli_refusal_names_the_fix(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """`plan` refuses (exit 1) a table the verdict finds unsafe and says what would help
    (the planner's `fix`): a judge that never passes stands in for a motor nothing is safe
    for, and the verdict for the one that would fail it."""
    from profiles.ppmc312 import init_planner

    plain = init_planner.tighten_init

    def stuck(motor: Motor, shape: Any, pulses: int, judge: Any, **kw: Any) -> Any:
        never, _ = _never_within(("origin-return",))
        kw["aim_deg"] = AIM_DEG
        return plain(motor, shape, pulses, never, **kw)

    monkeypatch.setattr(init_planner, "TIGHTEN_ROUNDS", 1)
    monkeypatch.setattr(init_planner, "RELAX_STEPS", 0)
    monkeypatch.setattr(init_planner, "tighten_init", stuck)
    unsafe = SimpleNamespace(safe=False, describe=lambda: "UNSAFE (failed: origin-return)")
    monkeypatch.setattr("verify.safety.judge_safety", lambda *a, **k: unsafe)
    code, _, err = run(capsys, "plan", "--kind", "linear", "--motor", "nema23-heavy",
                         "--pulses", "2000", "-o", tmp_path / "t.json")
    assert code == 1 and not (tmp_path / "t.json").exists()
    assert "refused" in err and "what would help: " in err
    assert "--commands 80,81,82,83,84,85,86,87,88,10,05 if the machine never runs " \
           "11 (origin-return)" in err


def _plan(start_rate: int, high_rate: int, took_s: float, levers: Levers, plain: Any) -> Any:
    table = InitTable(Clock.internal("8MHz"), "linear", start_rate, high_rate, 1000)
    return SimpleNamespace(table=table, duration_s=took_s, pulses=PULSES,
                           extras={"levers": levers, "untightened": plain})


def test_the_price_line_in_plain_words() -> None:
    plain = _plan(1600, 400, 0.2000, Levers(), None)          # 5 000 pps start, 20 000 top
    plan = _plan(2000, 500, 0.2100, Levers(0.8, 0.9, 0.8), plain)
    assert init_tightening(plan, 75.0)[:3] == [   # too long for one line: a part a line
        "start speed lowered to 4 000 pps (from 5 000 pps)",
        "ramp made gentler (90% of the torque it could use)",
        "top speed lowered to 16 000 pps (from 20 000 pps) to keep the rotor within 75° "
        "under every command judged"]
    lines = init_tightening(plan, 75.0)
    assert lines[-1] == ("price: a move of 4000 pulses takes 210 ms, 5.0% longer than the "
                         "untightened table's 200 ms")
    much = _plan(2000, 400, 0.5000, Levers(0.8), plain)
    assert init_tightening(much, 75.0)[-1] == ("price: a move of 4000 pulses takes 500 ms, "
                                               "2.5× as long as the untightened table's 200 ms")
    faster = _plan(2000, 400, 0.1990, Levers(0.8), plain)
    assert init_tightening(faster, 75.0) == [
        "start speed lowered to 4 000 pps (from 5 000 pps) to keep the rotor within 75° "
        "under every command judged",
        "price: a move of 4000 pulses takes 199 ms, 0.5% shorter than the untightened "
        "table's 200 ms"]


def test_init_refusals_by_the_criterion_name_what_would_help(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from dataclasses import replace

    from profiles.errors import InitPlanError
    from profiles.ppmc312 import init_planner

    motor = load_motor(next(p for p in bundled_motor_paths() if "nema17" in p.stem))
    crowded = replace(motor, max_pps=motor.start_pps * 1.01)  # no room for a high rate
    with pytest.raises(InitPlanError, match=r"start rate \d+ − 0x80 at 8MHz: a top speed "
                                            r"further above the start speed \(max_pps"):
        init_planner.init_candidates(crowded, "linear")
    monkeypatch.setattr(init_planner, "_smallest_safe", lambda *a: None)  # nothing passes
    with pytest.raises(InitPlanError, match=r"even with the longest ramp the chip takes "
                                            r"\(1048575 pulses\): a lower top speed"):
        init_planner.init_candidates(motor, "s_curve", highs=2)


@pytest.mark.slow  # a whole tightening, its candidate searches forgotten first
def test_a_tightening_reports_progress_for_every_search(datasheet_path: Path) -> None:
    """The plain table's candidate search and each gentler one's: a long tightening keeps
    its progress bar moving."""
    from profiles.ppmc312.init_planner import forget_candidates

    motor = load_motor(datasheet_path)
    heard: list[tuple[int, int]] = []
    forget_candidates()
    plan = tighten_init(motor, "linear", PULSES, init_judge(motor),
                        progress=lambda done, total: heard.append((done, total)))
    searches = sum(1 for done, _ in heard if done == 0)
    assert plan.extras["plans"] >= 2 and searches == plan.extras["plans"]
    assert all(0 <= done <= total for done, total in heard)
