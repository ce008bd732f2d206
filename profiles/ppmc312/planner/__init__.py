"""Optimal stall-safe free-curve planner, baseline planner and clock choice.

Modules by algorithm: `problem` (the clock, the motor's limits as the DP sees them,
`Shaping`), `search` (grid, graph, DP, top search), `refine` (exact times, integer
refinement, jerk and switch-safe counts), `free_curve` (both LE variants, the table),
`tightening` (the load angle, where the rotor rings), `duty_cycle` (a mix of moves).

The planner chooses the stage rates of a PPMC-312 free curve (fastest first on
the wire, slowest first here) and their pulse counts so that the table obeys
the stall-safety criterion of `profiles.ppmc312.criterion` and the chip's free-curve rules,
and minimises the move time of `pulses`:

    T = Σ_{k<N} w_k / f_k + (pulses − Σ_{k<N} w_k) / f_N,

w_k being the pulses of stage k on the accel plus the decel side (the top
stage's own pulses run at f_N, exactly like the cruise, so they cancel), subject
to accel total + decel total ≤ pulses (the chip then runs a trapezoid that stays
on the planned staircase). For a fixed top speed f_N = 1/λ the cost is additive
over stages, w_k·(1/f_k − λ), and given the speeds the smallest legal counts are
optimal (an extra pulse below f_N only costs time), so the speeds are chosen by a
dynamic programme over a rate grid: state (stages used, rate), transition to a
faster rate within the jump limit, stage count

    n_k = max(2, ceil(256 / r_k), ceil((f_{k+1} − f_k)·f_k / A_k))

with A_k the exact minimum of the capability over [f_k, f_{k+1}]. Every DP run
also yields, for every other top rate, a real path whose exact time is known;
the top is searched by re-running the DP at the best top's λ (a smaller λ is a
Lagrange multiplier on the pulse budget, used when the budget binds). The grid
is every integer rate where speed resolution is coarse and a uniform speed
subset elsewhere; the result is then refined over exact integer rates.
"""

from ..criterion import switch_safe
from .duty_cycle import plan_duty_cycle
from .free_curve import plan, plan_baseline, plan_free_curve, plan_staircase, table_of
from .problem import Plan, Shaping, check_plan_args, choose_clock, make_problem, reference_pulses
from .tightening import tighten, tighten_uniform

__all__ = ["Plan", "Shaping", "check_plan_args", "choose_clock", "make_problem", "plan",
           "plan_baseline", "plan_duty_cycle", "plan_free_curve", "plan_staircase",
           "reference_pulses", "switch_safe", "table_of", "tighten", "tighten_uniform"]
