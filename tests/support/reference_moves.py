"""What the reference planners' tests (tests/verify/references/) share: the bundled
motors, a constant-torque motor whose optimum is plain kinematics, that optimum's time by
hand, and the checks every reference's move must pass."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from profiles.motor import Motor, bundled_motor_paths, load_motor
from verify.references import Reference, exact_optimum, move_limits
from verify.references._common import capability_violation

BUNDLED: dict[str, Motor] = {p.stem: load_motor(p) for p in bundled_motor_paths()}


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


def assert_move(motor: Motor, n: float, ref: Reference, rel_tol: float = 1e-6) -> None:
    """Starts and ends at v0, covers exactly 0…N, time runs forward, stays in capability."""
    lim = move_limits(motor, n)
    assert ref.v_pps[0] == pytest.approx(lim.v0_pps, rel=1e-9)
    assert ref.v_pps[-1] == pytest.approx(lim.v0_pps, rel=1e-9)
    assert ref.x_pulses[0] == 0 and ref.x_pulses[-1] == pytest.approx(n, rel=1e-12)
    assert np.all(np.diff(ref.t_s) >= 0)
    assert ref.t_s[-1] == pytest.approx(ref.duration_s, rel=1e-9)
    assert capability_violation(motor, lim, ref, rel_tol=rel_tol) == ""


def solved_against_exact(solve: Callable[[Motor, float], Reference], name: str,
                         n: int) -> tuple[Reference, float]:
    """The bundled motor `name`'s move of `n` pulses as `solve` plans it (its boundaries,
    length, time and capability checked by assert_move), and the exact optimum's time."""
    motor = BUNDLED[name]
    ref = solve(motor, n)
    assert_move(motor, n, ref)
    return ref, exact_optimum(motor, n).duration_s
