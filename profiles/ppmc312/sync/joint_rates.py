"""line mode, rate choice: each follower's accel side on the common stage boundaries.

At each boundary every follower picks the floor or the ceiling of its ideal rate, the
one that leaves its position there closest to the line, carrying the error forward
(sigma-delta: rounding never accumulates). Its top rate is the one whose cruise lasts
closest to the leader's. Each step up stays within the motor's capability (the stage
before it is raised to its least count).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from ..limits import RATE_MAX, RATE_MIN
from .joint_stages import Joint


def choose_rate(rho: float, prev: int, miss: Callable[[int], float]) -> int:
    """The floor or ceiling of the ideal rate `rho` (faster than the stage before, `prev`)
    that `miss` scores lower; one faster than `prev` when neither fits."""
    options = {r for r in (math.floor(rho), math.ceil(rho)) if RATE_MIN <= r < prev}
    return min(options or {prev - 1}, key=miss)


def pulses_missed(ticks: float, due: float) -> Callable[[int], float]:
    """How far from `due` pulses a stage of `ticks` clock ticks at rate r ends."""
    return lambda r: abs(ticks / r - due)


def accel_side(joint: Joint, i: int, t_acc: Sequence[float], cruise_pulses: float,
               t_cruise: float, common: bool) -> tuple[list[int], list[int]] | None:
    """Axis i's rates and accel counts, slowest first, following the leader's accel stages
    of durations `t_acc` [s] and then cruising `cruise_pulses` in `t_cruise` [s] (None: a
    rate below the chip's least). `common`: a step's least is the larger of its accel and
    decel counts (an LE=0 table runs the same counts both ways)."""
    least, hz = joint.leasts[i], joint.clocks[i].hz
    v_lead = joint.v_lead
    rates: list[int] = []
    acc: list[int] = []
    tau = t_end = p_end = 0.0
    pos = 0
    for g in joint.groups[i]:
        t_end += sum(t_acc[f] for f in g)
        p_end += sum(t_acc[f] * v_lead[f] for f in g) * joint.scale[i]
        prev = rates[-1] if rates else RATE_MAX + 1
        rho = joint.ideal(i, g, t_acc)
        if g == [0]:   # the top: the rate whose cruise lasts closest to the leader's
            rr = choose_rate(rho, prev, lambda r: abs(cruise_pulses * r / hz - t_cruise))
        else:          # the rate that ends the stage closest to the line
            rr = choose_rate(rho, prev, pulses_missed((t_end - tau) * hz, p_end - pos))
        if rr < RATE_MIN:
            return None
        if rates:  # the step up to rr within the motor's capability
            pair = least(rates[-1], rr)
            low = max(pair) if common else pair[0]
            if acc[-1] < low:
                tau += (low - acc[-1]) * rates[-1] / hz
                pos += low - acc[-1]
                acc[-1] = low
        nn = max(round((t_end - tau) * hz / rr), least(rr, 0)[0])
        rates.append(rr)
        acc.append(nn)
        tau += nn * rr / hz
        pos += nn
    return rates, acc
