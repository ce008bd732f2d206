"""One table for a machine's mix of move lengths (a duty cycle)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...errors import FieldRangeError, PlanError
from ...motor import Motor
from ..clock import Clock
from .free_curve import Plan, plan_free_curve
from .problem import check_plan_args


def plan_duty_cycle(motor: Motor, mix: list[tuple[int, float]], *, clock: Clock | None = None,
                    max_stages: int = 127, separate_decel: bool | None = None,
                    load_angle_deg: float | None = None,
                    candidates: int = 8) -> tuple[Plan, dict[int, float]]:
    """One table for a machine's mix of moves: `mix` is (pulses, weight) per move length.
    Minimises Σ weight × move time (as the chip runs each length) over tables planned for
    each length of the mix and for `candidates` lengths spread geometrically between the
    shortest and the longest: never worse on the mix than the plan for any single length
    of it. Returns the plan (its `duration_s` is the weighted time) and each length's
    time."""
    from ..execution import simulate_move

    if not mix:
        raise PlanError("the move mix is empty: give at least one pulses,weight row")
    for n, w in mix:
        check_plan_args(max_stages, n)
        if not 0.0 <= w <= 1e12:
            raise FieldRangeError(f"weight of the {n}-pulse move", w, 0, 10**12)
    if sum(w for _, w in mix) <= 0:
        raise PlanError("the move mix's weights sum to 0: give at least one positive weight")
    lengths = sorted({n for n, _ in mix})
    spread = np.geomspace(lengths[0], lengths[-1], candidates) if len(lengths) > 1 else ()
    targets = sorted(set(lengths) | {round(float(x)) for x in spread})
    best: tuple[float, Plan, dict[int, float]] | None = None
    for target in targets:
        try:
            plan = plan_free_curve(motor, clock=clock, max_stages=max_stages, pulses=target,
                                   separate_decel=separate_decel, load_angle_deg=load_angle_deg)
        except PlanError:
            continue  # e.g. too short a move for a table: the other candidates remain
        times = {n: simulate_move(plan.table, n).duration_s for n in lengths}
        total = sum(w * times[n] for n, w in mix)
        if best is None or total < best[0]:
            best = (total, plan, times)
    if best is None:
        raise PlanError("no table could be planned for any length of the mix")
    total, plan, times = best
    info = plan.info + f"; duty cycle of {len(mix)} move lengths: weighted time {total:.6g} s"
    return replace(plan, duration_s=total, pulses=None, info=info), times


