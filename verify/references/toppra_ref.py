"""toppra: time-optimal path parameterisation with the torque curve as a linear constraint.

The path is the move itself, normalised: s ∈ [0, 1] ↔ x = N·s, time τ = t/t_ref, so path
speed ṡ = v/v_ref and path acceleration u = a/a_ref. toppra wants constraints linear in
u and in x = ṡ²; the capability a_acc(v) is not linear in v², so each gridpoint gets the
tangent of a_acc (and a_dec) as a function of v² at the speed of the previous solution,
and the problem is solved again (re-linearised) a few times. Interpolation
discretisation (constraints held at both ends of every interval) on a cosine-clustered
grid; sampling under toppra's constant-acceleration assumption.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any

import numpy as np

from profiles.errors import ReferenceSolveError, require_int
from profiles.motor import Motor

from ._common import MoveLimits, Reference, move_limits

#: Re-linearisation rounds of the torque-curve tangents (5–6 converge to < 1e-5 in time).
TOPPRA_ITERATIONS = 6


def cosine_grid(count: int) -> np.ndarray:
    """`count` path points on [0, 1], clustered at both ends where the speed is lowest
    and the profile bends hardest."""
    s = 0.5 * (1.0 - np.cos(np.pi * np.arange(count) / (count - 1)))
    s[0], s[-1] = 0.0, 1.0
    return s


def _slopes(motor: Motor, f: Any, v: np.ndarray) -> np.ndarray:
    """d f/dv of a piecewise-linear capability at speeds v (the piece at or right of v)."""
    bps = motor.curve_speed_pps
    vals = f(bps)
    piece = np.clip(np.searchsorted(bps, v, side="right") - 1, 0, len(bps) - 2)
    return (vals[piece + 1] - vals[piece]) / (bps[piece + 1] - bps[piece])


def _tangent_rows(motor: Motor, lim: MoveLimits, sd: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Tangent (value, slope) in x = ṡ² of a_acc and a_dec, normalised, at path speeds sd.

    Returns arrays of shape (n, 2): column 0 for a_acc, column 1 for a_dec.
    dA/dx = (dA/dv)·v_ref²/(2·v)/a_ref with v = v_ref·sd.
    """
    v = np.minimum(sd * lim.v_ref_pps, lim.v_lim_pps)
    value = np.stack([motor.a_acc_pps2(v), motor.a_dec_pps2(v)], axis=1) / lim.a_ref_pps2
    dv = np.stack([_slopes(motor, motor.a_acc_pps2, v), _slopes(motor, motor.a_dec_pps2, v)],
                  axis=1)
    slope = dv * lim.v_ref_pps**2 / (2.0 * v[:, None]) / lim.a_ref_pps2
    return value, slope


def _solve_once(motor: Motor, lim: MoveLimits, grid: np.ndarray, sd_lin: np.ndarray
                ) -> np.ndarray:
    """One toppra solve with the tangents taken at path speeds `sd_lin`; returns ṡ."""
    import toppra
    from toppra.algorithm import ParameterizationReturnCode
    from toppra.constraint import (
        DiscretizationType,
        LinearConstraint,
        canlinear_colloc_to_interpolate,
    )

    value, slope = _tangent_rows(motor, lim, sd_lin)
    x_lin = sd_lin**2
    x_max = (lim.v_lim_pps / lim.v_ref_pps) ** 2
    n = len(grid)

    class TorqueCurveConstraint(LinearConstraint):
        """u ≤ A(x_i) + A'(x_i)(x − x_i) and −u ≤ D(x_i) + D'(x_i)(x − x_i)."""

        def __init__(self) -> None:
            super().__init__()
            self.discretization_type = DiscretizationType.Interpolation
            self.identical = False

        def compute_constraint_params(self, path: Any, gridpoints: np.ndarray,
                                      *args: Any, **kwargs: Any) -> tuple[Any, ...]:
            a = np.tile([1.0, -1.0], (n, 1))
            b = -slope
            c = -(value - slope * x_lin[:, None])
            f = np.tile(np.eye(2), (n, 1, 1))
            g = np.zeros((n, 2))
            xbound = np.tile([0.0, x_max], (n, 1))
            # toppra leaves the interpolation rewrite (rows of i and i+1 on stage i)
            # to each constraint; without it the ends of an interval go unchecked.
            # Its (…, xbound, ubound) order differs from this method's (…, ubound, xbound).
            rows = canlinear_colloc_to_interpolate(a, b, c, f, g, None, None, gridpoints)
            return (*rows[:5], None, xbound)

    algo = toppra.algorithm.TOPPRA([TorqueCurveConstraint()], _line_path(), gridpoints=grid,
                                   parametrizer="ParametrizeConstAccel")
    sd0 = lim.v0_pps / lim.v_ref_pps
    _, sd, _ = algo.compute_parameterization(sd0, sd0)
    if algo.problem_data.return_code != ParameterizationReturnCode.Ok or sd is None:
        raise ReferenceSolveError(f"toppra: parameterisation failed "
                                  f"({algo.problem_data.return_code})")
    return np.maximum(np.asarray(sd, dtype=float), 0.0)


def toppra_reference(motor: Motor, pulses: Any, *, gridpoints: int = 1000) -> Reference:
    """toppra time-optimal (jerk-free) move of `pulses` pulses from v0 to v0."""
    require_int("gridpoints", gridpoints, 10, 100_000)
    from toppra.parametrizer import ParametrizeConstAccel

    logging.getLogger("toppra").setLevel(logging.ERROR)  # it logs every solve at INFO
    start = time.perf_counter()
    lim = move_limits(motor, pulses)
    grid = cosine_grid(gridpoints)
    # First tangents at the speed cap; then at the previous solution's speeds. For a
    # capability convex in v² (falling pieces) every tangent lies below the curve, so
    # each round stays feasible and only gets faster.
    sd = np.full(gridpoints, lim.v_lim_pps / lim.v_ref_pps)
    durations: list[float] = []
    for _ in range(TOPPRA_ITERATIONS):
        sd = _solve_once(motor, lim, grid, np.maximum(sd, lim.v0_pps / lim.v_ref_pps))
        durations.append(float(np.sum(2 * np.diff(grid) / (sd[:-1] + sd[1:]))))
    solve_s = time.perf_counter() - start

    # Sample at the gridpoint times: constant path acceleration between gridpoints.
    traj = ParametrizeConstAccel(_line_path(), grid, sd)
    duration_n = durations[-1]
    t_n = np.concatenate([[0.0], np.cumsum(2 * np.diff(grid) / (sd[:-1] + sd[1:]))])
    t_n[-1] = min(t_n[-1], float(traj.duration))
    x = np.asarray(traj(t_n), dtype=float).reshape(-1) * lim.pulses
    x[0], x[-1] = 0.0, lim.pulses
    v = np.asarray(traj(t_n, 1), dtype=float).reshape(-1) * lim.v_ref_pps
    a = np.asarray(traj(t_n, 2), dtype=float).reshape(-1) * lim.a_ref_pps2
    change = abs(durations[-1] - durations[-2]) / durations[-1] if len(durations) > 1 else math.nan
    info = (f"toppra: {gridpoints} cosine gridpoints, {TOPPRA_ITERATIONS} linearisations, "
            f"last change {change:.2e}")
    return Reference(name="toppra", duration_s=duration_n * lim.t_ref_s, t_s=t_n * lim.t_ref_s,
                     x_pulses=x, v_pps=v, a_pps2=a, solve_s=solve_s, info=info)


def _line_path() -> Any:
    import toppra

    return toppra.SplineInterpolator([0.0, 1.0], [[0.0], [1.0]])
