"""The exact jerk-free time optimum: the physics bound every planner is compared with.

Speed-up follows v dv/dx = a_acc(v) from v0, slow-down v dv/dx = −a_dec(v) into v0,
capped at v_lim; the optimum is the lower envelope of the two. Between curve
points a(v) is linear, so time and distance over a speed interval have closed forms
(computed here with log1p and short series so that nearly constant a stays exact).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from profiles.errors import require_int
from profiles.motor import Motor

from ._common import MoveLimits, Reference, move_limits


def _log1p_over_z(z: np.ndarray) -> np.ndarray:
    """log1p(z)/z, with its limit 1 at z = 0."""
    small = np.abs(z) < 1e-4
    zs = np.where(small, 1.0, z)
    return np.where(small, 1 - z / 2 + z * z / 3 - z**3 / 4, np.log1p(zs) / zs)


def _h(z: np.ndarray) -> np.ndarray:
    """(z − log1p(z))/z², with its limit 1/2 at z = 0 (series where cancellation bites)."""
    small = np.abs(z) < 1e-3
    zs = np.where(small, 1.0, z)
    return np.where(small, 0.5 - z / 3 + z * z / 4 - z**3 / 5, (zs - np.log1p(zs)) / zs**2)


def interval_time_distance(v_nodes: np.ndarray, a_nodes: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray]:
    """Time and distance to change speed over each [v_k, v_k+1] with a(v) linear between.

    a must be > 0 at every node. With z = a_k+1/a_k − 1 and Δ = v_k+1 − v_k:
    dt = Δ/a_k · log1p(z)/z,  dx = v_k·dt + Δ²/a_k · (z − log1p(z))/z².
    """
    dv = np.diff(v_nodes)
    a1 = a_nodes[:-1]
    z = a_nodes[1:] / a1 - 1.0
    dt = dv / a1 * _log1p_over_z(z)
    dx = v_nodes[:-1] * dt + dv * dv / a1 * _h(z)
    return dt, dx


def _nodes(lo: float, hi: float, breakpoints: np.ndarray, count: int) -> np.ndarray:
    """`count` evenly spaced speeds over [lo, hi] plus the curve points inside."""
    inner = breakpoints[(breakpoints > lo) & (breakpoints < hi)]
    return np.unique(np.concatenate([np.linspace(lo, hi, max(count, 2)), inner]))


def _peak_speed(motor: Motor, lim: MoveLimits) -> float:
    """Highest speed of the optimum: where accelerating + braking distance equals N."""
    v0, v_lim, n = lim.v0_pps, lim.v_lim_pps, lim.pulses
    nodes = _nodes(v0, v_lim, motor.curve_speed_pps, 2)
    _, dx_acc = interval_time_distance(nodes, motor.a_acc_pps2(nodes))
    _, dx_dec = interval_time_distance(nodes, motor.a_dec_pps2(nodes))
    x_both = np.concatenate([[0.0], np.cumsum(dx_acc + dx_dec)])
    if x_both[-1] <= n:
        return v_lim
    k = int(np.searchsorted(x_both, n, side="right")) - 1
    lo, hi = float(nodes[k]), float(nodes[k + 1])
    base = float(x_both[k])

    acc_lo, acc_hi = float(motor.a_acc_pps2(lo)), float(motor.a_acc_pps2(hi))
    dec_lo, dec_hi = float(motor.a_dec_pps2(lo)), float(motor.a_dec_pps2(hi))
    slope_acc = (acc_hi - acc_lo) / (hi - lo)
    slope_dec = (dec_hi - dec_lo) / (hi - lo)

    def excess(v: float) -> float:
        return (base + _distance(lo, v, acc_lo, acc_lo + slope_acc * (v - lo))
                + _distance(lo, v, dec_lo, dec_lo + slope_dec * (v - lo)) - n)

    # Safeguarded Newton on a monotone closed form (d/dv = v/a_acc + v/a_dec):
    # converges in a handful of steps, falls back to halving if a step leaves the bracket.
    a, b = lo, hi
    v = 0.5 * (a + b)
    for _ in range(100):
        f = excess(v)
        if f < 0:
            a = v
        else:
            b = v
        slope = v / (acc_lo + slope_acc * (v - lo)) + v / (dec_lo + slope_dec * (v - lo))
        step = v - f / slope
        if abs(step - v) <= 1e-15 * v or b - a <= 4 * math.ulp(b):
            return step if a <= step <= b else v
        v = step if a < step < b else 0.5 * (a + b)
    return v


def _distance(v1: float, v2: float, a1: float, a2: float) -> float:
    """Scalar twin of `interval_time_distance`'s distance (for the peak-speed solve)."""
    dv = v2 - v1
    z = a2 / a1 - 1.0
    g = 1 - z / 2 + z * z / 3 - z**3 / 4 if abs(z) < 1e-4 else math.log1p(z) / z
    h = 0.5 - z / 3 + z * z / 4 - z**3 / 5 if abs(z) < 1e-3 else (z - math.log1p(z)) / (z * z)
    return v1 * dv / a1 * g + dv * dv / a1 * h


def exact_optimum(motor: Motor, pulses: Any, *, points: int = 4000) -> Reference:
    """Time-optimal jerk-free rest-to-rest move of `pulses` pulses (the test oracle).

    `points` samples (about half speeding up, half slowing down) plus the curve
    points; every sample is exact (closed form), `duration_s` is exact.
    """
    require_int("points", points, 4, 10_000_000)
    start = time.perf_counter()
    lim = move_limits(motor, pulses)
    v0, v_lim, n = lim.v0_pps, lim.v_lim_pps, lim.pulses
    v_peak = _peak_speed(motor, lim)
    bps = motor.curve_speed_pps

    v_up = _nodes(v0, v_peak, bps, points // 2)
    a_up = np.asarray(motor.a_acc_pps2(v_up), dtype=float)
    dt_up, dx_up = interval_time_distance(v_up, a_up)
    t_up = np.concatenate([[0.0], np.cumsum(dt_up)])
    x_up = np.concatenate([[0.0], np.cumsum(dx_up)])

    v_dn = _nodes(v0, v_peak, bps, points - points // 2)  # ascending; mirrored below
    a_dn = np.asarray(motor.a_dec_pps2(v_dn), dtype=float)
    dt_dn, dx_dn = interval_time_distance(v_dn, a_dn)
    tau_dn = np.concatenate([[0.0], np.cumsum(dt_dn)])  # time to brake from v to v0
    xi_dn = np.concatenate([[0.0], np.cumsum(dx_dn)])   # distance to brake from v to v0

    cruise_x = max(n - x_up[-1] - xi_dn[-1], 0.0) if v_peak >= v_lim else 0.0
    cruise_t = cruise_x / v_peak
    t_brake = t_up[-1] + cruise_t
    x_brake = x_up[-1] + cruise_x
    t_dn = t_brake + (tau_dn[-1] - tau_dn[::-1])
    x_dn = x_brake + (xi_dn[-1] - xi_dn[::-1])
    duration = float(t_dn[-1])

    t_s = np.concatenate([t_up, t_dn])
    x = np.concatenate([x_up, x_dn])
    v = np.concatenate([v_up, v_dn[::-1]])
    a = np.concatenate([a_up, -a_dn[::-1]])
    if cruise_x > 0:
        a[len(v_up) - 1] = 0.0  # the last speed-up sample opens the cruise
    x[-1] = n  # closed forms agree with N to rounding; pin the end exactly
    solve_s = time.perf_counter() - start
    info = (f"exact: v0 {v0:.6g} pps, peak {v_peak:.6g} pps (v_lim {v_lim:.6g}), "
            f"cruise {cruise_t:.6g} s")
    return Reference(name="exact", duration_s=duration, t_s=t_s, x_pulses=x, v_pps=v,
                     a_pps2=a, solve_s=solve_s, info=info)
