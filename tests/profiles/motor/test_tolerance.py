"""Tolerance boxes: the motor file keys, the binding corner, Monte Carlo, the robust plan
and check."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from profiles.errors import FormatError, StepRampError
from profiles.motor import Motor, load_motor
from profiles.motor.tolerance import (
    box,
    clopper_pearson_upper,
    corners,
    sample_params,
    samples,
    worst_case_motor,
)
from profiles.ppmc312.criterion import all_length_problems
from profiles.ppmc312.execution import simulate_move
from profiles.ppmc312.load_angle import worst_load_angle
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.table import dump_table
from profiles.ppmc312.tolerance_box import judge_box, sample_peaks
from tests.support.paths import ROOT
from verify import cli

DATA = ROOT / "profiles" / "data"


NEMA17 = DATA / "motor-nema17-1600.json"


FULL_BOX = {"inertia_kgm2": [4.0e-6, 9.0e-6], "friction_torque_nm": [0.0, 0.04],
            "load_torque_nm": [-0.03, 0.02], "torque_scale": [0.8, 1.0],
            "damping_ratio": [0.05, 0.2]}


def motor_with(**extra: object) -> Motor:
    obj = json.loads(NEMA17.read_text())
    obj.update(extra)
    return Motor.from_json(obj)


def test_tolerances_round_trip_and_box() -> None:
    m = motor_with(tolerances=FULL_BOX, resonance_bands_pps=[[3000, 3300]])
    again = Motor.from_json(json.loads(json.dumps(m.to_json())))
    assert again.to_json() == m.to_json()
    assert again.to_json()["tolerances"] == FULL_BOX
    assert set(box(m)) == set(FULL_BOX)
    assert len(corners(m)) == 2 ** 5
    assert m.tolerance("torque_scale") == (0.8, 1.0)
    # a degenerate range is no dimension
    assert box(motor_with(tolerances={"torque_scale": [1.0, 1.0]})) == {}


@pytest.mark.parametrize("tol, words", [
    ({"inertia_kgm2": [9e-6, 4e-6]}, "must not exceed"),
    ({"inertia_kgm2": [7e-6, 9e-6]}, "must hold the nominal"),
    ({"torque_scale": [0.8, 0.9]}, "must hold the nominal 1"),
    ({"stiffness": [1, 2]}, "unknown field 'stiffness'"),
    ({"damping_ratio": [0.1]}, "expected [low, high]"),
    ({"friction_torque_nm": [-0.01, 0.03]}, "friction_torque_nm low"),
    ({"torque_scale": [0.0, 1.0]}, "torque_scale low"),
])
def test_bad_tolerances_are_one_line_errors(tol: dict, words: str) -> None:
    with pytest.raises(StepRampError) as e:
        motor_with(tolerances=tol)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_corner_that_cannot_start_is_named() -> None:
    m = motor_with(tolerances={"friction_torque_nm": [0.0, 0.5]})
    with pytest.raises(FormatError, match="tolerance box"):
        worst_case_motor(m)


def test_worst_case_capability_binds_every_corner_and_sample() -> None:
    """Where the box can accelerate at all, the worst-case motor's a_acc and a_dec are ≤
    every corner's and every sample's and equal to the smallest corner's (attained:
    exact); where some corner cannot (capability ≤ 0), neither can the worst case, so
    every step there fails both ways (J max binds only for a positive numerator)."""
    m = motor_with(tolerances=FULL_BOX)
    worst = worst_case_motor(m)
    v = np.linspace(0, m.top_curve_pps, 997)
    lo, hi = v[:-1], v[1:]
    for name in ("a_acc_pps2", "a_dec_pps2", "min_a_acc_pps2", "min_a_dec_pps2"):
        args = (v,) if name.startswith("a_") else (lo, hi)
        every = np.array([getattr(c.motor, name)(*args) for c in corners(m)])
        sampled = np.array([getattr(s.motor, name)(*args) for s in samples(m, 300, seed=3)])
        w = getattr(worst, name)(*args)
        low = every.min(axis=0)
        can = low > 0
        assert can.any() and (~can).any()  # the box covers both regimes
        tol = 1e-9 * np.abs(low).max()
        np.testing.assert_allclose(w[can], low[can], rtol=1e-12)
        assert np.all(w[can] <= sampled.min(axis=0)[can] + tol)
        assert np.all(w[~can] <= 0)


def test_samples_are_seeded_uniform_in_the_box() -> None:
    m = motor_with(tolerances=FULL_BOX)
    a, b = sample_params(m, 2000, seed=7), sample_params(m, 2000, seed=7)
    for key, (lo, hi) in FULL_BOX.items():
        assert np.array_equal(a[key], b[key])
        assert a[key].min() >= lo and a[key].max() <= hi
        assert abs(a[key].mean() - (lo + hi) / 2) < 0.05 * (hi - lo)
    assert not np.array_equal(a["inertia_kgm2"], sample_params(m, 2000, seed=8)["inertia_kgm2"])


def test_clopper_pearson() -> None:
    # 0 failures: the closed form, ≈ 3/N ("rule of three")
    assert clopper_pearson_upper(0, 1000) == pytest.approx(1 - 0.05 ** (1 / 1000), rel=1e-12)
    assert clopper_pearson_upper(0, 1000) < 3 / 1000
    # with failures: the beta quantile (scipy is a toppra dependency)
    from scipy import stats
    # (900 of 1000: the binomial terms span e^-2300…1, summed without overflow)
    for x, n in ((1, 10), (3, 1000), (40, 200), (900, 1000), (4000, 5000)):
        assert clopper_pearson_upper(x, n) == pytest.approx(stats.beta.ppf(0.95, x + 1, n - x),
                                                            rel=1e-9)
    assert clopper_pearson_upper(5, 5) == 1.0


def test_each_sample_is_judged_as_its_own_motor() -> None:
    """A Monte Carlo sample's verdict is the scalar verdict of that sample's motor, both
    directions of its load torque included (rows of one kernel call, each its own step)."""
    m = motor_with(tolerances=FULL_BOX)
    table = plan_free_curve(m, pulses=5000).table
    n = 300
    peaks, where, _ = sample_peaks(table, m, [n], 6, seed=1)
    assert np.all(where == n)
    for i, s in enumerate(samples(m, 6, seed=1)):
        scalar = max(worst_load_angle(table, s.motor, pulses=[n]).worst_angle_deg,
                     worst_load_angle(table, replace(s.motor, load_torque_nm=-s.motor
                                                     .load_torque_nm), pulses=[n])
                     .worst_angle_deg)
        assert peaks[i] == pytest.approx(scalar, abs=1e-9), i


def test_robust_plan_is_safe_at_every_corner_where_the_nominal_is_not() -> None:
    m = motor_with(tolerances={"inertia_kgm2": [6.8e-6 * 0.7, 6.8e-6 * 1.3],
                               "torque_scale": [0.8, 1.0], "friction_torque_nm": [0.01, 0.03]})
    robust = plan_free_curve(m, pulses=20000).table
    nominal = plan_free_curve(motor_with(), pulses=20000).table
    unsafe_somewhere = False
    for c in corners(m):
        assert not all_length_problems(robust, c.motor), c.describe()
        unsafe_somewhere |= bool(all_length_problems(nominal, c.motor))
    assert unsafe_somewhere
    assert simulate_move(robust, 20000).duration_s > simulate_move(nominal, 20000).duration_s


@pytest.mark.slow
def test_robust_plan_load_angle_at_every_corner() -> None:
    m = motor_with(tolerances={"inertia_kgm2": [6.8e-6 * 0.7, 6.8e-6 * 1.3],
                               "torque_scale": [0.8, 1.0]})
    plan = plan_free_curve(m, pulses=20000, load_angle_deg=75)
    assert "tolerance corners" in plan.info
    for c in corners(m):
        assert worst_load_angle(plan.table, c.motor).worst_angle_deg <= 75.0 + 1e-9


def test_check_cli_over_the_box(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tol = {"inertia_kgm2": [6.8e-6 * 0.7, 6.8e-6 * 1.3], "torque_scale": [0.8, 1.0]}
    obj = json.loads(NEMA17.read_text())
    obj["tolerances"] = tol
    motor_path = tmp_path / "m.json"
    motor_path.write_text(json.dumps(obj))
    m = load_motor(motor_path)
    robust = tmp_path / "robust.json"
    robust.write_text(dump_table(plan_free_curve(worst_case_motor(m), pulses=5000).table))
    nominal = tmp_path / "nominal.json"
    nominal.write_text(dump_table(plan_free_curve(load_motor(NEMA17), pulses=5000).table))
    args = ["check", "--motor", str(motor_path), "--pulses", "300,5000", "--samples", "100"]
    assert cli.main([*args, str(nominal)]) == 1
    out = capsys.readouterr().out
    assert "(at the tolerance box's worst case)" in out
    code = cli.main([*args, "--format", "json", str(robust)])
    doc = json.loads(capsys.readouterr().out)
    safety = doc["files"][0]["safety"]
    box_json = safety["tolerance_box"]
    assert box_json["samples"] == 100 and box_json["corners"] == 4
    assert code == (0 if safety["safe"] else 1)
    assert math.isclose(box_json["stall_probability_upper"], 1 - 0.05 ** (1 / 100)) \
        or box_json["sample_failures"] > 0


@pytest.mark.parametrize("holding", [None, 0.33])
@pytest.mark.parametrize("direction", [1, -1])
def test_box_rotors_are_the_variant_motors_rotors(holding: float | None, direction: int) -> None:
    """Row i of `rotors(motor, params)` is the rotor of `variant(motor, params at i)`: the
    torque scale multiplies the curve and the holding torque that caps it."""
    from profiles.motor.rotor import rotor_of, rotors

    m = replace(motor_with(tolerances=FULL_BOX), holding_torque_nm=holding)
    params = sample_params(m, 7, seed=2)
    rows = rotors(m, params, direction=direction)
    for i, s in enumerate(samples(m, 7, seed=2)):
        assert rows.rotor(i) == rotor_of(s.motor, direction=direction)


@pytest.mark.parametrize("max_step_s", [None, 2e-5])
def test_box_rotors_steps_are_each_rotors_own(max_step_s: float | None) -> None:
    """`Rotors.step_s` and `Rotors.settle_s` work out every row at once: the same steps
    and settling times, to the bit, as each row's own `Rotor.step_s` and `settle_s` (the
    reference), on a box's samples and both directions."""
    from profiles.motor.rotor import rotors, settle_s

    m = replace(motor_with(tolerances=FULL_BOX), holding_torque_nm=0.33)
    params = sample_params(m, 200, seed=3)
    for direction in (1, -1):
        rows = rotors(m, params, direction=direction)
        want = np.asarray([rows.rotor(i).step_s() for i in range(len(rows))])
        if max_step_s is not None:
            want = np.minimum(want, max_step_s)
        assert np.array_equal(rows.step_s(max_step_s), want)
        assert np.array_equal(rows.settle_s(want), [settle_s(rows.rotor(i), h)
                                                    for i, h in enumerate(want)])


@pytest.mark.parametrize(("samples", "told"), [(50, [(4, 5), (5, 5)]), (0, [(4, 4)])])
def test_judge_box_tells_its_progress_corners_then_samples(samples: int,
                                                           told: list[tuple[int, int]]) -> None:
    """A unit per corner and one for the Monte Carlo samples (when there are any): the
    corners' verdict first, then the samples'."""
    m = motor_with(tolerances={"inertia_kgm2": [6.8e-6 * 0.7, 6.8e-6 * 1.3],
                               "torque_scale": [0.8, 1.0]})
    table = plan_free_curve(worst_case_motor(m), pulses=5000).table
    heard: list[tuple[int, int]] = []
    judge_box(table, m, pulses=[200, 5000], samples=samples, seed=4,
              progress=lambda done, total: heard.append((done, total)))
    assert heard == told


def test_samples_are_seeded_by_0_unless_told() -> None:
    """`samples` draws the same motors as `sample_params` with seed 0 by default, and other
    ones with another seed."""
    m = motor_with(tolerances=FULL_BOX)
    default = [v.params for v in samples(m, 3)]
    assert default == [v.params for v in samples(m, 3, seed=0)]
    assert default != [v.params for v in samples(m, 3, seed=1)]
