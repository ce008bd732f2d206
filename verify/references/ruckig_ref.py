"""ruckig: jerk-limited rest-to-rest with constant limits, a bracket of the optimum.

ruckig takes scalar limits only, so against a torque curve it brackets the optimum:
the smallest capability over the speeds used gives a stall-safe (feasible) upper
bound, the largest capability an infeasible lower bound. Solved in normalised units
(x/N, t/t_ref): in raw pulses ruckig fails on a few percent of moves.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from profiles.errors import (
    FormatError,
    ReferenceSolveError,
    StepRampError,
    echo,
    require_number,
)
from profiles.motor import Motor
from profiles.ruckig_move import RuckigMove, solve_move

from ._common import Reference, move_limits

#: Samples taken from a ruckig trajectory (plus its phase boundaries).
RUCKIG_SAMPLES = 2001


def max_over(motor: Motor, f: Any, lo: float, hi: float) -> float:
    """Largest value of a piecewise-linear capability over [lo, hi] (ends or curve points)."""
    bps = motor.curve_speed_pps
    speeds = np.concatenate([[lo, hi], bps[(bps > lo) & (bps < hi)]])
    return float(np.max(f(speeds)))


def _limit(name: str, value: float | None, lo: float, hi: float) -> float | None:
    if value is None:
        return None
    return float(require_number(name, value, lo, hi))


def v_max_candidates(motor: Motor, v0: float, v_lim: float) -> list[float]:
    """Speed caps to try: geometric between v0 and v_lim, plus the curve's points."""
    if v_lim <= v0 * (1 + 1e-9):
        return [v_lim]
    bps = motor.curve_speed_pps
    grid = np.geomspace(v0 * (1 + 1e-6), v_lim, 96)
    return sorted({*grid.tolist(), *bps[(bps > v0) & (bps < v_lim)].tolist(), v_lim})


def ruckig_reference(motor: Motor, pulses: Any, *, v_max_pps: float | None = None,
                     a_max_pps2: float | None = None, j_max_pps3: float | None = None,
                     bound: str = "feasible") -> Reference:
    """Jerk-limited ruckig move of `pulses` pulses from v0 to v0 with constant limits.

    bound="feasible": accelerate with min a_acc and brake with min a_dec over [v0, v_max],
    v_max (unless given) being the cap that makes this move fastest
    (stall-safe, an upper bound of the optimum's time). bound="optimistic": the largest
    a_acc and a_dec over [0, v_max] (infeasible in general: a lower bound of the jerk-free
    optimum). `a_max_pps2` overrides both directions. Jerk: `j_max_pps3`, else the motor's
    max_jerk_pps3, else none (ruckig's second-order mode: an exact trapezoid).
    """
    if bound not in ("feasible", "optimistic"):
        raise FormatError(f"bound: expected 'feasible' or 'optimistic', got {echo(bound)}")
    start = time.perf_counter()
    lim = move_limits(motor, pulses)
    v0 = lim.v0_pps
    v_given = _limit("v_max_pps", v_max_pps, v0, lim.v_lim_pps)
    a_given = _limit("a_max_pps2", a_max_pps2, 1e-9, 1e15)
    j_given = _limit("j_max_pps3", j_max_pps3, 1e-9, 1e18)
    jerk = j_given if j_given is not None else motor.max_jerk_pps3

    def limits(v_max: float) -> tuple[float, float]:
        if a_given is not None:
            return a_given, a_given
        if bound == "feasible":
            return (float(motor.min_a_acc_pps2(v0, v_max)),
                    float(motor.min_a_dec_pps2(v0, v_max)))
        return (max_over(motor, motor.a_acc_pps2, 0.0, v_max),
                max_over(motor, motor.a_dec_pps2, 0.0, v_max))

    def solve(v_max: float) -> RuckigMove:
        a_up, a_down = limits(v_max)
        try:
            return solve_move(lim.pulses, v_max_pps=v_max, a_up_pps2=a_up, a_down_pps2=a_down,
                              j_max_pps3=None if jerk is None else float(jerk), v0_pps=v0,
                              t_ref_s=lim.t_ref_s)
        except StepRampError as exc:
            raise ReferenceSolveError(str(exc)) from exc

    if v_given is not None or bound != "feasible" or a_given is not None:
        v_max = v_given if v_given is not None else lim.v_lim_pps
    else:
        # With constant limits, the feasible acceleration is the capability's minimum
        # over [v0, v_max]: a higher cap can make every move slower (down to nothing
        # near the speed where a_acc reaches 0). Choose the cap that gives the fastest
        # feasible move; one calculate takes about a microsecond.
        v_max = min(v_max_candidates(motor, v0, lim.v_lim_pps),
                    key=lambda v: solve(v).duration_s if limits(v)[0] > 0 else math.inf)
    a_up, a_down = limits(v_max)
    move = solve(v_max)
    solve_s = time.perf_counter() - start

    ends = move.phase_ends_s
    t_s = np.unique(np.concatenate([np.linspace(0.0, move.duration_s, RUCKIG_SAMPLES),
                                    ends[ends < move.duration_s]]))
    x, v, a = move.sample(t_s)
    x[-1] = lim.pulses
    v[0] = v[-1] = v0  # ruckig meets the boundary speeds to ~1e-12 relative; pin them
    jerk_txt = "none" if jerk is None else f"{jerk:.6g} pps³"
    info = (f"ruckig {bound}: v_max {v_max:.6g} pps, a +{a_up:.6g}/−{a_down:.6g} pps², "
            f"jerk {jerk_txt}")
    return Reference(name=f"ruckig-{bound}", duration_s=move.duration_s, t_s=t_s, x_pulses=x,
                     v_pps=v, a_pps2=a, solve_s=solve_s, info=info)
