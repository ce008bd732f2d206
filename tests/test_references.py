"""Continuous references: the exact oracle against hand kinematics, and the solvers
(toppra, ruckig, casadi) against the oracle and against the motor's capability."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.errors import FieldRangeError, FormatError, StepRampError
from profiles.motor import Motor, bundled_motor_paths, load_motor
from tests.support.paths import ROOT
from verify.references import (
    Reference,
    ReferenceSolveError,
    best_reference,
    casadi_reference,
    exact_optimum,
    is_feasible,
    move_limits,
    references,
    ruckig_reference,
    toppra_reference,
)
from verify.references._common import ZERO_ACCEL_MARGIN, accel_zero_pps, capability_violation
from verify.references._suite import CHECK_REL_TOL

BUNDLED = {p.stem: load_motor(p) for p in bundled_motor_paths()}


def flat_motor(torque_nm: float = 0.5, friction_nm: float = 0.05, top_pps: float = 20000.0,
               start_pps: float = 400.0, **extra: float) -> Motor:
    """A constant-torque motor: its optimum is a textbook triangle/trapezoid."""
    return Motor(steps_per_rev=200, curve_speed_pps=np.array([0.0, top_pps]),
                 curve_torque_nm=np.array([torque_nm, torque_nm]), inertia_kgm2=1e-5,
                 safety_factor=0.8, start_pps=start_pps, friction_torque_nm=friction_nm,
                 **extra)


def hand_trapezoid(torque_nm: float, friction_nm: float, top_pps: float, v0: float,
                   n: float) -> float:
    """Time of the rest-to-rest move from plain kinematics (v² = v0² + 2 a x)."""
    k = 200 / (2 * math.pi * 1e-5)
    a_up = (0.8 * torque_nm - friction_nm) * k
    a_down = (0.8 * torque_nm + friction_nm) * k
    v_peak = math.sqrt(v0 * v0 + 2 * n * a_up * a_down / (a_up + a_down))
    if v_peak <= top_pps:
        return (v_peak - v0) / a_up + (v_peak - v0) / a_down
    ramps_x = (top_pps**2 - v0**2) / (2 * a_up) + (top_pps**2 - v0**2) / (2 * a_down)
    return (top_pps - v0) / a_up + (top_pps - v0) / a_down + (n - ramps_x) / top_pps


# --- exact oracle -----------------------------------------------------------------

@pytest.mark.parametrize("n", [1, 7, 300, 2000, 123_457, 10_000_000])
def test_exact_matches_hand_kinematics_on_constant_torque(n: int) -> None:
    motor = flat_motor()
    ref = exact_optimum(motor, n)
    expected = hand_trapezoid(0.5, 0.05, 20000.0, 400.0, n)
    assert ref.duration_s == pytest.approx(expected, rel=1e-6)
    # constant acceleration: the samples obey v² = v0² + 2·a·x while speeding up
    up = ref.a_pps2 > 0
    a_up = float(motor.a_acc_pps2(0.0))
    assert np.allclose(ref.v_pps[up] ** 2, 400.0**2 + 2 * a_up * ref.x_pulses[up], rtol=1e-9)


def test_exact_cruises_at_the_cap_on_long_moves() -> None:
    ref = exact_optimum(flat_motor(), 1_000_000)
    assert ref.v_pps.max() == pytest.approx(20000.0, rel=1e-12)
    assert "cruise 0 s" not in ref.info


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(sorted(BUNDLED)), st.floats(1, 1e6), st.floats(1.0001, 3))
def test_exact_is_monotone_in_pulses(name: str, n: float, factor: float) -> None:
    motor = BUNDLED[name]
    assert exact_optimum(motor, n * factor, points=64).duration_s > \
        exact_optimum(motor, n, points=64).duration_s


@pytest.mark.parametrize("name", sorted(BUNDLED))
@pytest.mark.parametrize("n", [1, 2000, 100_000])
def test_exact_against_brute_force_integration(name: str, n: int) -> None:
    motor = BUNDLED[name]
    ref = exact_optimum(motor, n)
    # T = ∫ dx / v over the sampled (exact) speed profile, fine trapezoid
    x = np.linspace(0, n, 400_001)
    v = ref.speed_at_position(x)
    assert np.trapezoid(1 / v, x) == pytest.approx(ref.duration_s, rel=2e-4)
    # and the samples respect t(x) consistency
    assert np.allclose(ref.position_at(ref.t_s), ref.x_pulses)


@pytest.mark.parametrize("name", sorted(BUNDLED))
def test_exact_boundary_and_capability(name: str) -> None:
    motor = BUNDLED[name]
    lim = move_limits(motor, 5000)
    ref = exact_optimum(motor, 5000)
    assert ref.v_pps[0] == ref.v_pps[-1] == lim.v0_pps == min(motor.start_pps, motor.jump_pps)
    assert ref.x_pulses[0] == 0 and ref.x_pulses[-1] == 5000
    assert np.all(np.diff(ref.t_s) >= 0) and np.all(np.diff(ref.x_pulses) >= 0)
    assert capability_violation(motor, lim, ref, rel_tol=1e-9) == ""
    assert ref.solve_s < 0.05


def test_speed_limit_stops_short_of_zero_acceleration() -> None:
    motor = BUNDLED["motor-nema23-heavy"]  # a_acc < 0 at its last curve point
    v_zero = accel_zero_pps(motor)
    assert v_zero < motor.top_pps
    assert float(motor.a_acc_pps2(v_zero)) == pytest.approx(0.0, abs=1e-6)
    lim = move_limits(motor, 1e6)
    assert lim.v_lim_pps == pytest.approx(v_zero * (1 - ZERO_ACCEL_MARGIN))
    assert float(motor.a_acc_pps2(lim.v_lim_pps)) > 0
    assert exact_optimum(motor, 1e6).v_pps.max() == pytest.approx(lim.v_lim_pps)
    # a motor that keeps positive a_acc is capped by its curve / max_pps instead
    assert move_limits(flat_motor(max_pps=9000.0), 10).v_lim_pps == 9000.0


def test_start_speed_above_the_cap_runs_the_move_at_the_cap() -> None:
    motor = flat_motor(start_pps=5000.0, max_pps=3000.0)
    ref = exact_optimum(motor, 600)
    assert np.all(ref.v_pps == 3000.0)
    assert ref.duration_s == pytest.approx(0.2)


def test_jump_limit_lowers_the_boundary_speed() -> None:
    motor = flat_motor(max_jump_pps=100.0)
    assert exact_optimum(motor, 50).v_pps[0] == 100.0
    assert exact_optimum(motor, 50).duration_s == pytest.approx(
        hand_trapezoid(0.5, 0.05, 20000.0, 100.0, 50), rel=1e-9)


@pytest.mark.parametrize("bad", [0, -5, 0.5, math.inf, math.nan, 1e11])
def test_bad_pulses_name_the_field(bad: float) -> None:
    with pytest.raises(FieldRangeError, match=r"^pulses: "):
        exact_optimum(flat_motor(), bad)


@pytest.mark.parametrize("bad", ["100", None, True])
def test_non_numeric_pulses(bad: object) -> None:
    with pytest.raises(FormatError, match=r"^pulses: "):
        exact_optimum(flat_motor(), bad)


def test_bad_points() -> None:
    with pytest.raises(StepRampError, match=r"^points: "):
        exact_optimum(flat_motor(), 100, points=2)


# --- solvers ----------------------------------------------------------------------

def assert_move(motor: Motor, n: float, ref: Reference, rel_tol: float = 1e-6) -> None:
    """Starts and ends at v0, covers exactly 0…N, time runs forward, stays in capability."""
    lim = move_limits(motor, n)
    assert ref.v_pps[0] == pytest.approx(lim.v0_pps, rel=1e-9)
    assert ref.v_pps[-1] == pytest.approx(lim.v0_pps, rel=1e-9)
    assert ref.x_pulses[0] == 0 and ref.x_pulses[-1] == pytest.approx(n, rel=1e-12)
    assert np.all(np.diff(ref.t_s) >= 0)
    assert ref.t_s[-1] == pytest.approx(ref.duration_s, rel=1e-9)
    assert capability_violation(motor, lim, ref, rel_tol=rel_tol) == ""


@pytest.mark.parametrize("name", sorted(BUNDLED))
@pytest.mark.parametrize("n", [1, 2000, 100_000])
def test_ruckig_brackets_the_exact_optimum(name: str, n: int) -> None:
    motor = BUNDLED[name]
    exact = exact_optimum(motor, n).duration_s
    feasible = ruckig_reference(motor, n)
    optimistic = ruckig_reference(motor, n, bound="optimistic")
    assert feasible.duration_s >= exact >= optimistic.duration_s
    assert_move(motor, n, feasible, rel_tol=1e-9)
    # the optimistic one uses more acceleration than the motor has at speed
    lim = move_limits(motor, n)
    assert capability_violation(motor, lim, optimistic) != "" or n == 1


def test_ruckig_without_jerk_is_the_hand_trapezoid() -> None:
    """Constant torque: the feasible and optimistic brackets collapse onto the optimum."""
    motor = flat_motor()
    for n in (50, 500_000):
        expected = hand_trapezoid(0.5, 0.05, 20000.0, 400.0, n)
        assert ruckig_reference(motor, n).duration_s == pytest.approx(expected, rel=1e-9)
        assert ruckig_reference(motor, n, bound="optimistic").duration_s == \
            pytest.approx(expected, rel=1e-9)


def test_ruckig_jerk_limit_costs_time_and_stays_within_it() -> None:
    motor = BUNDLED["motor-pk566-5phase-half"]
    free = ruckig_reference(motor, 5000)
    jerk = 1e9
    limited = ruckig_reference(motor, 5000, j_max_pps3=jerk)
    assert limited.duration_s > free.duration_s
    assert_move(motor, 5000, limited, rel_tol=1e-9)
    da = np.diff(limited.a_pps2)
    dt = np.diff(limited.t_s)
    assert np.all(np.abs(da) <= jerk * dt * (1 + 1e-6) + 1e-6)
    # the motor's own jerk limit is used by default
    with_jerk = Motor(**{**_motor_kwargs(motor), "max_jerk_pps3": jerk})
    assert ruckig_reference(with_jerk, 5000).duration_s == pytest.approx(limited.duration_s)


def _motor_kwargs(motor: Motor) -> dict[str, object]:
    return {f: getattr(motor, f) for f in motor.__dataclass_fields__}


def test_ruckig_bad_arguments() -> None:
    motor = BUNDLED["motor-nema17-1600"]
    with pytest.raises(FieldRangeError, match=r"^v_max_pps: "):
        ruckig_reference(motor, 100, v_max_pps=1e9)
    with pytest.raises(FieldRangeError, match=r"^a_max_pps2: "):
        ruckig_reference(motor, 100, a_max_pps2=-1.0)
    with pytest.raises(FormatError, match=r"^bound: "):
        ruckig_reference(motor, 100, bound="tight")


def test_ruckig_explicit_limits_are_used() -> None:
    motor = flat_motor()
    ref = ruckig_reference(motor, 1000, v_max_pps=2000.0, a_max_pps2=1e5)
    assert ref.v_pps.max() == pytest.approx(2000.0)
    assert np.max(np.abs(ref.a_pps2)) == pytest.approx(1e5)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(BUNDLED))
@pytest.mark.parametrize("n", [2000, 100_000])
def test_toppra_within_0p2_percent_of_exact(name: str, n: int) -> None:
    motor = BUNDLED[name]
    exact = exact_optimum(motor, n).duration_s
    ref = toppra_reference(motor, n)
    # interpolation discretisation holds the constraint at both interval ends, so the
    # result is feasible and therefore never faster than the exact optimum
    assert exact * (1 - 1e-9) <= ref.duration_s <= exact * 1.002
    assert_move(motor, n, ref)


@pytest.mark.slow  # a toppra solve; CI runs it
def test_toppra_short_move() -> None:
    motor = BUNDLED["motor-nema17-1600"]
    ref = toppra_reference(motor, 10, gridpoints=200)
    assert ref.duration_s == pytest.approx(exact_optimum(motor, 10).duration_s, rel=5e-3)
    assert_move(motor, 10, ref)


def test_toppra_bad_gridpoints() -> None:
    with pytest.raises(FieldRangeError, match=r"^gridpoints: "):
        toppra_reference(flat_motor(), 10, gridpoints=3)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(BUNDLED))
@pytest.mark.parametrize("n", [2000, 100_000])
def test_casadi_without_jerk_within_0p2_percent_of_exact(name: str, n: int) -> None:
    motor = BUNDLED[name]
    exact = exact_optimum(motor, n).duration_s
    ref = casadi_reference(motor, n)
    assert ref.duration_s == pytest.approx(exact, rel=2e-3)
    assert_move(motor, n, ref)


@pytest.mark.slow
def test_casadi_jerk_limited_sits_between_exact_and_ruckig() -> None:
    motor = BUNDLED["motor-pk566-5phase-half"]
    jerk = 1e9
    ref = casadi_reference(motor, 2000, jerk=jerk)
    exact = exact_optimum(motor, 2000).duration_s
    ruck = ruckig_reference(motor, 2000, j_max_pps3=jerk).duration_s
    assert exact < ref.duration_s <= ruck
    assert_move(motor, 2000, ref)
    assert ref.a_pps2[0] == pytest.approx(0, abs=1e-6 * jerk) and \
        ref.a_pps2[-1] == pytest.approx(0, abs=1e-6 * jerk)
    assert np.all(np.abs(np.diff(ref.a_pps2)) <= jerk * np.diff(ref.t_s) * (1 + 1e-6) + 1e-3)


def test_casadi_bad_arguments() -> None:
    with pytest.raises(FieldRangeError, match=r"^intervals: "):
        casadi_reference(flat_motor(), 10, intervals=2)
    with pytest.raises(FieldRangeError, match=r"^jerk: "):
        casadi_reference(flat_motor(), 10, jerk=0.0)


@pytest.mark.slow
def test_references_all_feasible_and_best_is_fastest() -> None:
    motor = BUNDLED["motor-nema23-heavy"]
    refs = references(motor, 5000)
    assert set(refs) == {"exact", "toppra", "ruckig", "casadi"}
    for ref in refs.values():
        assert is_feasible(ref), ref.info
        assert_move(motor, 5000, ref, rel_tol=CHECK_REL_TOL)
    best = best_reference(refs)
    assert best.duration_s == min(r.duration_s for r in refs.values())
    assert best.duration_s == pytest.approx(refs["exact"].duration_s, rel=2e-3)


def test_references_flags_violations_and_best_skips_them() -> None:
    motor = BUNDLED["motor-nema17-1600"]
    refs = references(motor, 3000, include=("ruckig",))
    assert set(refs) == {"exact", "ruckig"}
    assert all(is_feasible(r) for r in refs.values())
    # a reference that accelerates harder than the motor can is marked and skipped
    fast = ruckig_reference(motor, 3000, bound="optimistic")
    fast.info += "; " + "capability violated: " + capability_violation(
        motor, move_limits(motor, 3000), fast, rel_tol=CHECK_REL_TOL)
    assert not is_feasible(fast)
    assert best_reference({**refs, "fast": fast}) is refs["exact"]
    with pytest.raises(ReferenceSolveError):
        best_reference({"fast": fast})
    with pytest.raises(FormatError, match=r"^include: "):
        references(motor, 3000, include=("gurobi",))


def test_no_heavy_imports_at_module_level() -> None:
    import subprocess
    import sys

    code = ("import sys, verify.references; "
            "print(sorted(m for m in ('toppra', 'casadi', 'ruckig') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=str(ROOT))
    assert out.stdout.strip() == "[]"


def test_ruckig_speed_caps_span_the_start_to_the_limit() -> None:
    """Candidates lie above the start speed up to the limit, the curve's points among
    them; a limit at the start speed (a move that cannot speed up) is its only cap."""
    from verify.references.ruckig_ref import v_max_candidates

    motor = BUNDLED["motor-nema17-1600"]
    caps = v_max_candidates(motor, 1000.0, 20_000.0)
    assert caps[-1] == 20_000.0 and all(1000.0 < c <= 20_000.0 for c in caps)
    inside = motor.curve_speed_pps[(motor.curve_speed_pps > 1000) & (motor.curve_speed_pps < 2e4)]
    assert set(inside.tolist()) <= set(caps)
    assert v_max_candidates(motor, 1000.0, 1000.0) == [1000.0]
    assert v_max_candidates(motor, 1000.0, 1000.0 * (1 + 1e-10)) == [1000.0 * (1 + 1e-10)]
