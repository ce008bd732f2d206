"""profiles.ppmc312.init_judge: how an init table's verdict blames short moves, early stops and
commands, samples past the peak and criterion findings on the ramp."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

from profiles.motor.angles import AIM_DEG
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.init_judge import judgement
from profiles.ppmc312.table import InitTable


def _verdict(moves: tuple[float, int], stop: tuple[float, int], families: dict[str, float],
             *, aim: float = AIM_DEG) -> Any:
    la = SimpleNamespace(worst_deg=moves[0], worst_pulses=moves[1], worst_at="nominal",
                         sample_failures=0)
    commands = [("decel-stop", SimpleNamespace(worst_deg=stop[0], ramp_pulse=stop[1],
                                               sample_failures=0, worst_at="corner 1 "
                                               "(friction_torque_nm 0)"))]
    commands += [(n, SimpleNamespace(use_deg=d)) for n, d in families.items()]
    worst = max(moves[0], stop[0], *families.values())
    return SimpleNamespace(criterion=(), load_angle=la, commands=commands, aim_deg=aim,
                           safe=worst < 90, within_aim=worst <= aim)


TABLE = InitTable(Clock.internal("8MHz"), "linear", 2000, 400, 1000)  # start zone: 250 pulses


def test_judgement_blames_short_moves_early_stops_and_commands_from_rest_on_the_start() -> None:
    j = judgement(_verdict((80.0, 400), (70.0, 900), {"origin-return": 95.0,
                                                     "set-speed": 60.0}), TABLE)
    assert (j.start_deg, j.ramp_deg) == (95.0, 70.0)   # a move of 400: ramp pulse 200 ≤ 250
    assert j.failing == ("moves", "origin-return") and not j.safe
    j = judgement(_verdict((80.0, 600), (78.0, 240), {"constant": 50.0, "set-speed": 77.0}),
                  TABLE)
    assert (j.start_deg, j.ramp_deg) == (78.0, 80.0)   # the stop early, the move not
    assert j.failing == ("moves", "decel-stop", "set-speed")


def test_judgement_counts_sample_failures_as_the_peak_and_a_criterion_finding_on_the_ramp(
        ) -> None:
    v = _verdict((60.0, 10), (50.0, 900), {"stop": 40.0})
    v.load_angle.sample_failures = 3       # Monte Carlo samples past the peak, corners not
    v.criterion = (SimpleNamespace(severity="error"),)
    j = judgement(v, TABLE)
    assert (j.start_deg, j.ramp_deg) == (90.0, 90.0)
    assert j.failing == ("criterion", "moves")
    short = InitTable(Clock.internal("8MHz"), "linear", 2000, 400, 40)  # a quarter: 10
    j = judgement(_verdict((80.0, 32), (20.0, 16), {}), short)   # the zone is 16 pulses
    assert (j.start_deg, j.ramp_deg) == (80.0, 0.0)
    j = judgement(_verdict((80.0, 34), (20.0, 17), {}), short)
    assert (j.start_deg, j.ramp_deg) == (0.0, 80.0)
